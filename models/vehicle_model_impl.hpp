// Template definitions of VehicleModel, included by the .cpp files that instantiate it (double in
// vehicle_model.cpp, the Jet in jet_instantiations.cpp).
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "load_distribution.hpp"
#include "magic_formula_tire_impl.hpp"
#include "scalar_utils.hpp"
#include "swerve/core/smoothing.hpp"
#include "swerve/kinematics/module_commands.hpp"
#include "swerve/models/vehicle_model.hpp"

namespace swerve {

template <typename T>
struct VehicleModel<T>::ForceSums {
  T fx_body{0.0};  // N, sum of contact forces, body frame
  T fy_body{0.0};
  T mz{0.0};       // N m, yaw moment about the CoM
  T wear{0.0};     // total wear rate of the modules
};

template <typename T>
VehicleModel<T>::VehicleModel(const VehicleParams& params, Fidelity fidelity)
    : params_((params.validate(), params)),
      fidelity_(fidelity),
      tire_(params.tire),
      modules_(params.layout.size()),
      state_size_(StateIndex::prefix_size(params.layout.size())) {
  static_loads_ = params_.static_normal_loads();
  if (fidelity_ == Fidelity::kPlant) {
    lag_ = params_.plant.actuator_lag;
    saturate_ = params_.plant.actuator_saturation;
    relaxation_ = params_.plant.relaxation_length > 0.0;
    load_transfer_ = params_.plant.load_transfer;
  }
  // Linearised slip dynamics about rolling: each tire acts like a damper of rate K_i / V on its
  // contact velocity (K_i = mu Fz_i max(Bx Cx, By Cy), isotropic), so the body's velocity modes
  // decay at the eigenvalues of M^-1/2 (sum K_i J_i^T J_i) M^-1/2 / V, J_i = [1 0 -y_i; 0 1 x_i]
  // about the CoM and M = diag(m, m, Iz). The largest one per unit speed sets the step limit.
  {
    const MagicFormulaParams& tire = params_.tire;
    const double slope =
        std::max(tire.mu_longitudinal() * tire.longitudinal.b * tire.longitudinal.c,
                 tire.mu_lateral() * tire.lateral.b * tire.lateral.c);
    Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();
    for (int i = 0; i < modules_; ++i) {
      const Eigen::Vector2d arm = params_.layout.position_body(i) - params_.center_of_mass_body;
      Eigen::Matrix<double, 2, 3> jacobian;
      jacobian << 1.0, 0.0, -arm.y(), 0.0, 1.0, arm.x();
      stiffness += slope * static_loads_[static_cast<std::size_t>(i)] * jacobian.transpose() * jacobian;
    }
    const Eigen::Vector3d inv_sqrt_mass(1.0 / std::sqrt(params_.mass), 1.0 / std::sqrt(params_.mass),
                                        1.0 / std::sqrt(params_.yaw_inertia));
    const Eigen::Matrix3d scaled = inv_sqrt_mass.asDiagonal() * stiffness * inv_sqrt_mass.asDiagonal();
    slip_rate_per_speed_ = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scaled).eigenvalues().maxCoeff();
  }
  if (lag_) state_size_ += 2 * modules_;
  if (relaxation_) state_size_ += 2 * modules_;
  if (load_transfer_) {
    // Quasi-static pitch/roll equilibrium about the CoM at height h (no suspension):
    //   sum (x_i - x_c) dFz_i = -h m a_x,   sum (y_i - y_c) dFz_i = -h m a_y,   sum dFz_i = 0,
    // solved least-norm like the static loads.
    const Eigen::MatrixXd p = detail::least_norm_load_matrix(params_);
    const double scale = -params_.cog_height.value_or(0.0) * params_.mass;
    for (Eigen::Index i = 0; i < p.rows(); ++i) {
      transfer_per_ax_.push_back(p(i, 1) * scale);
      transfer_per_ay_.push_back(p(i, 2) * scale);
    }
  }
}

template <typename T>
int VehicleModel<T>::wheel_speed_index(int module) const {
  return lag_ ? StateIndex::prefix_size(modules_) + module : -1;
}

template <typename T>
int VehicleModel<T>::steering_rate_index(int module) const {
  return lag_ ? StateIndex::prefix_size(modules_) + modules_ + module : -1;
}

template <typename T>
int VehicleModel<T>::transient_slip_ratio_index(int module) const {
  if (!relaxation_) return -1;
  return StateIndex::prefix_size(modules_) + (lag_ ? 2 * modules_ : 0) + 2 * module;
}

template <typename T>
int VehicleModel<T>::transient_slip_angle_index(int module) const {
  return relaxation_ ? transient_slip_ratio_index(module) + 1 : -1;
}

template <typename T>
double VehicleModel<T>::slip_time_constant(double contact_speed) const {
  const double speed = std::max(std::abs(contact_speed), params_.tire.slip_speed_epsilon);
  return speed / slip_rate_per_speed_;
}

template <typename T>
int VehicleModel<T>::recommended_substeps(double dt, double contact_speed) const {
  return std::max(1, static_cast<int>(std::ceil(dt / (2.0 * slip_time_constant(contact_speed)))));
}

template <typename T>
Eigen::Matrix<double, 3, 2> VehicleModel<T>::acceleration_per_module_force(int module) const noexcept {
  // Module i adds (fx, fy) to the force sums and arm x f to the yaw moment about the CoM; then
  // r_dot = Mz / Iz, vx_dot = Fx / m + r_dot c_y, vy_dot = Fy / m - r_dot c_x (derivative_at_steering).
  const Eigen::Vector2d arm = params_.layout.position_body(module) - params_.center_of_mass_body;
  const double cx = params_.center_of_mass_body.x();
  const double cy = params_.center_of_mass_body.y();
  const Eigen::RowVector2d yaw(-arm.y() / params_.yaw_inertia, arm.x() / params_.yaw_inertia);
  Eigen::Matrix<double, 3, 2> per_force;
  per_force.row(0) = Eigen::RowVector2d(1.0 / params_.mass, 0.0) + cy * yaw;
  per_force.row(1) = Eigen::RowVector2d(0.0, 1.0 / params_.mass) - cx * yaw;
  per_force.row(2) = yaw;
  return per_force;
}

template <typename T>
Eigen::VectorXd VehicleModel<T>::complete_state(const Eigen::VectorXd& prefix) const {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(state_size_);
  x.head(prefix.size()) = prefix;
  if (lag_) {
    for (int i = 0; i < modules_; ++i) {
      const Eigen::Vector2d& p = params_.layout.position_body(i);
      const Eigen::Vector2d v_contact =
          point_velocity<double>(prefix(StateIndex::kVx), prefix(StateIndex::kVy), prefix(StateIndex::kYawRate), p);
      x(wheel_speed_index(i)) =
          rolling_speed<double>(v_contact, prefix(StateIndex::steering(i))) / params_.layout.wheel_radius();
    }
  }
  return x;
}

template <typename T>
void VehicleModel<T>::module_actuators(const T* x, const T* u, int i, T* x_dot, T* steer_rate_out,
                                       T* omega_out) const noexcept {
  const ModuleLimits& limits = params_.layout.limits();
  const double radius = params_.layout.wheel_radius();
  const T& delta = x[StateIndex::steering(i)];
  // Steering: delta_dot = commanded (ideal) or lagged rate; the plant clamps and stops at the ends.
  T steer_command = u[InputIndex::steering_rate(i)];
  T wheel_command = u[InputIndex::wheel_speed(i)];
  if (saturate_) {
    steer_command = clamp_by_value<T>(steer_command, T(-limits.max_steering_rate), T(limits.max_steering_rate));
    const double max_omega = limits.max_drive_speed / radius;
    wheel_command = clamp_by_value<T>(wheel_command, T(-max_omega), T(max_omega));
  }
  T steer_rate = steer_command;
  T omega = wheel_command;
  if (lag_) {
    const int wi = wheel_speed_index(i);
    const int si = steering_rate_index(i);
    omega = x[wi];
    steer_rate = x[si];
    T omega_dot = (wheel_command - omega) / params_.actuators.drive_time_constant;
    if (saturate_) {
      const double max_alpha = limits.max_drive_acceleration / radius;
      omega_dot = clamp_by_value<T>(omega_dot, T(-max_alpha), T(max_alpha));
    }
    x_dot[wi] = omega_dot;
    x_dot[si] = (steer_command - steer_rate) / params_.actuators.steering_time_constant;
  }
  if (saturate_ && limits.has_steering_end_stops()) {
    const double d = scalar_value(delta);
    const double rate = scalar_value(steer_rate);
    if ((d >= limits.max_steering_angle && rate > 0.0) || (d <= limits.min_steering_angle && rate < 0.0)) {
      steer_rate = T(0.0);
    }
  }
  *steer_rate_out = steer_rate;
  *omega_out = omega;
}

// One module's contribution: wheel-frame slip (docs/paper.md, assumption 3), Magic Formula forces,
// rotation wheel -> body by delta_i, yaw moment about the CoM, wear (assumption 5), and the
// module's own state derivatives (steering angle, actuator and transient-slip states).
template <typename T>
void VehicleModel<T>::module_forces(const T* x, const T* u, int i, const T& fz, const double* steering_cos,
                                    const double* steering_sin, ForceSums* sums, ModuleDiagnostics<T>* diag,
                                    T* x_dot) const noexcept {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const double radius = params_.layout.wheel_radius();
  const Eigen::Vector2d& p = params_.layout.position_body(i);
  const T& vx = x[StateIndex::kVx];
  const T& vy = x[StateIndex::kVy];
  const T& r = x[StateIndex::kYawRate];
  const T& delta = x[StateIndex::steering(i)];

  T steer_rate, omega;
  module_actuators(x, u, i, x_dot, &steer_rate, &omega);
  x_dot[StateIndex::steering(i)] = steer_rate;

  // Contact-point velocity: body frame v + r z x p (zero scrub radius: steering does not move the
  // contact), then into the wheel frame by R(-delta).
  const Eigen::Matrix<T, 2, 1> v_contact = point_velocity<T>(vx, vy, r, p);
  const T c = steering_cos != nullptr ? T(steering_cos[i]) : cos(delta);
  const T s = steering_sin != nullptr ? T(steering_sin[i]) : sin(delta);
  const T u_wheel = c * v_contact.x() + s * v_contact.y();
  const T v_wheel = c * v_contact.y() - s * v_contact.x();
  const T tread_speed = radius * omega;
  const WheelSlip<T> slip = compute_wheel_slip(params_.tire, u_wheel, v_wheel, tread_speed);

  WheelSlip<T> sliding = slip;  // what the contact slides at: the power and wear come from it
  if (relaxation_) {
    // Transient slip, first order with relaxation length sigma (Pacejka 2012, sec. 7.2.2):
    //   sigma kappa'_dot = V (kappa - kappa'), V = sqrt(u^2 + V_r^2 + eps^2) (finite rate at rest).
    const int ki = transient_slip_ratio_index(i);
    const double eps = params_.tire.slip_speed_epsilon;
    const T rate = sqrt(u_wheel * u_wheel + tread_speed * tread_speed + T(eps * eps)) /
                   params_.plant.relaxation_length;
    x_dot[ki] = rate * (slip.slip_ratio - x[ki]);
    x_dot[ki + 1] = rate * (slip.slip_angle - x[ki + 1]);
    // The force comes from the transient slips, and so does the sliding: F times the kinematic slip
    // velocity would count the carcass' deflection (stored, then given back) as worn energy. It did:
    // a start from rest on agv_4wheel (relaxation 0.05 m) wore 0.10 J in 50 ms where the plant
    // without relaxation wore 0.003 J, with the body speed ringing past its command.
    sliding = transient_sliding(slip, x[ki], x[ki + 1]);
  }
  if (drive_dead(faults_, i)) {
    // A free wheel spins at its contact's speed along the wheel: no longitudinal slip, no Fx.
    sliding.slip_ratio = T(0.0);
    sliding.slip_velocity_x_wheel = T(0.0);
  }
  const T& kappa = sliding.slip_ratio;
  const T& alpha = sliding.slip_angle;
  // The floor's grip scales the peak D = mu Fz, so the curve keeps its shape (observe_friction_scales).
  const TireForces<T> f =
      tire_.forces(kappa, alpha, friction_scales_ != nullptr ? T(fz * friction_scales_[i]) : fz);
  const T fx_body = c * f.fx_wheel - s * f.fy_wheel;
  const T fy_body = s * f.fx_wheel + c * f.fy_wheel;
  const double arm_x = p.x() - params_.center_of_mass_body.x();
  const double arm_y = p.y() - params_.center_of_mass_body.y();
  const T power = frictional_power(f, sliding, params_.wear.model == WearModelKind::kFrictionalPower
                                                   ? params_.wear.smoothing
                                                   : 0.0);
  const T wear = wear_rate(params_.wear, f, sliding, fz);

  sums->fx_body += fx_body;
  sums->fy_body += fy_body;
  sums->mz += arm_x * fy_body - arm_y * fx_body;
  sums->wear += wear;
  if (diag != nullptr) {
    diag->slip_ratio = kappa;
    diag->slip_angle = alpha;
    diag->normal_load = fz;
    diag->fx_wheel = f.fx_wheel;
    diag->fy_wheel = f.fy_wheel;
    diag->fx_body = fx_body;
    diag->fy_body = fy_body;
    diag->slip_velocity_x_wheel = sliding.slip_velocity_x_wheel;
    diag->slip_velocity_y_wheel = sliding.slip_velocity_y_wheel;
    diag->frictional_power = power;
    diag->wear_rate = wear;
  }
}

template <typename T>
void VehicleModel<T>::add_caster_forces(const T* x, const T* ax_ay, ForceSums* sums) const noexcept {
  using std::sqrt;
  const T& vx = x[StateIndex::kVx];
  const T& vy = x[StateIndex::kVy];
  const T& r = x[StateIndex::kYawRate];
  const double eps = params_.tire.slip_speed_epsilon;
  for (std::size_t j = 0; j < params_.casters.size(); ++j) {
    const CasterParams& caster = params_.casters[j];
    const auto contact = static_cast<std::size_t>(modules_) + j;
    T fz = T(static_loads_[contact]);
    if (ax_ay != nullptr) {
      fz = fz + transfer_per_ax_[contact] * ax_ay[0] + transfer_per_ay_[contact] * ax_ay[1];
      if (scalar_value(fz) < 0.0) fz = T(0.0);
    }
    const Eigen::Matrix<T, 2, 1> v_caster = point_velocity<T>(vx, vy, r, caster.position_body);
    const T scale = -caster.rolling_resistance * fz / sqrt(v_caster.squaredNorm() + T(eps * eps));
    const T fx = scale * v_caster.x();
    const T fy = scale * v_caster.y();
    sums->fx_body += fx;
    sums->fy_body += fy;
    sums->mz += (caster.position_body.x() - params_.center_of_mass_body.x()) * fy -
                (caster.position_body.y() - params_.center_of_mass_body.y()) * fx;
  }
}

template <typename T>
ModelStatus VehicleModel<T>::check_finite(const T* x, const T* u, Eigen::Ref<Vector> x_dot) const noexcept {
  for (int k = 0; k < state_size_; ++k) {
    if (!detail::is_finite(x[k])) {
      x_dot.setConstant(T(detail::kQuietNaN));
      return ModelStatus::kNonFiniteState;
    }
  }
  for (int k = 0; k < input_size(); ++k) {
    if (!detail::is_finite(u[k])) {
      x_dot.setConstant(T(detail::kQuietNaN));
      return ModelStatus::kNonFiniteInput;
    }
  }
  return ModelStatus::kOk;
}

template <typename T>
ModelStatus VehicleModel<T>::derivative(const Eigen::Ref<const Vector>& x_in, const Eigen::Ref<const Vector>& u_in,
                                        Eigen::Ref<Vector> x_dot_out, ModuleDiagnostics<T>* diagnostics,
                                        T* total_wear_rate) const noexcept {
  return derivative_at_steering(x_in, u_in, nullptr, nullptr, x_dot_out, diagnostics, total_wear_rate);
}

template <typename T>
ModelStatus VehicleModel<T>::derivative_at_steering(const Eigen::Ref<const Vector>& x_in,
                                                    const Eigen::Ref<const Vector>& u_in, const double* steering_cos,
                                                    const double* steering_sin, Eigen::Ref<Vector> x_dot_out,
                                                    ModuleDiagnostics<T>* diagnostics,
                                                    T* total_wear_rate) const noexcept {
  using std::cos;
  using std::sin;
  using std::sqrt;
  if (x_in.size() != state_size_ || u_in.size() != input_size() || x_dot_out.size() != state_size_) {
    return ModelStatus::kInvalidArgument;
  }
  T* x_dot = x_dot_out.data();
  const T* x = x_in.data();
  const T* u = u_in.data();
  const ModelStatus inputs = check_finite(x, u, x_dot_out);
  if (inputs != ModelStatus::kOk) return inputs;

  const T& psi = x[StateIndex::kPsi];
  const T& vx = x[StateIndex::kVx];
  const T& vy = x[StateIndex::kVy];
  const T& r = x[StateIndex::kYawRate];
  const T cos_psi = cos(psi);
  const T sin_psi = sin(psi);
  x_dot[StateIndex::kX] = cos_psi * vx - sin_psi * vy;
  x_dot[StateIndex::kY] = sin_psi * vx + cos_psi * vy;
  x_dot[StateIndex::kPsi] = r;

  ForceSums sums;
  if (!load_transfer_) {
    for (int i = 0; i < modules_; ++i) {
      module_forces(x, u, i, T(static_loads_[static_cast<std::size_t>(i)]), steering_cos, steering_sin, &sums,
                    diagnostics != nullptr ? diagnostics + i : nullptr, x_dot);
    }
    add_caster_forces(x, nullptr, &sums);
  } else {
    // One fixed-point pass resolves the algebraic loop loads -> forces -> acceleration -> loads:
    // forces at the static loads give the CoM acceleration a = F / m (body frame), which sets the
    // transferred loads; the forces are then evaluated again at those loads.
    ForceSums first;
    for (int i = 0; i < modules_; ++i) {
      module_forces(x, u, i, T(static_loads_[static_cast<std::size_t>(i)]), steering_cos, steering_sin, &first, nullptr,
                    x_dot);
    }
    add_caster_forces(x, nullptr, &first);
    const T accel[2] = {first.fx_body / params_.mass, first.fy_body / params_.mass};
    for (int i = 0; i < modules_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      T fz = static_loads_[k] + transfer_per_ax_[k] * accel[0] + transfer_per_ay_[k] * accel[1];
      if (scalar_value(fz) < 0.0) fz = T(0.0);
      module_forces(x, u, i, fz, steering_cos, steering_sin, &sums, diagnostics != nullptr ? diagnostics + i : nullptr, x_dot);
    }
    add_caster_forces(x, accel, &sums);
  }

  // Rigid body about the CoM c, velocity states of the body origin (see the header):
  //   r_dot  = Mz / Iz
  //   vx_dot = Fx / m + r vy + r^2 c_x + r_dot c_y
  //   vy_dot = Fy / m - r vx + r^2 c_y - r_dot c_x
  const double cx = params_.center_of_mass_body.x();
  const double cy = params_.center_of_mass_body.y();
  const T r_dot = sums.mz / params_.yaw_inertia;
  x_dot[StateIndex::kYawRate] = r_dot;
  x_dot[StateIndex::kVx] = sums.fx_body / params_.mass + r * vy + r * r * cx + r_dot * cy;
  x_dot[StateIndex::kVy] = sums.fy_body / params_.mass - r * vx + r * r * cy - r_dot * cx;
  if (total_wear_rate != nullptr) *total_wear_rate = sums.wear;

  for (int k = 0; k < state_size_; ++k) {
    if (!detail::is_finite(x_dot[k])) return ModelStatus::kNonFiniteResult;
  }
  return ModelStatus::kOk;
}

}  // namespace swerve
