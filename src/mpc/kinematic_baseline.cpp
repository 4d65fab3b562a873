#include "swerve/mpc/kinematic_baseline.hpp"

#include <cmath>
#include <sstream>

#include "swerve/config/config_error.hpp"
#include "swerve/mpc/safe_stop.hpp"

namespace swerve {
namespace {

template <typename Value>
[[noreturn]] void reject(const std::string& field, const Value& value, const char* rule) {
  throw_invalid_field("BaselineOptions", field, value, rule);
}

Eigen::Matrix3d planar_rotation(double heading) {
  const double c = std::cos(heading), s = std::sin(heading);
  Eigen::Matrix3d m;
  m << c, -s, 0, s, c, 0, 0, 0, 1;
  return m;
}

// Validated before any member is sized from them (a horizon < 1 must throw, not allocate).
BaselineOptions validated(BaselineOptions options) {
  options.validate();
  return options;
}

}  // namespace

void BaselineOptions::validate() const {
  if (horizon < 1) reject("horizon", horizon, "must be >= 1");
  if (!std::isfinite(dt) || dt <= 0.0) reject("dt", dt, "must be finite and > 0");
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(pose_weight[i]) || pose_weight[i] < 0) reject("pose_weight", pose_weight.transpose(), "must be >= 0");
    if (!std::isfinite(twist_weight[i]) || twist_weight[i] < 0) reject("twist_weight", twist_weight.transpose(), "must be >= 0");
    if (!std::isfinite(rate_weight[i]) || rate_weight[i] < 0) reject("rate_weight", rate_weight.transpose(), "must be >= 0");
  }
  if (!(twist_weight.minCoeff() > 0.0 || rate_weight.minCoeff() > 0.0)) {
    reject("twist_weight", twist_weight.transpose(), "or rate_weight must be > 0 on every axis (the plan must be unique)");
  }
  if (!std::isfinite(terminal_scale) || terminal_scale < 0) reject("terminal_scale", terminal_scale, "must be >= 0");
  if (gauss_newton_iterations < 1) reject("gauss_newton_iterations", gauss_newton_iterations, "must be >= 1");
  if (!std::isfinite(flip_hysteresis) || flip_hysteresis < 0 || flip_hysteresis > kPi / 2) {
    reject("flip_hysteresis", flip_hysteresis, "must be in [0, pi/2]");
  }
}

KinematicBaseline::KinematicBaseline(const ModuleLayout& layout, std::shared_ptr<const Reference> reference,
                                     BaselineOptions options)
    : options_(validated(options)), kinematics_(layout), reference_(std::move(reference)), modules_(layout.size()),
      horizon_(options_.horizon), factorization_(3 * options_.horizon) {
  if (!reference_) throw ConfigError("KinematicBaseline.reference: must not be null");
  const int n3 = 3 * horizon_;
  drive_sign_ = planned_first_sign_ = Eigen::VectorXi::Ones(modules_);
  twists_ = Eigen::MatrixXd::Zero(3, horizon_);
  reference_poses_ = reference_twists_ = Eigen::MatrixXd::Zero(3, horizon_);
  inputs_ = Eigen::MatrixXd::Zero(2 * modules_, horizon_);
  prediction_jacobian_ = weighted_jacobian_ = hessian_ = Eigen::MatrixXd::Zero(n3, n3);
  gradient_ = solution_ = weights_ = free_response_ = target_ = Eigen::VectorXd::Zero(n3);
  module_states_ = ModuleStates(modules_);
  output_.modules = ModuleArray<ModuleCommand>(modules_);
  for (int k = 0; k < horizon_; ++k) {
    const double scale = k == horizon_ - 1 ? options_.terminal_scale : 1.0;
    weights_.segment<3>(3 * k) = scale * options_.pose_weight;
  }
}

void KinematicBaseline::reset() noexcept {
  drive_sign_.setOnes();
  twists_.setZero();
}

bool KinematicBaseline::plan_twists(const Eigen::Vector3d& pose_world, const Eigen::Vector3d& twist_body,
                                    const Eigen::Ref<const Eigen::MatrixXd>& reference_poses,
                                    const Eigen::Ref<const Eigen::MatrixXd>& reference_twists) noexcept {
  if (!pose_world.allFinite() || !twist_body.allFinite() || !reference_poses.allFinite() ||
      !reference_twists.allFinite()) {
    return false;
  }
  const double dt = options_.dt;
  // Headings for the rotations: the reference's yaw rate first, then the last iterate's.
  double psi = pose_world.z();
  for (int iteration = 0; iteration < options_.gauss_newton_iterations; ++iteration) {
    // Stacked prediction Y = Y0 + G U with the rotation of step j fixed at the iterate's heading.
    prediction_jacobian_.setZero();
    psi = pose_world.z();
    for (int j = 0; j < horizon_; ++j) {
      const Eigen::Matrix3d block = dt * planar_rotation(psi);
      for (int k = j; k < horizon_; ++k) prediction_jacobian_.block<3, 3>(3 * k, 3 * j) = block;
      psi += dt * (iteration == 0 ? reference_twists(2, j) : twists_(2, j));
    }
    // Targets: reference poses with headings unwrapped next to the predicted heading.
    double predicted_heading = pose_world.z();
    for (int k = 0; k < horizon_; ++k) {
      predicted_heading += dt * (iteration == 0 ? reference_twists(2, k) : twists_(2, k));
      target_.segment<3>(3 * k) = reference_poses.col(k);
      target_[3 * k + 2] = predicted_heading + wrap_angle(reference_poses(2, k) - predicted_heading);
      free_response_.segment<3>(3 * k) = pose_world;
    }
    // Normal equations: (G'WG + R + D'SD) U = G'W(T - Y0) + R U_ref + D'S d0.
    // Plain operands only, so Eigen's products need no temporaries (no allocation per cycle).
    weighted_jacobian_ = weights_.asDiagonal() * prediction_jacobian_;
    hessian_.noalias() = prediction_jacobian_.transpose() * weighted_jacobian_;
    target_ = weights_.cwiseProduct(target_ - free_response_);
    gradient_.noalias() = prediction_jacobian_.transpose() * target_;
    for (int k = 0; k < horizon_; ++k) {
      for (int a = 0; a < 3; ++a) {
        const int i = 3 * k + a;
        hessian_(i, i) += options_.twist_weight[a] + options_.rate_weight[a] * (k + 1 < horizon_ ? 2.0 : 1.0);
        if (k + 1 < horizon_) {
          hessian_(i, i + 3) -= options_.rate_weight[a];
          hessian_(i + 3, i) -= options_.rate_weight[a];
        }
        gradient_[i] += options_.twist_weight[a] * reference_twists(a, k);
        if (k == 0) gradient_[i] += options_.rate_weight[a] * twist_body[a];
      }
    }
    factorization_.compute(hessian_);
    if (factorization_.info() != Eigen::Success) return false;
    solution_ = gradient_;
    factorization_.solveInPlace(solution_);
    if (!solution_.allFinite()) return false;
    for (int k = 0; k < horizon_; ++k) twists_.col(k) = solution_.segment<3>(3 * k);
  }
  // Drive limits: the largest twist of the same direction that no module speed exceeds, reached
  // from the current twist no faster than the drive acceleration limit allows any module (the
  // plant's drives cannot do more, and a plan that ignores it overshoots).
  const ModuleLayout& layout = kinematics_.layout();
  const double max_speed = layout.limits().max_drive_speed;
  const double max_change = layout.limits().max_drive_acceleration * dt;
  Eigen::Vector3d previous = twist_body;
  for (int k = 0; k < horizon_; ++k) {
    Eigen::Vector3d limited;
    if (kinematics_.desaturate_twist(twists_.col(k), max_speed, DesaturationPriority::kProportional, &limited) ==
        KinematicsStatus::kOk) {
      twists_.col(k) = limited;
    }
    const Eigen::Vector3d change = twists_.col(k) - previous;
    double largest = 0.0;
    for (const Eigen::Vector2d& p : layout.positions_body()) {
      largest = std::max(largest, Eigen::Vector2d(change.x() - change.z() * p.y(), change.y() + change.z() * p.x()).norm());
    }
    if (largest > max_change) twists_.col(k) = previous + (max_change / largest) * change;
    previous = twists_.col(k);
  }
  return true;
}

void KinematicBaseline::module_inputs(const Eigen::Ref<const Eigen::VectorXd>& steering_angles,
                                      Eigen::Ref<Eigen::MatrixXd> inputs) noexcept {
  const ModuleLimits& limits = kinematics_.layout().limits();
  const double dt = options_.dt;
  const double radius = kinematics_.layout().wheel_radius();
  const bool end_stops = limits.has_steering_end_stops();
  const double hold_threshold = kinematics_.options().hold_speed_threshold;
  for (int i = 0; i < modules_; ++i) {
    double angle = steering_angles[i];
    int sign = drive_sign_[i];
    for (int k = 0; k < horizon_; ++k) {
      kinematics_.inverse(twists_.col(k), &module_states_);
      const double speed = module_states_[i].speed;
      double target = angle;
      double signed_speed = 0.0;
      if (speed > hold_threshold) {
        // The 180 deg flip: keep the current drive direction while its steering error stays within
        // 90 deg + hysteresis, else drive the other way round; never past an end stop.
        const double forward = module_states_[i].angle;
        const double reverse = wrap_angle(forward + kPi);
        const double error_same = std::abs(wrap_angle((sign > 0 ? forward : reverse) - angle));
        if (error_same > kPi / 2 + options_.flip_hysteresis) sign = -sign;
        target = sign > 0 ? forward : reverse;
        if (end_stops && (target < limits.min_steering_angle || target > limits.max_steering_angle)) {
          sign = -sign;
          target = sign > 0 ? forward : reverse;
        }
        signed_speed = sign * speed;
      }
      const double error = end_stops ? target - angle : wrap_angle(target - angle);
      const double rate = std::clamp(error / dt, -limits.max_steering_rate, limits.max_steering_rate);
      angle = end_stops ? angle + dt * rate : wrap_angle(angle + dt * rate);
      if (options_.cosine_scaling) signed_speed *= std::max(0.0, std::cos(target - angle));
      inputs(2 * i, k) = rate;
      inputs(2 * i + 1, k) = signed_speed / radius;
      if (k == 0) planned_first_sign_[i] = sign;
    }
  }
}

const ControlOutput& KinematicBaseline::step(const Eigen::Ref<const Eigen::VectorXd>& measured, double t) noexcept {
  output_.solve = SolveSummary{};
  const auto start = SolverClock::now();
  if (measured.size() != 6 + modules_ || !measured.allFinite() || !std::isfinite(t) ||
      !is_plausible_state(measured, kinematics_.layout())) {
    fill_safe_stop(kinematics_.layout(), options_.dt, measured, &output_.modules);
    output_.source = CommandSource::kSafeStop;
    output_.reason = "measured state rejected (wrong size, NaN/inf or implausible)";
    return output_;
  }
  for (int k = 0; k < horizon_; ++k) {
    const ReferenceSample sample = reference_->sample(t + (k + 1) * options_.dt);
    reference_poses_.col(k) = sample.pose_world;
    reference_twists_.col(k) = sample.twist_body;
  }
  if (!plan_twists(measured.head<3>(), measured.segment<3>(3), reference_poses_, reference_twists_)) {
    fill_safe_stop(kinematics_.layout(), options_.dt, measured, &output_.modules);
    output_.source = CommandSource::kSafeStop;
    output_.reason = "the kinematic plan failed";
    return output_;
  }
  module_inputs(measured.segment(6, modules_), inputs_);
  commit_first_step();
  for (int i = 0; i < modules_; ++i) {
    ModuleCommand& command = output_.modules[i];
    command.steering_rate = inputs_(2 * i, 0);
    command.steering_angle = wrap_angle(measured[6 + i] + options_.dt * command.steering_rate);
    command.wheel_speed = inputs_(2 * i + 1, 0);
  }
  output_.source = CommandSource::kOptimizer;
  output_.reason = "kinematic plan";
  output_.solve.status = SolveStatus::kConverged;
  output_.solve.reason = "closed-form Gauss-Newton solve";
  output_.solve.iterations = options_.gauss_newton_iterations;
  output_.solve.solve_time_s = std::chrono::duration<double>(SolverClock::now() - start).count();
  return output_;
}

}  // namespace swerve
