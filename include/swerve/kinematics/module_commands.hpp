// The body twist -> module command map, written once for every caller and every scalar type:
// Kinematics::command (hardware setpoints), the kinematic baseline (its plan's module inputs) and
// the prediction step (on ceres::Jet, with smooth limits, for the optimisers' derivatives).
// point_velocity gives a module's contact velocity, choose_drive_direction the 180 deg choice under
// a flip policy and the end stops, steering_rate_toward and drive_wheel_speed the inputs for one
// control period; module_commands chains them for a whole vehicle.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>

#include "swerve/core/scalar.hpp"
#include "swerve/core/smoothing.hpp"
#include "swerve/kinematics/module_faults.hpp"
#include "swerve/kinematics/module_layout.hpp"
#include "swerve/kinematics/module_state.hpp"
#include "swerve/kinematics/se2.hpp"

namespace swerve {

// Velocity of the body point `r_body` of a rigid body whose origin moves with (vx, vy) and turns
// at omega, all in the body frame: v + omega z x r.
template <typename T>
Eigen::Matrix<T, 2, 1> point_velocity(const T& vx, const T& vy, const T& omega, const Eigen::Vector2d& r_body) {
  return Eigen::Matrix<T, 2, 1>(vx - omega * r_body.y(), vy + omega * r_body.x());
}
template <typename T>
Eigen::Matrix<T, 2, 1> point_velocity(const Eigen::Matrix<T, 3, 1>& twist_body, const Eigen::Vector2d& r_body) {
  return point_velocity<T>(twist_body.x(), twist_body.y(), twist_body.z(), r_body);
}

// The component of `velocity` along a wheel heading `angle`: the speed a wheel rolls at without
// slip when its contact point moves with `velocity`.
template <typename T>
T rolling_speed(const Eigen::Matrix<T, 2, 1>& velocity, const T& angle) {
  using std::cos;
  using std::sin;
  return cos(angle) * velocity.x() + sin(angle) * velocity.y();
}

// How a module chooses between driving along its contact velocity and turning the other way round
// (heading + pi) with its wheel reversed.
enum class FlipPolicy {
  kNearest,     // the way round with less steering (WPILib's optimize): flip beyond 90 deg
  kHysteresis,  // keep the previous way round until keeping it needs more than 90 deg + band
};

template <typename T>
struct DriveDirection {
  T turn{0.0};        // rad: steering from the current angle to the chosen heading
  T other_turn{0.0};  // rad: steering to the other way round
  int sign = 1;       // +1: the wheel drives along the contact velocity; -1: reversed, heading + pi
  // kHysteresis only: the way round was kept inside the band (90 deg -+ band), where either needs
  // about a quarter turn and the other is reachable. A caller coordinating several modules (the
  // baseline turns them all the same way round) may take other_turn instead.
  bool in_band = false;
};

// rad: how far past an end stop a kept heading is held at the stop (hysteresis policy). At 45 deg
// the module still moves its contact point at cos 45 deg = 71 % of the wanted velocity along it;
// beyond, the swing to the other stop pays for itself. See docs/decisions/end-stop-hysteresis.md.
inline constexpr double kEndStopHold = kPi / 4;

// rad: the prediction's tie band (ModuleCommandRule::tie_band, choose_drive_direction's
// `tie_band`): a flip must save more steering than this, and a heading at most this far past an end
// stop is steered to the stop. A module whose contact velocity points about 90 deg from its wheel (a
// crab started with the wheels straight, a heading at a +-90 deg stop) otherwise chooses by the last
// digits of the twist: modules of one vehicle split, turn opposite ways with their wheels driving
// and yaw the body, which at the stops cannot be corrected. 0.15 rad costs at most 1 - cos 0.15 =
// 1.1 % of a wheel's speed. Hardware setpoints (Kinematics) keep WPILib's exact 90 deg (tie band 0).
// See docs/decisions/end-stop-hysteresis.md.
inline constexpr double kDirectionTieBand = 0.15;

// The way round for a module steered at `angle` whose contact velocity points along `heading`.
// `previous_sign` is the way round kept by kHysteresis (0: none yet, then the nearest); the band
// is `band` + `widening` above 90 deg and `band` below it. With end stops (limits not [-pi, pi])
// angles are absolute, turns are not wrapped, and a heading past a stop is never chosen while the
// other is reachable. `tie_band` (0: none): a near tie keeps the forward way round, and a heading that
// close past a stop counts as at the stop (kDirectionTieBand). `end_stop_hold`: how far past a stop
// kHysteresis holds a kept heading at the stop (kEndStopHold, for a rolling wheel).
template <typename T>
DriveDirection<T> choose_drive_direction(const T& heading, const T& angle, int previous_sign, FlipPolicy policy,
                                         double band, const ModuleLimits& limits, double widening = 0.0,
                                         double tie_band = 0.0, double end_stop_hold = kEndStopHold) {
  const bool end_stops = limits.has_steering_end_stops();
  // The heading half a turn from a wrapped one, wrapped, without another remainder.
  const auto opposite_of = [](const T& wrapped) -> T {
    return scalar_value(wrapped) > 0.0 ? wrapped - kPi : wrapped + kPi;
  };
  const auto reachable = [&](const T& target) {
    const double value = scalar_value(target);
    return !end_stops || (value >= limits.min_steering_angle && value <= limits.max_steering_angle);
  };
  // Targets are needed for the end stops only; without them every turn is wrapped.
  // A target just past a stop is taken at the stop (tie_band).
  const auto near_stop = [&](const T& target) -> T {
    const double value = scalar_value(target);
    if (value > limits.max_steering_angle && value <= limits.max_steering_angle + tie_band) {
      return T(limits.max_steering_angle);
    }
    if (value < limits.min_steering_angle && value >= limits.min_steering_angle - tie_band) {
      return T(limits.min_steering_angle);
    }
    return target;
  };
  // With a tie band the forward target may sit clamped at a stop, so the reverse one is taken
  // from the wrapped heading, not from it.
  const T wrapped = end_stops ? wrap_angle_of<T>(heading) : heading;
  const T forward = end_stops ? near_stop(wrapped) : heading;
  const T reverse = end_stops ? near_stop(opposite_of(wrapped)) : heading;
  const T turn_forward = end_stops ? T(forward - angle) : wrap_angle_of<T>(heading - angle);
  const T turn_reverse = end_stops ? T(reverse - angle) : opposite_of(turn_forward);
  const auto turn_of = [&](int s) -> const T& { return s > 0 ? turn_forward : turn_reverse; };
  const auto target_of = [&](int s) -> const T& { return s > 0 ? forward : reverse; };
  // The way round of less steering; a near tie (within tie_band) keeps the forward one. Without
  // end stops the two turns add up to half a turn, so this is "flip beyond 90 deg" (plus half the
  // band); with wide end stops an unwrapped turn can exceed 90 deg both ways round.
  int sign =
      std::abs(scalar_value(turn_reverse)) + tie_band < std::abs(scalar_value(turn_forward)) ? -1 : 1;
  bool in_band = false;
  // Hysteresis across an end stop: a kept heading up to kEndStopHold past a stop is steered to the
  // stop rather than swung half a turn to the other one. A heading that sits at a stop (crabbing at
  // 90 deg on +-90 deg steering) is on either side of it by the noise of a measurement, and a
  // tracking correction pushes it further; without the hold, modules split between the two stops,
  // or all swung across together with their wheels driving, for seconds.
  bool held_at_stop = false;
  const double hold = std::max(band, end_stop_hold);
  const auto within_band_past_stop = [&](const T& target) {
    const double value = scalar_value(target);
    return end_stops && value >= limits.min_steering_angle - hold && value <= limits.max_steering_angle + hold;
  };
  if (policy == FlipPolicy::kHysteresis && previous_sign != 0) {
    sign = previous_sign > 0 ? 1 : -1;
    const double kept = std::abs(scalar_value(turn_of(sign)));
    if (kept > kPi / 2 + band + widening && std::abs(scalar_value(turn_of(-sign))) < kept) {
      sign = -sign;
    } else {
      in_band = kept >= kPi / 2 - band && reachable(target_of(-sign));
    }
    held_at_stop = !reachable(target_of(sign)) && within_band_past_stop(target_of(sign));
  }
  if (!held_at_stop && !reachable(target_of(sign)) && reachable(target_of(-sign))) {
    sign = -sign;
    in_band = false;
  }
  DriveDirection<T> out;
  if (held_at_stop) {
    const double stop = scalar_value(target_of(sign)) > 0.0 ? limits.max_steering_angle : limits.min_steering_angle;
    out.turn = T(stop) - angle;
    out.other_turn = turn_of(-sign);
    out.sign = sign;
    out.in_band = in_band;
    return out;
  }
  out.turn = turn_of(sign);
  out.other_turn = turn_of(-sign);
  out.sign = sign;
  out.in_band = in_band;
  return out;
}

// Hard limits (hardware, the baseline) or the C1 blends of core/smoothing.hpp (the prediction,
// whose derivatives the gradient optimisers follow).
enum class LimitShape { kHard, kSmooth };

// Blend widths of the smooth limits, relative to each limit's scale.
inline constexpr double kRateLimitSmoothing = 0.1;    // x max steering rate
inline constexpr double kSpeedLimitSmoothing = 0.05;  // x max wheel speed
inline constexpr double kAlignmentSmoothing = 0.05;   // on cos(remaining steering error), at 0

// The steering rate that makes `turn` within dt, under the module's rate limit.
template <typename T>
T steering_rate_toward(const T& turn, double dt, const ModuleLimits& limits, LimitShape shape) {
  const double most = limits.max_steering_rate;
  if (shape == LimitShape::kSmooth) return soft_clamp<T>(turn / dt, -most, most, kRateLimitSmoothing * most);
  return clamp_by_value<T>(turn / dt, T(-most), T(most));
}

// The share of a wheel's speed that moves its contact point the way it should when `turn_left` of
// steering remains: cos(turn_left), 0 beyond 90 deg (the cosine scaling).
template <typename T>
T steering_alignment(const T& turn_left, LimitShape shape) {
  using std::cos;
  if (shape == LimitShape::kSmooth) return soft_max<T>(cos(turn_left), 0.0, kAlignmentSmoothing);
  return clamp_by_value<T>(cos(turn_left), T(0.0), T(1.0));
}

// Wheel speed (rad/s) for a signed contact speed (m/s) when `turn_left` of steering remains at the
// end of the period: scaled by steering_alignment when `align`, so a module still steering does
// not push sideways; limited to the drive speed.
template <typename T>
T drive_wheel_speed(const T& signed_speed, const T& turn_left, bool align, const ModuleLimits& limits,
                    double wheel_radius, LimitShape shape) {
  const double most = limits.max_drive_speed / wheel_radius;
  const T alignment = align ? steering_alignment<T>(turn_left, shape) : T(1.0);
  const T wheel_speed = signed_speed * alignment / wheel_radius;
  if (shape == LimitShape::kSmooth) return soft_clamp<T>(wheel_speed, -most, most, kSpeedLimitSmoothing * most);
  return clamp_by_value<T>(wheel_speed, T(-most), T(most));
}

// m/s: a module slower than this keeps its angle (its direction would be noise: the singularity
// hold). 1 mm/s is well below any useful command and well above the round-off of a zero twist.
inline constexpr double kHoldSpeed = 1e-3;

struct ModuleCommandRule {
  FlipPolicy flip = FlipPolicy::kNearest;
  double flip_hysteresis = 0.0;  // rad, kHysteresis only
  double tie_band = 0.0;         // rad: choose_drive_direction's (the prediction: kDirectionTieBand)
  LimitShape shape = LimitShape::kHard;
  bool align_wheel = true;       // drive_wheel_speed's cosine scaling
  // m/s: below it the singularity hold (kHoldSpeed), and the wheel rolls with the velocity's
  // component along the held angle.
  double hold_speed = kHoldSpeed;
  // Known faults (null: none). A module whose steering is stuck gets no steering rate, and its
  // wheel rolls with the contact velocity's component along its angle, as in the hold: driving it
  // anywhere else would only add longitudinal slip to the lateral drag it cannot avoid.
  const ModuleFaults* faults = nullptr;
};

// Module inputs that carry out `twist_body` over the next dt from the steering angles `angles`
// (n): inputs[2 i] is module i's steering rate (rad/s), inputs[2 i + 1] its wheel speed (rad/s).
// `previous_signs` (n, +1/-1/0) is read by kHysteresis and may be null for kNearest; the chosen
// signs are written to `signs` when it is not null.
template <typename T>
void module_commands(const ModuleLayout& layout, const Eigen::Matrix<T, 3, 1>& twist_body,
                     const Eigen::Ref<const Eigen::Matrix<T, Eigen::Dynamic, 1>>& angles, double dt,
                     const ModuleCommandRule& rule, Eigen::Ref<Eigen::Matrix<T, Eigen::Dynamic, 1>> inputs,
                     const int* previous_signs = nullptr, int* signs = nullptr) {
  using std::atan2;
  using std::sqrt;
  const ModuleLimits& limits = layout.limits();
  const double radius = layout.wheel_radius();
  for (int i = 0; i < layout.size(); ++i) {
    const Eigen::Matrix<T, 2, 1> velocity = point_velocity<T>(twist_body, layout.position_body(i));
    const T& angle = angles[i];
    T rate(0.0), wheel_speed(0.0);
    int sign = previous_signs != nullptr ? previous_signs[i] : 0;
    if (!steering_stuck(rule.faults, i) &&
        std::hypot(scalar_value(velocity.x()), scalar_value(velocity.y())) >= rule.hold_speed) {
      const T speed = sqrt(velocity.squaredNorm());
      const DriveDirection<T> direction = choose_drive_direction<T>(atan2(velocity.y(), velocity.x()), angle, sign,
                                                                    rule.flip, rule.flip_hysteresis, limits,
                                                                    0.0, rule.tie_band);
      rate = steering_rate_toward<T>(direction.turn, dt, limits, rule.shape);
      // Drive only as fast as the wheel points the right way at the end of this step.
      wheel_speed = drive_wheel_speed<T>(static_cast<double>(direction.sign) * speed, direction.turn - rate * dt,
                                         rule.align_wheel, limits, radius, rule.shape);
      sign = direction.sign;
    } else {
      wheel_speed = drive_wheel_speed<T>(rolling_speed<T>(velocity, angle), T(0.0), false, limits, radius, rule.shape);
    }
    inputs[2 * i] = rate;
    inputs[2 * i + 1] = wheel_speed;
    if (signs != nullptr) signs[i] = sign;
  }
}

}  // namespace swerve
