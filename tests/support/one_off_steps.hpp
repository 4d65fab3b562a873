// A model's step and a problem's rollout on scratch made for the one call, so a test that steps once
// reads like the maths. Each allocates its PredictionData: not for code on the real-time path,
// which keeps its data (PredictionWorkspace) from construction.
#pragma once

#include <Eigen/Core>

#include <memory>

#include "swerve/ocp/ocp_problem.hpp"
#include "swerve/ocp/prediction_model.hpp"

namespace swerve::testing {

inline bool step_once(const PredictionModel& model, const Eigen::Ref<const Eigen::VectorXd>& x,
                      const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                      double* stage_wear) {
  const std::unique_ptr<PredictionData> data = model.create_data();
  return model.step(*data, x, u, dt, x_next, stage_wear);
}

inline bool step_jacobians_once(const PredictionModel& model, const Eigen::Ref<const Eigen::VectorXd>& x,
                                const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                                Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                                Eigen::Ref<Eigen::VectorXd> wear_gradient) {
  const std::unique_ptr<PredictionData> data = model.create_data();
  return model.step_jacobians(*data, x, u, dt, x_next, a, b, stage_wear, wear_gradient);
}

inline double rollout_once(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& inputs, int first_step,
                           Eigen::Ref<Eigen::MatrixXd> states, Eigen::Ref<Eigen::VectorXd> stage_costs,
                           double* stage_wear = nullptr) {
  const std::unique_ptr<PredictionData> data = problem.model().create_data();
  return problem.rollout(*data, inputs, first_step, states, stage_costs, stage_wear);
}

inline CostBreakdown evaluate_once(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                                   Eigen::Ref<Eigen::MatrixXd> states) {
  const std::unique_ptr<PredictionData> data = problem.model().create_data();
  return problem.evaluate(*data, inputs, states);
}

}  // namespace swerve::testing
