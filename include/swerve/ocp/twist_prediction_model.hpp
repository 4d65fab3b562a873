// The MPC's prediction model with the body twist as its input: each step maps the commanded twist
// (vx, vy, r) to per-module steering-rate and wheel-speed commands (inverse kinematics, the 180 deg
// choice nearest the current steering angle, the steering-rate limit, and the wheel speed scaled by
// the cosine of the steering error still left) and advances the dynamic model under them.
// Searching this 3-dimensional input instead of the 2n module rates keeps every candidate plan
// kinematically consistent (no module fighting another), which a sampling optimiser with a few
// hundred proposals per cycle cannot otherwise find; tire dynamics and wear still come from the
// full dynamic model, so the optimiser still trades tracking for wear.
#pragma once

#include <Eigen/Core>

#include "swerve/ocp/vehicle_prediction_model.hpp"

namespace swerve {

class TwistPredictionModel final : public PredictionModel {
 public:
  explicit TwistPredictionModel(const VehicleParams& params, PredictionOptions options = PredictionOptions{});

  int state_size() const noexcept override { return modules_.state_size(); }
  int input_size() const noexcept override { return 3; }
  std::unique_ptr<PredictionData> create_data() const override { return modules_.create_data(); }
  bool step(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
            const Eigen::Ref<const Eigen::VectorXd>& twist_body, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
            double* stage_wear) const noexcept override;
  void charge_work_to(const Clock* clock) noexcept override { modules_.charge_work_to(clock); }
  void observe_module_faults(const ModuleFaults* faults) noexcept override { modules_.observe_module_faults(faults); }
  void observe_friction_scales(const double* scales) noexcept override { modules_.observe_friction_scales(scales); }
  void observe_wear_weights(const double* weights) noexcept override { modules_.observe_wear_weights(weights); }
  bool has_jacobians() const noexcept override { return true; }
  bool step_jacobians(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                      const Eigen::Ref<const Eigen::VectorXd>& twist_body, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                      Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                      Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept override;

  // The module inputs (2n: steering rate, wheel speed per module) that carry out `twist_body` over
  // the next `dt` from state `x` (steering angles read from x). noexcept, no allocation.
  void module_inputs(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Vector3d& twist_body, double dt,
                     Eigen::Ref<Eigen::VectorXd> inputs) const noexcept {
    modules_.module_inputs(x, twist_body, dt, inputs);
  }

  const VehiclePredictionModel& module_model() const noexcept { return modules_; }

 private:
  VehiclePredictionModel modules_;
};

}  // namespace swerve
