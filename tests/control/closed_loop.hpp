// Test fixtures for the tracking controllers: a small 4-module vehicle, the dynamic model itself
// (ideal actuators) as the plant, straight-line and arc references, and a closed-loop runner that
// feeds a controller's commands to the plant and records tracking error and tire wear.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "support/model_fixtures.hpp"
#include "swerve/models/integrators.hpp"
#include "swerve/models/vehicle_model.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/control/tracking_controller.hpp"

namespace swerve::testing {

// 0.6 m x 0.5 m rectangle, wheel radius 0.1 m, 40 kg, plate inertia of the footprint (~2 kg m^2),
// drive 2 m/s and 2 m/s^2, steering 3 rad/s, default tire and frictional-power wear.
inline ModuleLimits small_robot_limits() {
  ModuleLimits limits;
  limits.max_drive_speed = 2.0;
  limits.max_drive_acceleration = 2.0;
  limits.max_steering_rate = 3.0;
  return limits;
}

inline VehicleParams small_robot() {
  VehicleParams params = make_params(ModuleLayout::rectangle(0.6, 0.5, 0.1, small_robot_limits()));
  params.name = "small_robot";
  params.mass = 40.0;
  params.yaw_inertia = 40.0 * (0.6 * 0.6 + 0.5 * 0.5) / 12.0;  // 2.03
  // The plant below is the model with ideal actuators, so the prediction must not expect lagged
  // drives either (it charges a command change only their share of the wear, VehiclePredictionModel).
  params.plant.actuator_lag = false;
  return params;
}

// At rest for `dwell` s at the origin (heading 0), then a start whose body twist ramps from rest to
// `twist` in 0.5 s and stays there, `seconds` in all: a pure translation (the heading stays 0, so the
// body frame is the world's) or a pure turn in place. Rows (t, x, y, psi, vx, vy, r) every 0.05 s,
// through the dwell too: the spline through the poses is global, and rows at the dwell's ends only
// would let it wander between them ahead of the start.
inline std::shared_ptr<const Reference> start_after_dwell(double dwell, const Eigen::Vector3d& twist, double seconds) {
  const double accelerate = 0.5;  // s to reach the twist
  std::vector<std::vector<double>> rows;
  for (double t = 0.0; t < dwell - 1e-9; t += 0.05) rows.push_back({t, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0});
  for (int k = 0; 0.05 * k <= seconds + 1e-9; ++k) {
    const double t = 0.05 * k;
    const double share = std::min(1.0, t / accelerate);  // of the twist, now
    const double travel = t < accelerate ? 0.5 * t * t / accelerate : t - 0.5 * accelerate;  // of it, integrated
    rows.push_back({dwell + t, travel * twist.x(), travel * twist.y(), travel * twist.z(), share * twist.x(),
                    share * twist.y(), share * twist.z()});
  }
  return std::make_shared<SampledReference>(rows);
}

// A start along the world direction `direction` at `speed` after the dwell.
inline std::shared_ptr<const Reference> line_after_dwell(double dwell, double direction, double speed) {
  return start_after_dwell(dwell, Eigen::Vector3d(speed * std::cos(direction), speed * std::sin(direction), 0.0), 1.0);
}

// Straight along +x from (0, lateral), 50 m.
inline std::shared_ptr<const Reference> line_reference(double speed, double acceleration = 1.0, double lateral = 0.0) {
  SpeedProfile profile;
  profile.speed = speed;
  profile.acceleration = acceleration;
  return std::make_shared<PathReference>(make_line_curve({0.0, lateral}, 0.0, 50.0), profile, 0.0);
}

// Counter-clockwise arc of radius 1.5 m from the origin heading +x (yaw rate speed / 1.5).
inline std::shared_ptr<const Reference> arc_reference(double speed, double acceleration = 1.0) {
  SpeedProfile profile;
  profile.speed = speed;
  profile.acceleration = acceleration;
  return std::make_shared<PathReference>(make_arc_curve({0.0, 0.0}, 0.0, 1.5, 2.0 * kPi), profile, 0.0);
}

// The plant: the same dynamic model the MPC predicts with (ideal actuators), integrated by RK4 with
// enough substeps to be stable at rest (the stiffest case).
class ModelPlant {
 public:
  ModelPlant(const VehicleParams& params, double dt)
      : model_(params, Fidelity::kIdeal), dynamics_(model_, IntegratorMethod::kRk4), dynamics_data_(dynamics_), dt_(dt),
        substeps_(model_.recommended_substeps(dt, 0.0)), next_(model_.state_size()) {}

  int substeps() const { return substeps_; }
  int modules() const { return model_.modules(); }

  // Applies the commands for one step; returns false if the model failed. Adds the step's wear.
  bool step(const ModuleArray<ModuleCommand>& commands, Eigen::VectorXd* state, double* total_wear) {
    Eigen::VectorXd u(2 * modules());
    for (int i = 0; i < modules(); ++i) {
      u[2 * i] = commands[i].steering_rate;
      u[2 * i + 1] = commands[i].wheel_speed;
    }
    double wear = 0.0;
    if (dynamics_.step(dynamics_data_, *state, u, dt_, substeps_, next_, &wear) != ModelStatus::kOk) return false;
    *state = next_;
    if (total_wear != nullptr) *total_wear += wear;
    return true;
  }

 private:
  VehicleModel<double> model_;
  DiscreteDynamics<double> dynamics_;
  DiscreteDynamics<double>::Data dynamics_data_;
  double dt_;
  int substeps_;
  Eigen::VectorXd next_;
};

struct ClosedLoopResult {
  bool model_ok = true;
  bool commands_finite = true;
  double final_position_error = NAN;  // m, at the end
  double final_heading_error = NAN;   // rad
  double worst_late_position_error = 0.0;  // m, over the last `settle_window` seconds
  double total_wear = 0.0;            // J (frictional-power wear)
  int optimizer_cycles = 0;
  int cycles = 0;
  int work_budget_cuts = 0;           // cycles with ControlOutput::work_budget_cut
  double longest_step_s = 0.0;        // ControlOutput::step_time_s, the longest
  Eigen::VectorXd final_state;
};

// Runs `controller` on the model plant from `initial_state` for `duration` seconds.
inline ClosedLoopResult run_closed_loop(TrackingController& controller, const Reference& reference,
                                        const VehicleParams& params, double dt, const Eigen::VectorXd& initial_state,
                                        double duration, double settle_window = 1.0) {
  ModelPlant plant(params, dt);
  ClosedLoopResult result;
  Eigen::VectorXd state = initial_state;
  const int steps = static_cast<int>(std::lround(duration / dt));
  for (int k = 0; k < steps; ++k) {
    const double t = k * dt;
    const ControlOutput& out = controller.step(state, t);
    ++result.cycles;
    if (out.source == CommandSource::kOptimizer) ++result.optimizer_cycles;
    if (out.work_budget_cut) ++result.work_budget_cuts;
    result.longest_step_s = std::max(result.longest_step_s, out.step_time_s);
    for (int i = 0; i < out.modules.size(); ++i) {
      const ModuleCommand& c = out.modules[i];
      if (!std::isfinite(c.steering_angle) || !std::isfinite(c.steering_rate) || !std::isfinite(c.wheel_speed)) {
        result.commands_finite = false;
      }
    }
    if (!plant.step(out.modules, &state, &result.total_wear)) {
      result.model_ok = false;
      break;
    }
    const ReferenceSample ref = reference.sample(t + dt);
    const double position_error = (state.head<2>() - ref.pose_world.head<2>()).norm();
    if (t + dt > duration - settle_window + 1e-9) {
      result.worst_late_position_error = std::max(result.worst_late_position_error, position_error);
    }
    result.final_position_error = position_error;
    result.final_heading_error = std::abs(wrap_angle(state[2] - ref.pose_world.z()));
  }
  result.final_state = state;
  return result;
}

inline bool all_finite(const ControlOutput& out) {
  for (int i = 0; i < out.modules.size(); ++i) {
    const ModuleCommand& c = out.modules[i];
    if (!std::isfinite(c.steering_angle) || !std::isfinite(c.steering_rate) || !std::isfinite(c.wheel_speed)) {
      return false;
    }
  }
  return true;
}

}  // namespace swerve::testing
