// Clocks for deterministic deadline tests (no wall-clock bound in ctest):
//   ManualClock: time moves only when the test (or a scripted solver) advances it.
//   WorkClock:   the library's clock that moves by a fixed cost per read; with ClockedModel, also by
//                each model evaluation, so a solve's "duration" is a count of work, identical on
//                every machine and under any load.
#pragma once

#include <memory>

#include "swerve/ocp/ocp_problem.hpp"
#include "swerve/ocp/prediction_model.hpp"
#include "swerve/ocp/deadline.hpp"

namespace swerve::testing {

class ManualClock final : public Clock {
 public:
  TimePoint now() const noexcept override { return now_; }
  void advance(Duration by) noexcept { now_ += by; }
  void advance_s(double seconds) noexcept { now_ += to_duration(seconds); }

 private:
  TimePoint now_{};  // the epoch: deadlines in tests are relative anyway
};

using ::swerve::WorkClock;  // the library's (swerve/ocp/deadline.hpp)

// A PredictionModel that charges every evaluation to a WorkClock: `step_cost_s` per step(),
// `jacobian_cost_s` per step_jacobians(). The wrapped model does the real work.
class ClockedModel final : public PredictionModel {
 public:
  ClockedModel(const PredictionModel& model, WorkClock* clock, double step_cost_s, double jacobian_cost_s)
      : model_(model), clock_(clock), step_cost_(to_duration(step_cost_s)), jacobian_cost_(to_duration(jacobian_cost_s)) {}

  int state_size() const noexcept override { return model_.state_size(); }
  int input_size() const noexcept override { return model_.input_size(); }
  int input_group_size() const noexcept override { return model_.input_group_size(); }
  bool has_jacobians() const noexcept override { return model_.has_jacobians(); }

  std::unique_ptr<PredictionData> create_data() const override { return model_.create_data(); }
  bool step(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
            double dt, Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept override {
    clock_->advance(step_cost_);
    ++steps_;
    return model_.step(data, x, u, dt, x_next, stage_wear);
  }
  bool step_jacobians(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                      const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                      Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                      Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept override {
    clock_->advance(jacobian_cost_);
    ++jacobian_steps_;
    return model_.step_jacobians(data, x, u, dt, x_next, a, b, stage_wear, wear_gradient);
  }
  long steps() const noexcept { return steps_; }
  long jacobian_steps() const noexcept { return jacobian_steps_; }

 private:
  const PredictionModel& model_;
  WorkClock* clock_;
  Duration step_cost_, jacobian_cost_;
  mutable long steps_ = 0, jacobian_steps_ = 0;
};

// The same problem (weights, bounds, state, reference) on another model, e.g. a ClockedModel.
inline std::unique_ptr<OcpProblem> problem_on(const PredictionModel& model, const OcpProblem& problem) {
  auto copy = std::make_unique<OcpProblem>(model, problem.horizon(), problem.dt(), problem.weights(), problem.bounds());
  copy->set_initial_state(problem.initial_state());
  copy->set_previous_input(problem.previous_input());
  for (int k = 1; k <= problem.horizon(); ++k) {
    copy->set_reference(k, problem.reference_poses().col(k - 1), problem.reference_twists().col(k - 1));
  }
  return copy;
}

}  // namespace swerve::testing
