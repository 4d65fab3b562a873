// The MPC's prediction model of a swerve vehicle: the dynamic model with ideal actuators (the
// paper's hierarchical design: the drives track steering-rate and wheel-speed commands), as a
// PredictionModel. Steering end stops are respected by clipping the steering rate.
//
// Tire forces make the body velocities very stiff (cornering stiffness B C D ~ 1e4 N/rad per wheel
// against a few hundred kg: time constants of milliseconds, shorter still near standstill where
// slip is regularised), so an explicit step at the controller's dt diverges. The default step is
// therefore semi-implicit: steering angles advance explicitly, the body twist solves the backward
// Euler equation v+ = v + dt a(v+, delta+, omega) by Newton's method, the pose follows the SE(2)
// exponential of v+ over dt.
//
// Stage wear. The tire transient that the implicit step steps over (milliseconds) is where most of
// the wear of a sudden command happens, so dt times the wear rate at (v+, delta+) misses it (up to
// 25x low at a start-up against the 1 kHz RK4 plant). For the frictional-power wear model (no
// casters) the stage wear is therefore k times the energy balance of the step: the drives' work
// minus the body's kinetic-energy gain, sum_i h Fx_i(v+) r omega_i - [KE(v+) - KE(v0)], exact for
// steady motion and equal to the linear-damper limit 1/2 m dv^2 for an impulsive change (the
// implicit forces' impulse h F(v+) is the body's momentum change). Otherwise (Archard wear, or
// casters): dt times the rate.
//
// Slow motion (body and every commanded contact speed under 0.25 m/s, five slip-regularisation
// speeds) takes `slow_substeps` (5) shorter steps: with one step there the stage wear was off by
// 6-20x either way against the RK4 plant (within 2 % with five), and the controller, fearing the
// wrong things at a start, lagged and wore twice the baseline's wear on a smoothly ramped curve
// (20.5 J against 10.4 J; 11.4 J with them). Faster motion keeps one step: start-ups and large
// command changes are within ~15 %, and five steps everywhere cost too many optimiser proposals.
// Explicit RK4 with substeps is kept for comparison.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <vector>

#include "swerve/models/integrators.hpp"
#include "swerve/models/vehicle_model.hpp"
#include "swerve/mpc/prediction_model.hpp"

namespace swerve {

enum class PredictionMethod { kSemiImplicit, kRk4 };
const char* to_string(PredictionMethod method) noexcept;  // "semi_implicit", "rk4"

struct PredictionOptions {
  PredictionMethod method = PredictionMethod::kSemiImplicit;
  int substeps = 1;              // per controller step (both methods)
  int slow_substeps = 5;         // semi-implicit, when body and commanded wheels are under 0.25 m/s
  int max_newton_iterations = 8; // semi-implicit only
  void validate() const;         // throws ConfigError
};

class VehiclePredictionModel final : public PredictionModel {
 public:
  VehiclePredictionModel(const VehicleParams& params, PredictionOptions options = PredictionOptions{});

  int state_size() const noexcept override { return state_size_; }
  int input_size() const noexcept override { return input_size_; }
  int input_group_size() const noexcept override { return 2; }  // (steering rate, wheel speed) per module
  bool step(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
            Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept override;

  const VehicleModel<double>& vehicle() const noexcept { return model_; }
  const PredictionOptions& options() const noexcept { return options_; }

 private:
  bool semi_implicit_substep(const Eigen::Ref<const Eigen::VectorXd>& x, double h, Eigen::Ref<Eigen::VectorXd> x_next,
                             double* wear) const noexcept;
  // Body acceleration (vx_dot, vy_dot, r_dot) at trial_state_ with twist `v`.
  bool body_acceleration(const Eigen::Vector3d& v, Eigen::Vector3d* acceleration, double* wear_rate) const noexcept;

  PredictionOptions options_;
  VehicleModel<double> model_;
  DiscreteDynamics<double> rk4_;
  int modules_, state_size_, input_size_;
  Eigen::VectorXd min_angle_, max_angle_;
  // Kinetic energy of the body (CoM translation + rotation) moving with twist v of the body origin.
  double kinetic_energy(const Eigen::Vector3d& v) const noexcept;

  bool energy_wear_;  // stage wear from the energy balance (see above)
  double wheel_radius_;
  mutable Eigen::VectorXd u_applied_, trial_state_, state_dot_, substep_state_;
  mutable std::vector<ModuleDiagnostics<double>> diagnostics_;
};

}  // namespace swerve
