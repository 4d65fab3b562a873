#include "swerve/kinematics/kinematics.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

// Rules named by the field alone (throw_invalid_field with no owner).
constexpr const char* kOwner = "";

bool finite3(const Eigen::Vector3d& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}
bool finite2(const Eigen::Vector2d& v) { return std::isfinite(v.x()) && std::isfinite(v.y()); }

bool finite_states(const ModuleStates& states) {
  for (const ModuleState& s : states) {
    if (!std::isfinite(s.speed) || !std::isfinite(s.angle)) return false;
  }
  return true;
}

// atan2 returns -pi for (-x, -0); the interfaces promise (-pi, pi].
double heading_of(double x, double y) {
  const double angle = std::atan2(y, x);
  return angle <= -kPi ? kPi : angle;
}

// theta + pi, wrapped, exactly (no remainder call): theta is already in (-pi, pi].
double opposite(double angle) { return angle > 0.0 ? angle - kPi : angle + kPi; }

void zero_states(int size, ModuleStates* states) {
  states->resize(size);
  for (ModuleState& s : *states) s = ModuleState{};
}

// Largest s in [0, 1] with |f + s g| <= limit, given |f| <= limit (the quadratic
// |g|^2 s^2 + 2 f.g s + |f|^2 - limit^2 <= 0 holds at s = 0; take its larger root).
double largest_feasible_scale(const Eigen::Vector2d& f, const Eigen::Vector2d& g, double limit) {
  const double gg = g.squaredNorm();
  if (gg <= 0.0) return 1.0;
  const double fg = f.dot(g);
  const double c = f.squaredNorm() - limit * limit;
  const double discriminant = std::max(0.0, fg * fg - gg * c);
  return std::clamp((-fg + std::sqrt(discriminant)) / gg, 0.0, 1.0);
}

}  // namespace

const OptionFields<KinematicsOptions>& KinematicsOptions::fields() {
  static const OptionFields<KinematicsOptions> table{
      {"hold_speed_threshold", &KinematicsOptions::hold_speed_threshold, Bound::positive()},
      {"flip_hysteresis", &KinematicsOptions::flip_hysteresis, Bound::right_open(0.0, kPi / 2.0), {}, nullptr,
       "(pi/2: a module would never flip)"},
      {"whole_robot_flip", &KinematicsOptions::whole_robot_flip},
      {"cosine_scaling", &KinematicsOptions::cosine_scaling},
  };
  return table;
}

void KinematicsOptions::validate() const { check_fields("KinematicsOptions", *this, fields()); }

Kinematics::Kinematics(ModuleLayout layout, KinematicsOptions options)
    : layout_(std::move(layout)), options_(options), size_(layout_.size()) {
  if (size_ > kMaxModules) {
    throw_invalid_field(kOwner, "Kinematics: ModuleLayout.modules", size_, "at most " + std::to_string(kMaxModules) + " modules supported");
  }
  options_.validate();
  double sum_r2 = 0.0;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  Eigen::MatrixXd stacked(2 * size_, 3);  // A, 2N x 3; construction may allocate
  for (int i = 0; i < size_; ++i) {
    const Eigen::Vector2d& r = layout_.position_body(i);
    positions_[static_cast<std::size_t>(i)] = r;
    stacked.row(2 * i) << 1.0, 0.0, -r.y();
    stacked.row(2 * i + 1) << 0.0, 1.0, r.x();
    sum_r2 += r.squaredNorm();
    centroid += r;
  }
  centroid /= size_;
  length_scale_ = std::sqrt(sum_r2 / size_);
  const Eigen::Matrix3d normal = stacked.transpose() * stacked;
  pseudo_inverse_.resize(3, 2 * size_);
  pseudo_inverse_ = normal.ldlt().solve(stacked.transpose());
  // Centred layouts make A^T A = diag(N, N, sum |r|^2), so the least-squares solution reduces to
  // means and a moment ratio; the tolerance keeps the two equal to round-off.
  centred_ = centroid.norm() <= 1e-12 * length_scale_;
  inv_sum_r2_ = 1.0 / sum_r2;
  inv_count_ = 1.0 / size_;
}

// ---- first order ---------------------------------------------------------------------------------

KinematicsStatus Kinematics::inverse(const Eigen::Vector3d& twist_body, ModuleStates* states,
                                     const Eigen::Vector2d& center_of_rotation_body) const noexcept {
  if (!finite3(twist_body) || !finite2(center_of_rotation_body)) {
    zero_states(size_, states);
    return KinematicsStatus::kNonFiniteInput;
  }
  states->resize(size_);
  for (int i = 0; i < size_; ++i) {
    const Eigen::Vector2d u = module_velocity(i, twist_body, center_of_rotation_body);
    const double speed = u.norm();
    (*states)[i] = ModuleState{speed, speed > 0.0 ? heading_of(u.x(), u.y()) : 0.0};
  }
  return KinematicsStatus::kOk;
}

KinematicsStatus Kinematics::command(const Eigen::Vector3d& twist_body, ModuleHeadingMemory* memory,
                                     ModuleStates* states, const Eigen::Vector2d& center_of_rotation_body,
                                     const ModuleStates* measured) const noexcept {
  auto fail = [&](KinematicsStatus status) {
    states->resize(size_);
    const bool memory_fits = memory->size() == size_;
    for (int i = 0; i < size_; ++i) (*states)[i] = ModuleState{0.0, memory_fits ? memory->angle(i) : 0.0};
    return status;
  };
  if (memory->size() != size_ || (measured != nullptr && measured->size() != size_)) {
    return fail(KinematicsStatus::kWrongModuleCount);
  }
  if (!finite3(twist_body) || !finite2(center_of_rotation_body) ||
      (measured != nullptr && !finite_states(*measured))) {
    return fail(KinematicsStatus::kNonFiniteInput);
  }
  // One fused pass of inverse -> desaturate -> hold, keeping each module's unit direction so the
  // flip decision below needs no trigonometry beyond the one atan2 per module.
  std::array<Eigen::Vector2d, kMaxModules> velocity;
  double fastest = 0.0;
  for (int i = 0; i < size_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    velocity[k] = module_velocity(i, twist_body, center_of_rotation_body);
    fastest = std::max(fastest, velocity[k].squaredNorm());
  }
  fastest = std::sqrt(fastest);
  const double max_speed = layout_.limits().max_drive_speed;
  const double scale = fastest > max_speed ? max_speed / fastest : 1.0;
  states->resize(size_);
  Directions directions;
  for (int i = 0; i < size_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const Eigen::Vector2d u = scale * velocity[k];
    const double speed = u.norm();
    if (speed >= options_.hold_speed_threshold) {
      directions.cos[k] = u.x() / speed;
      directions.sin[k] = u.y() / speed;
      (*states)[i] = ModuleState{speed, heading_of(u.x(), u.y())};
    } else {  // singularity hold: see hold_singular
      (*states)[i] = ModuleState{u.x() * memory->cos_angle(i) + u.y() * memory->sin_angle(i), memory->angle(i)};
    }
  }
  choose_flips(memory, states, directions, measured);
  return KinematicsStatus::kOk;
}

KinematicsStatus Kinematics::hold_singular(const ModuleHeadingMemory& memory, ModuleStates* states) const noexcept {
  if (memory.size() != size_ || states->size() != size_) return KinematicsStatus::kWrongModuleCount;
  if (!finite_states(*states)) return KinematicsStatus::kNonFiniteInput;
  for (int i = 0; i < size_; ++i) {
    ModuleState& s = (*states)[i];
    if (std::abs(s.speed) >= options_.hold_speed_threshold) continue;
    // Keep the velocity's component along the held heading: tiny, signed, and exactly what that
    // heading can deliver.
    const double projection =
        s.speed * (std::cos(s.angle) * memory.cos_angle(i) + std::sin(s.angle) * memory.sin_angle(i));
    s = ModuleState{projection, memory.angle(i)};
  }
  return KinematicsStatus::kOk;
}

KinematicsStatus Kinematics::optimize(ModuleHeadingMemory* memory, ModuleStates* states,
                                      const ModuleStates* measured) const noexcept {
  if (memory->size() != size_ || states->size() != size_) return KinematicsStatus::kWrongModuleCount;
  if (measured != nullptr && measured->size() != size_) return KinematicsStatus::kWrongModuleCount;
  if (!finite_states(*states) || (measured != nullptr && !finite_states(*measured))) {
    return KinematicsStatus::kNonFiniteInput;
  }
  Directions directions;
  for (int i = 0; i < size_; ++i) {
    ModuleState& s = (*states)[i];
    if (std::abs(s.speed) < options_.hold_speed_threshold) continue;
    s.angle = wrap_angle(s.angle);
    if (s.speed < 0.0) s = ModuleState{-s.speed, opposite(s.angle)};  // raw direction of travel
    const auto k = static_cast<std::size_t>(i);
    directions.cos[k] = std::cos(s.angle);
    directions.sin[k] = std::sin(s.angle);
  }
  choose_flips(memory, states, directions, measured);
  return KinematicsStatus::kOk;
}

void Kinematics::choose_flips(ModuleHeadingMemory* memory, ModuleStates* states, const Directions& directions,
                              const ModuleStates* measured) const noexcept {
  // Each moving module's way round by the shared rule (module_commands.hpp): the flip hysteresis
  // on its remembered decision, never past an end stop. The whole-robot mode decides one sign for
  // all, by the same rule on the mean steering error of the unflipped choice.
  const ModuleLimits& limits = layout_.limits();
  std::array<DriveDirection<double>, kMaxModules> chosen;
  double sum_error = 0.0;
  int moving_count = 0;
  for (int i = 0; i < size_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const ModuleState& state = (*states)[i];
    if (state.speed < options_.hold_speed_threshold) continue;  // held (or reversed) modules
    // The angle steered from: measured, else remembered; with neither the raw direction costs nothing.
    const double angle =
        measured != nullptr ? (*measured)[i].angle : (memory->known(i) ? memory->angle(i) : state.angle);
    const FlipPolicy policy = options_.whole_robot_flip ? FlipPolicy::kNearest : FlipPolicy::kHysteresis;
    chosen[k] = choose_drive_direction<double>(state.angle, angle, memory->drive_sign(i), policy,
                                               options_.flip_hysteresis, limits);
    if (options_.whole_robot_flip) {
      sum_error += std::abs(chosen[k].sign > 0 ? chosen[k].turn : chosen[k].other_turn);
      ++moving_count;
    }
  }
  int robot_sign = memory->robot_drive_sign();
  if (options_.whole_robot_flip && moving_count > 0) {
    const double error_of_unflipped = sum_error / moving_count;
    if (robot_sign == 0) {
      robot_sign = error_of_unflipped > kPi / 2.0 ? -1 : 1;
    } else {
      const double error_of_current = robot_sign > 0 ? error_of_unflipped : kPi - error_of_unflipped;
      if (error_of_current > kPi / 2.0 + options_.flip_hysteresis) robot_sign = -robot_sign;
    }
    memory->set_robot_drive_sign(robot_sign);
  }
  const bool scale_by_cosine = options_.cosine_scaling && measured != nullptr;
  for (int i = 0; i < size_; ++i) {
    ModuleState& state = (*states)[i];
    const auto k = static_cast<std::size_t>(i);
    if (state.speed < options_.hold_speed_threshold) {
      if (!memory->known(i) || memory->angle(i) != state.angle) memory->remember(i, state.angle, 0);
      continue;
    }
    DriveDirection<double>& direction = chosen[k];
    if (options_.whole_robot_flip && direction.sign != robot_sign) {
      std::swap(direction.turn, direction.other_turn);
      direction.sign = robot_sign;
    }
    const int sign = direction.sign;
    if (sign < 0) state = ModuleState{-state.speed, opposite(state.angle)};
    if (scale_by_cosine) state.speed *= steering_alignment<double>(direction.turn, LimitShape::kHard);
    memory->remember(i, state.angle, sign * directions.cos[k], sign * directions.sin[k], sign);
  }
}

KinematicsStatus Kinematics::desaturate(double max_speed, ModuleStates* states) noexcept {
  if (!std::isfinite(max_speed) || max_speed <= 0.0) return KinematicsStatus::kInvalidLimit;
  double fastest = 0.0;
  for (const ModuleState& s : *states) {
    if (!std::isfinite(s.speed)) return KinematicsStatus::kNonFiniteInput;
    fastest = std::max(fastest, std::abs(s.speed));
  }
  if (fastest > max_speed) {
    const double scale = max_speed / fastest;
    for (ModuleState& s : *states) s.speed *= scale;
  }
  return KinematicsStatus::kOk;
}

KinematicsStatus Kinematics::desaturate_twist(const Eigen::Vector3d& twist_body, double max_module_speed,
                                              DesaturationPriority priority, Eigen::Vector3d* twist_out,
                                              const Eigen::Vector2d& center_of_rotation_body) const noexcept {
  *twist_out = Eigen::Vector3d::Zero();
  if (!finite3(twist_body) || !finite2(center_of_rotation_body)) return KinematicsStatus::kNonFiniteInput;
  if (!std::isfinite(max_module_speed) || max_module_speed <= 0.0) return KinematicsStatus::kInvalidLimit;
  const Eigen::Vector3d translation(twist_body.x(), twist_body.y(), 0.0);
  const Eigen::Vector3d rotation(0.0, 0.0, twist_body.z());
  double fastest = 0.0;
  for (int i = 0; i < size_; ++i) {
    fastest = std::max(fastest, module_velocity(i, twist_body, center_of_rotation_body).norm());
  }
  const double proportional = fastest > max_module_speed ? max_module_speed / fastest : 1.0;
  if (priority == DesaturationPriority::kProportional || proportional >= 1.0) {
    *twist_out = twist_body * proportional;
    return KinematicsStatus::kOk;
  }
  const bool keep_rotation = priority == DesaturationPriority::kKeepRotation;
  const Eigen::Vector3d& kept = keep_rotation ? rotation : translation;
  const Eigen::Vector3d& shrunk = keep_rotation ? translation : rotation;
  double scale = 1.0;
  for (int i = 0; i < size_; ++i) {
    const Eigen::Vector2d f = module_velocity(i, kept, center_of_rotation_body);
    if (f.norm() > max_module_speed) {  // the kept part alone is too fast: nothing to prefer
      *twist_out = twist_body * proportional;
      return KinematicsStatus::kOk;
    }
    scale = std::min(scale, largest_feasible_scale(f, module_velocity(i, shrunk, center_of_rotation_body),
                                                   max_module_speed));
  }
  *twist_out = kept + scale * shrunk;
  return KinematicsStatus::kOk;
}

Eigen::Vector3d Kinematics::solve_unweighted(const double* u) const noexcept {
  if (centred_) {
    double sum_x = 0.0, sum_y = 0.0, moment = 0.0;
    for (int i = 0; i < size_; ++i) {
      const Eigen::Vector2d& r = positions_[static_cast<std::size_t>(i)];
      const double ux = u[2 * i];
      const double uy = u[2 * i + 1];
      sum_x += ux;
      sum_y += uy;
      moment += r.x() * uy - r.y() * ux;
    }
    return {sum_x * inv_count_, sum_y * inv_count_, moment * inv_sum_r2_};
  }
  return pseudo_inverse_ * Eigen::Map<const Eigen::VectorXd>(u, 2 * size_);
}

KinematicsStatus Kinematics::solve_weighted(const double* u, const ModuleWeights& weights,
                                            Eigen::Vector3d* xi) const noexcept {
  // Normal equations sum_i w_i A_i^T A_i xi = sum_i w_i A_i^T u_i, with the rotation column scaled
  // by the layout's length so the rank test compares like with like.
  const double l = length_scale_;
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (int i = 0; i < size_; ++i) {
    const double w = weights[i];
    if (!std::isfinite(w) || w < 0.0) return KinematicsStatus::kInvalidWeight;
    const double x = positions_[static_cast<std::size_t>(i)].x() / l;
    const double y = positions_[static_cast<std::size_t>(i)].y() / l;
    const double ux = u[2 * i];
    const double uy = u[2 * i + 1];
    normal(0, 0) += w;
    normal(1, 1) += w;
    normal(0, 2) -= w * y;
    normal(1, 2) += w * x;
    normal(2, 2) += w * (x * x + y * y);
    rhs += w * Eigen::Vector3d(ux, uy, x * uy - y * ux);
  }
  normal(2, 0) = normal(0, 2);
  normal(2, 1) = normal(1, 2);
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(normal);
  const Eigen::Vector3d pivots = ldlt.vectorD().cwiseAbs();
  if (!(pivots.maxCoeff() > 0.0) || pivots.minCoeff() < 1e-12 * pivots.maxCoeff()) {
    return KinematicsStatus::kRankDeficient;
  }
  Eigen::Vector3d scaled = ldlt.solve(rhs);
  scaled.z() /= l;
  *xi = scaled;
  return KinematicsStatus::kOk;
}

KinematicsStatus Kinematics::forward(const ModuleStates& states, Eigen::Vector3d* twist_body) const noexcept {
  *twist_body = Eigen::Vector3d::Zero();
  if (states.size() != size_) return KinematicsStatus::kWrongModuleCount;
  if (!finite_states(states)) return KinematicsStatus::kNonFiniteInput;
  std::array<double, 2 * kMaxModules> u;
  for (int i = 0; i < size_; ++i) {
    u[static_cast<std::size_t>(2 * i)] = states[i].speed * std::cos(states[i].angle);
    u[static_cast<std::size_t>(2 * i + 1)] = states[i].speed * std::sin(states[i].angle);
  }
  *twist_body = solve_unweighted(u.data());
  return KinematicsStatus::kOk;
}

KinematicsStatus Kinematics::forward(const ModuleStates& states, const ModuleWeights& weights,
                                     Eigen::Vector3d* twist_body) const noexcept {
  *twist_body = Eigen::Vector3d::Zero();
  if (states.size() != size_ || weights.size() != size_) return KinematicsStatus::kWrongModuleCount;
  if (!finite_states(states)) return KinematicsStatus::kNonFiniteInput;
  std::array<double, 2 * kMaxModules> u;
  for (int i = 0; i < size_; ++i) {
    u[static_cast<std::size_t>(2 * i)] = states[i].speed * std::cos(states[i].angle);
    u[static_cast<std::size_t>(2 * i + 1)] = states[i].speed * std::sin(states[i].angle);
  }
  return solve_weighted(u.data(), weights, twist_body);
}

KinematicsStatus Kinematics::forward_delta(const ModulePositions& deltas, Eigen::Vector3d* delta_body) const noexcept {
  ModuleStates as_states(size_);  // a distance over unit time is a speed: same linear map
  if (deltas.size() != size_) {
    *delta_body = Eigen::Vector3d::Zero();
    return KinematicsStatus::kWrongModuleCount;
  }
  for (int i = 0; i < size_; ++i) as_states[i] = ModuleState{deltas[i].distance, deltas[i].angle};
  return forward(as_states, delta_body);
}

KinematicsStatus Kinematics::forward_delta(const ModulePositions& deltas, const ModuleWeights& weights,
                                           Eigen::Vector3d* delta_body) const noexcept {
  ModuleStates as_states(size_);
  if (deltas.size() != size_) {
    *delta_body = Eigen::Vector3d::Zero();
    return KinematicsStatus::kWrongModuleCount;
  }
  for (int i = 0; i < size_; ++i) as_states[i] = ModuleState{deltas[i].distance, deltas[i].angle};
  return forward(as_states, weights, delta_body);
}

// ---- second order --------------------------------------------------------------------------------

KinematicsStatus Kinematics::second_order(const Eigen::Vector3d& twist_body, const Eigen::Vector3d& acceleration_body,
                                          const ModuleStates& states, ModuleAccelerations* accelerations,
                                          const Eigen::Vector2d& center_of_rotation_body) const noexcept {
  accelerations->resize(size_);
  for (ModuleAcceleration& a : *accelerations) a = ModuleAcceleration{};
  if (states.size() != size_) return KinematicsStatus::kWrongModuleCount;
  if (!finite3(twist_body) || !finite3(acceleration_body) || !finite_states(states) ||
      !finite2(center_of_rotation_body)) {
    return KinematicsStatus::kNonFiniteInput;
  }
  const double omega = twist_body.z();
  const double alpha = acceleration_body.z();
  const double eps2 = options_.hold_speed_threshold * options_.hold_speed_threshold;
  for (int i = 0; i < size_; ++i) {
    // Positions relative to the point c whose velocity and acceleration are given.
    const Eigen::Vector2d r = positions_[static_cast<std::size_t>(i)] - center_of_rotation_body;
    const Eigen::Vector2d u = module_velocity(i, twist_body, center_of_rotation_body);
    // a_i = a + alpha x r_i - omega^2 r_i: acceleration of a point fixed on a rigid body.
    const Eigen::Vector2d a_point(acceleration_body.x() - alpha * r.y() - omega * omega * r.x(),
                                  acceleration_body.y() + alpha * r.x() - omega * omega * r.y());
    // Rate of the body-frame components: remove the frame's own rotation, omega x u.
    const Eigen::Vector2d u_rate(a_point.x() + omega * u.y(), a_point.y() - omega * u.x());
    const double c = std::cos(states[i].angle);
    const double s = std::sin(states[i].angle);
    const double cross = u.x() * u_rate.y() - u.y() * u_rate.x();
    ModuleAcceleration& out = (*accelerations)[i];
    out.drive_acceleration = c * u_rate.x() + s * u_rate.y();
    out.steering_rate = cross / std::max(u.squaredNorm(), eps2);
    out.acceleration_body = a_point;
  }
  return KinematicsStatus::kOk;
}

KinematicsStatus Kinematics::chassis_acceleration(const ModuleStates& states, const ModuleAccelerations& accelerations,
                                                  Eigen::Vector3d* acceleration_body) const noexcept {
  *acceleration_body = Eigen::Vector3d::Zero();
  if (states.size() != size_ || accelerations.size() != size_) return KinematicsStatus::kWrongModuleCount;
  Eigen::Vector3d twist;
  const KinematicsStatus status = forward(states, &twist);
  if (status != KinematicsStatus::kOk) return status;
  const double omega = twist.z();
  std::array<double, 2 * kMaxModules> rhs;
  for (int i = 0; i < size_; ++i) {
    const ModuleAcceleration& m = accelerations[i];
    if (!std::isfinite(m.drive_acceleration) || !std::isfinite(m.steering_rate)) {
      return KinematicsStatus::kNonFiniteInput;
    }
    const double c = std::cos(states[i].angle);
    const double s = std::sin(states[i].angle);
    const double v = states[i].speed;
    // u' = v' h + v theta' n (body frame); back to the inertial point acceleration a_i = u' + omega x u,
    // then A_i (a, alpha) = a_i + omega^2 r_i.
    const double rate_x = m.drive_acceleration * c - v * m.steering_rate * s;
    const double rate_y = m.drive_acceleration * s + v * m.steering_rate * c;
    const Eigen::Vector2d& r = positions_[static_cast<std::size_t>(i)];
    rhs[static_cast<std::size_t>(2 * i)] = rate_x - omega * v * s + omega * omega * r.x();
    rhs[static_cast<std::size_t>(2 * i + 1)] = rate_y + omega * v * c + omega * omega * r.y();
  }
  *acceleration_body = solve_unweighted(rhs.data());
  return KinematicsStatus::kOk;
}

Eigen::Vector3d Kinematics::inertial_acceleration(const Eigen::Vector3d& twist_body,
                                                  const Eigen::Vector3d& twist_rate_body) noexcept {
  const double omega = twist_body.z();
  return {twist_rate_body.x() - omega * twist_body.y(), twist_rate_body.y() + omega * twist_body.x(),
          twist_rate_body.z()};
}

std::optional<ModuleStates> Kinematics::inverse(const Eigen::Vector3d& twist_body,
                                                const Eigen::Vector2d& center_of_rotation_body) const {
  ModuleStates states(size_);
  if (inverse(twist_body, &states, center_of_rotation_body) != KinematicsStatus::kOk) return std::nullopt;
  return states;
}

std::optional<Eigen::Vector3d> Kinematics::forward(const ModuleStates& states) const {
  Eigen::Vector3d twist;
  if (forward(states, &twist) != KinematicsStatus::kOk) return std::nullopt;
  return twist;
}

ModuleState optimize_module(const ModuleState& desired, double current_angle) noexcept {
  const double error = wrap_angle(desired.angle - current_angle);
  if (std::abs(error) <= kPi / 2.0) return ModuleState{desired.speed, wrap_angle(desired.angle)};
  return ModuleState{-desired.speed, wrap_angle(desired.angle + kPi)};
}

}  // namespace swerve
