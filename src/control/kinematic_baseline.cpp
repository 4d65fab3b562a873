#include "swerve/control/kinematic_baseline.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "swerve/core/config_error.hpp"
#include "swerve/control/safe_stop.hpp"

namespace swerve {
namespace {

// The owner every rule of this file names (throw_invalid_field: "<owner>.<field> = <value>: <rule>").
constexpr const char* kOwner = "BaselineOptions";

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

const OptionFields<BaselineOptions>& BaselineOptions::fields() {
  static const OptionFields<BaselineOptions> table{
      {"pose_weight", &BaselineOptions::pose_weight, Bound::non_negative()},
      {"twist_weight", &BaselineOptions::twist_weight, Bound::non_negative()},
      {"rate_weight", &BaselineOptions::rate_weight, Bound::non_negative()},
      {"terminal_scale", &BaselineOptions::terminal_scale, Bound::non_negative()},
      {"weights_step", &BaselineOptions::weights_step, Bound::non_negative(), {}, nullptr,
       "(s: the dt the weights are set for; 0: off)"},
      {"gauss_newton_iterations", &BaselineOptions::gauss_newton_iterations, Bound::closed(1, 100)},
      {"cosine_scaling", &BaselineOptions::cosine_scaling},
      // The same rule as KinematicsOptions.flip_hysteresis: at pi/2 a module would never flip.
      {"flip_hysteresis", &BaselineOptions::flip_hysteresis, Bound::right_open(0.0, kPi / 2), {}, nullptr,
       "(pi/2: never flip)"},
      {"steer_speed_threshold", &BaselineOptions::steer_speed_threshold, Bound::non_negative()},
      {"common_scaling", &BaselineOptions::common_scaling},
      {"pre_align", &BaselineOptions::pre_align},
      {"pre_align_only_with_end_stops", &BaselineOptions::pre_align_only_with_end_stops},
      {"pre_align_tolerance", &BaselineOptions::pre_align_tolerance, Bound::half_open(0.0, kPi / 2), {}, nullptr,
       "(rad)"},
      {"wait_for_arrival", &BaselineOptions::wait_for_arrival},
  };
  return table;
}

void BaselineOptions::validate() const {
  check_fields("BaselineOptions", *this, horizon_and_step_fields<BaselineOptions>());
  check_fields("BaselineOptions", *this, fields());
  if (!(twist_weight.minCoeff() > 0.0 || rate_weight.minCoeff() > 0.0)) {
    throw_invalid_field(kOwner, "twist_weight", twist_weight.transpose(), "or rate_weight must be > 0 on every axis (the plan must be unique)");
  }
  measurement_filter.validate();
  fault_detection.validate();
}

KinematicBaseline::KinematicBaseline(const ModuleLayout& layout, std::shared_ptr<const Reference> reference,
                                     BaselineOptions options, ActuatorLags lags)
    : options_(validated(options)), kinematics_(layout), reference_(std::move(reference)), modules_(layout.size()),
      horizon_(options_.horizon), heading_memory_(layout.size()), planned_memory_(layout.size()),
      latency_(layout, options_.dt, options_.measurement_filter, lags),
      detector_(layout, options_.dt, lags.steering, options_.fault_detection),
      lost_angles_(layout, options_.dt) {
  if (!reference_) throw ConfigError("KinematicBaseline.reference: must not be null");
  pre_aligns_ = options_.pre_align &&
                (!options_.pre_align_only_with_end_stops || layout.limits().has_steering_end_stops());
  twists_ = Eigen::MatrixXd::Zero(3, horizon_);
  reference_poses_ = reference_twists_ = Eigen::MatrixXd::Zero(3, horizon_);
  inputs_ = Eigen::MatrixXd::Zero(2 * modules_, horizon_);
  weights_ = target_ = Eigen::VectorXd::Zero(3 * horizon_);
  headings_ = Eigen::VectorXd::Zero(horizon_);
  feedback_ = Eigen::MatrixXd::Zero(3, 6 * horizon_);
  feedforward_ = Eigen::MatrixXd::Zero(3, horizon_);
  module_states_ = ModuleStates(modules_);
  planned_angles_ = planned_speeds_ = Eigen::MatrixXd::Zero(modules_, horizon_);
  steer_from_ = Eigen::MatrixXi::Constant(modules_, horizon_, -1);
  angles_ = Eigen::VectorXd::Zero(modules_);
  signs_ = Eigen::VectorXi::Ones(modules_);
  turn_left_ = signed_speeds_ = Eigen::VectorXd::Zero(modules_);
  for (int i = 0; i < modules_; ++i) max_module_radius_ = std::max(max_module_radius_, layout.position_body(i).norm());
  directions_ = ModuleArray<DriveDirection<double>>(modules_);
  now_ = Eigen::VectorXd::Zero(6 + modules_);
  output_.modules = ModuleArray<ModuleCommand>(modules_);
  size_module_faults(modules_);
  const StepRescale rescale = step_rescale(options_.dt, options_.weights_step);
  for (int k = 0; k < horizon_; ++k) {
    const double scale = k == horizon_ - 1 ? rescale.per_change * options_.terminal_scale : 1.0;
    weights_.segment<3>(3 * k) = scale * rescale.stage * options_.pose_weight;
  }
  twist_weight_ = rescale.stage * options_.twist_weight;
  rate_weight_ = rescale.per_change * options_.rate_weight;
}

void KinematicBaseline::reset() noexcept {
  heading_memory_.reset();
  planned_memory_.reset();
  twists_.setZero();
  twist_committed_ = false;
  aligning_ = true;
  awaiting_arrival_ = false;
  arrival_wait_steps_ = stalled_wait_steps_ = 0;
  reference_hold_.reset();
  latency_.reset();
  detector_.reset();  // the faults found stay: they are the hardware's
  lost_angles_.reset();
}

bool KinematicBaseline::plan_twists(const Eigen::Vector3d& pose_world, const Eigen::Vector3d& twist_body,
                                    const Eigen::Vector3d& last_command,
                                    const Eigen::Ref<const Eigen::MatrixXd>& reference_poses,
                                    const Eigen::Ref<const Eigen::MatrixXd>& reference_twists) noexcept {
  if (!pose_world.allFinite() || !twist_body.allFinite() || !last_command.allFinite() || !reference_poses.allFinite() ||
      !reference_twists.allFinite()) {
    return false;
  }
  const double dt = options_.dt;
  const Eigen::Matrix3d twist_weight = twist_weight_.asDiagonal();
  const Eigen::Matrix3d rate_weight = rate_weight_.asDiagonal();
  for (int iteration = 0; iteration < options_.gauss_newton_iterations; ++iteration) {
    // Headings for the rotations: the reference's yaw rate first, then the last iterate's. Targets:
    // reference poses with headings unwrapped next to the predicted heading.
    double psi = pose_world.z();
    for (int k = 0; k < horizon_; ++k) {
      headings_[k] = psi;
      psi += dt * (iteration == 0 ? reference_twists(2, k) : twists_(2, k));
      target_.segment<3>(3 * k) = reference_poses.col(k);
      target_[3 * k + 2] = psi + wrap_angle(reference_poses(2, k) - psi);
    }
    // With the headings fixed the problem is linear-quadratic in the twists. Solved by a Riccati
    // recursion over the augmented state z_k = (pose_k, u_k-1), in O(N) (a dense solve of the
    // 3N x 3N normal equations cost O(N^3): 13 s per step at N = 1000).
    //   z_k+1 = A z_k + B_k u_k, A = [I 0; 0 0], B_k = [dt R(psi_k); I]
    //   stage: |u_k - u_ref,k|^2_R + |u_k - L z_k|^2_S (L z = u_k-1), pose: |E z_k+1 - target_k|^2_Q
    // Value V_k(z) = z' P z - 2 p' z + c, V_N = the last pose term.
    Matrix6 value_hessian = Matrix6::Zero();
    Vector6 value_gradient = Vector6::Zero();
    const auto add_pose_cost = [&](int k) {
      value_hessian.topLeftCorner<3, 3>().diagonal() += weights_.segment<3>(3 * k);
      value_gradient.head<3>() += weights_.segment<3>(3 * k).cwiseProduct(target_.segment<3>(3 * k));
    };
    add_pose_cost(horizon_ - 1);
    for (int k = horizon_ - 1; k >= 0; --k) {
      Eigen::Matrix<double, 6, 3> b;
      b.topRows<3>() = dt * planar_rotation(headings_[k]);
      b.bottomRows<3>().setIdentity();
      // A' P A keeps P's pose block only; L' S L puts S on the previous-twist block.
      const Eigen::Matrix<double, 3, 6> pb_transposed = (value_hessian * b).transpose();
      const Eigen::Matrix3d quu = twist_weight + rate_weight + pb_transposed * b;
      Eigen::Matrix<double, 3, 6> quz = Eigen::Matrix<double, 3, 6>::Zero();
      quz.leftCols<3>() = pb_transposed.leftCols<3>();
      quz.rightCols<3>() = -rate_weight;
      const Eigen::Vector3d qu = twist_weight * reference_twists.col(k) + b.transpose() * value_gradient;
      Eigen::LDLT<Eigen::Matrix3d> quu_factor(quu);
      if (quu_factor.info() != Eigen::Success || !quu_factor.isPositive()) return false;
      const Eigen::Matrix<double, 3, 6> gain = -quu_factor.solve(quz);
      const Eigen::Vector3d feedforward = quu_factor.solve(qu);
      feedback_.block<3, 6>(0, 6 * k) = gain;
      feedforward_.col(k) = feedforward;
      // V_k = min_u Q: P = Qzz - Quz' Quu^-1 Quz, p = qz - Quz' Quu^-1 qu.
      Matrix6 next_hessian = Matrix6::Zero();
      next_hessian.topLeftCorner<3, 3>() = value_hessian.topLeftCorner<3, 3>();
      next_hessian.bottomRightCorner<3, 3>() = rate_weight;
      next_hessian += quz.transpose() * gain;
      Vector6 next_gradient = Vector6::Zero();
      next_gradient.head<3>() = value_gradient.head<3>();
      next_gradient -= quz.transpose() * feedforward;
      value_hessian = 0.5 * (next_hessian + next_hessian.transpose());
      value_gradient = next_gradient;
      if (k > 0) add_pose_cost(k - 1);
    }
    Vector6 z;
    z << pose_world, twist_body;
    for (int k = 0; k < horizon_; ++k) {
      const Eigen::Vector3d u = feedforward_.col(k) + feedback_.block<3, 6>(0, 6 * k) * z;
      twists_.col(k) = u;
      z.head<3>() += dt * planar_rotation(headings_[k]) * u;
      z.tail<3>() = u;
    }
    if (!twists_.allFinite()) return false;
  }
  // Drive limits from the ramp's start on (see within_drive_limits). The ramp starts from the last
  // command, but never further ahead of the measured twist than kRampLead periods of drive
  // acceleration at any module: lagging drives stay within that (a drive following a ramp trails
  // it by its time constant times the acceleration, 2 periods for the carriers' 0.1 s), and a
  // vehicle that is blocked or slips does not wind the command up.
  constexpr double kRampLead = 4.0;
  twist_body_ = twist_body;
  ramp_start_ = limit_change(twist_body, last_command, kRampLead * drive_change_per_step());
  Eigen::Vector3d previous = ramp_start_;
  for (int k = 0; k < horizon_; ++k) {
    twists_.col(k) = within_drive_limits(previous, twists_.col(k));
    previous = twists_.col(k);
  }
  // Armed here, before module_inputs(), so that this step's steering already follows the at-rest
  // rule.
  if (pre_aligns_) arm_pre_alignment(pose_world, twist_body, reference_poses.col(0), reference_twists.col(0));
  return true;
}

void KinematicBaseline::arm_pre_alignment(const Eigen::Vector3d& pose_world, const Eigen::Vector3d& twist_body,
                                           const Eigen::Vector3d& reference_pose,
                                           const Eigen::Vector3d& reference_twist) noexcept {
  // The pre-alignment arms at a start:
  // - at a stop: the vehicle at rest, with nothing planned or the reference at rest (slower than
  //   the steer threshold);
  // - at a dwell the vehicle has arrived at (arrived()), however it still moves. A controller
  //   closing a residual error, or easing into the next leg its horizon already sees, creeps
  //   through a short dwell at a few cm/s; with a speed bound alone, that creep decided whether an
  //   in-place turn after a crab was pre-aligned or driven about a far centre, off the path by
  //   metres. A dwell here is the reference standing still (below the kinematics' hold speed),
  //   not creeping: a reference that creeps at the threshold is a leg to drive, not a start. A
  //   vehicle that reaches the dwell far from its pose (lagging a turn) is still under way: holding
  //   it would stop it short with its modules aimed at the next leg.
  // Once the wheels drove on a moving reference, the vehicle tracks until the next start, so a
  // re-steer under way is not one.
  // wait_for_arrival: at a dwell the vehicle has not arrived at, the reference waits for it
  // (awaits_arrival()), and the stop rule does not arm meanwhile. A residual error closed first
  // leaves the modules to turn once, to the next leg; aligned to the next leg first, they turn back
  // to close the residual and again to the leg once it has begun, dragged sideways meanwhile. The
  // wait ends when the vehicle has stood one horizon without arriving (a residual it does not
  // close), or, still moving, after kMostWaitHorizons: a vehicle closing in keeps the reference,
  // one that circles the pose does not.
  constexpr int kMostWaitHorizons = 4;
  const bool dwell = slower_than(reference_twist, kHoldSpeed);
  const bool arrived_here = arrived(pose_world, reference_pose);
  awaiting_arrival_ = options_.wait_for_arrival && dwell && !arrived_here && stalled_wait_steps_ < horizon_ &&
                      arrival_wait_steps_ < kMostWaitHorizons * horizon_;
  if (!dwell) {
    arrival_wait_steps_ = stalled_wait_steps_ = 0;
  } else if (awaiting_arrival_) {
    ++arrival_wait_steps_;
    if (at_rest(twist_body)) ++stalled_wait_steps_;
  }
  const bool stop = at_rest(twist_body) && (at_rest(twists_.col(0)) || at_rest(reference_twist));
  if (awaiting_arrival_) {
    aligning_ = false;  // a run's start short of its first pose waits too
  } else if (stop || (dwell && arrived_here)) {
    aligning_ = true;
  }
}

double KinematicBaseline::rest_speed() const noexcept { return std::max(options_.steer_speed_threshold, kHoldSpeed); }

bool KinematicBaseline::slower_than(const Eigen::Vector3d& twist_body, double speed) const noexcept {
  return twist_body.head<2>().norm() < speed && std::abs(twist_body.z()) * max_module_radius_ < speed;
}

bool KinematicBaseline::arrived(const Eigen::Vector3d& pose_world, const Eigen::Vector3d& reference_pose) const noexcept {
  // The farthest any module is from where the reference puts it (to first order in the heading
  // error), against the distance the steer threshold's speed covers in one horizon.
  const double position_error = (reference_pose.head<2>() - pose_world.head<2>()).norm();
  const double heading_error = std::abs(wrap_angle(reference_pose.z() - pose_world.z()));
  return position_error + heading_error * max_module_radius_ < rest_speed() * horizon_ * options_.dt;
}

double KinematicBaseline::drive_change_per_step() const noexcept {
  return kinematics_.layout().limits().max_drive_acceleration * options_.dt;
}

Eigen::Vector3d KinematicBaseline::limit_change(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                                double most) const noexcept {
  // `to`, or the twist towards it from `from` whose change moves no module's velocity by more than
  // `most`: the same proportional scaling as the drive-speed limit, applied to the change.
  const Eigen::Vector3d change = to - from;
  Eigen::Vector3d limited;
  if (kinematics_.desaturate_twist(change, most, DesaturationPriority::kProportional, &limited) !=
          KinematicsStatus::kOk ||
      limited == change) {
    return to;
  }
  return Eigen::Vector3d(from + limited);
}

Eigen::Vector3d KinematicBaseline::within_drive_limits(const Eigen::Vector3d& previous,
                                                       const Eigen::Vector3d& twist) const noexcept {
  // The largest twist of the same direction that no module speed exceeds, reached from `previous`
  // no faster than the drive acceleration limit allows any module (the plant's drives cannot do
  // more, and a plan that ignores it overshoots).
  Eigen::Vector3d limited = twist;
  Eigen::Vector3d desaturated;
  if (kinematics_.desaturate_twist(twist, kinematics_.layout().limits().max_drive_speed,
                                   DesaturationPriority::kProportional, &desaturated) == KinematicsStatus::kOk) {
    limited = desaturated;
  }
  return limit_change(previous, limited, drive_change_per_step());
}

Eigen::Vector3d KinematicBaseline::policy_twist(int k, const Eigen::Vector3d& pose_world,
                                                const Eigen::Vector3d& previous_twist) const noexcept {
  // The Riccati law u_k = f_k + K_k z_k of the last plan, z_k = (pose_k, u_k-1), with the heading
  // unwrapped next to the one the gains were taken at; the change cost's u_-1 is the measured twist,
  // as in the plan. Then the same drive limits as the plan's.
  if (k < 0 || k >= horizon_ || !pose_world.allFinite() || !previous_twist.allFinite()) {
    return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  Vector6 z;
  z.head<2>() = pose_world.head<2>();
  z[2] = headings_[k] + wrap_angle(pose_world.z() - headings_[k]);
  z.tail<3>() = k == 0 ? twist_body_ : previous_twist;
  const Eigen::Vector3d u = feedforward_.col(k) + feedback_.block<3, 6>(0, 6 * k) * z;
  return within_drive_limits(k == 0 ? ramp_start_ : previous_twist, u);
}

void KinematicBaseline::wheel_speeds_at(int k, Eigen::Ref<Eigen::MatrixXd> inputs) const noexcept {
  const ModuleLimits& limits = kinematics_.layout().limits();
  const double radius = kinematics_.layout().wheel_radius();
  const bool common_scaling = options_.cosine_scaling && options_.common_scaling;
  // The least alignment of the modules the plan drives at speed (common_scaling).
  double common = 1.0;
  if (common_scaling) {
    for (int i = 0; i < modules_; ++i) {
      if (steer_from_(i, k) == k) common = std::min(common, steering_alignment<double>(turn_left_[i], LimitShape::kHard));
    }
  }
  for (int i = 0; i < modules_; ++i) {
    // The paper's baseline drives at the planned speed while it steers; but a module left more
    // than a quarter turn from its direction of travel (a swing between end stops) would push the
    // vehicle backwards against the others, so it waits (the cosine scaling's zero beyond 90 deg).
    const double turn_left = turn_left_[i];
    const bool align = options_.cosine_scaling || std::abs(turn_left) > kPi / 2;
    inputs(2 * i + 1, k) =
        common_scaling ? drive_wheel_speed<double>(common * signed_speeds_[i], turn_left, std::abs(turn_left) > kPi / 2,
                                                   limits, radius, LimitShape::kHard)
                       : drive_wheel_speed<double>(signed_speeds_[i], turn_left, align, limits, radius, LimitShape::kHard);
  }
}

void KinematicBaseline::plan_module_directions(double threshold, bool at_rest_rule) noexcept {
  for (int k = 0; k < horizon_; ++k) {
    kinematics_.inverse(twists_.col(k), &module_states_);
    for (int i = 0; i < modules_; ++i) {
      planned_angles_(i, k) = module_states_[i].angle;
      planned_speeds_(i, k) = module_states_[i].speed;
    }
  }
  // steer_from_(i, k): the first step j >= k at which module i is planned faster than the threshold,
  // -1 if none. Below it, a module's planned direction is set by the feedback on the measured pose
  // (under sensor noise, by the noise): the steering aims at the next direction the plan really
  // drives in, or holds when there is none.
  for (int i = 0; i < modules_; ++i) {
    int next = -1;
    for (int k = horizon_ - 1; k >= 0; --k) {
      if (planned_speeds_(i, k) > threshold) next = k;
      steer_from_(i, k) = next;
    }
  }
  // While the wheels wait for a start (pre-alignment), the at-rest rule:
  // - each module aims at its direction where the plan drives it fastest within the horizon (for a
  //   start from rest, the horizon's end), not where its speed first passes the threshold. Early in
  //   the ramp the plan's velocity is the reference's small first motion plus the feedback on the
  //   pose error left at the stop, off the start's direction by up to a right angle; aligned there,
  //   the hold released with a module still a swing away from the start's direction;
  // - a heading past an end stop is held at the stop only within the direction's own uncertainty
  //   (the flip band's widening), not kEndStopHold's 45 deg: that hold spares a rolling wheel a
  //   swing, and a waiting wheel has nothing to spare. Held at the stop 45 deg off its direction, a
  //   module counted as aligned, and the heavy carriers started with it dragging.
  // Only between end stops: without them a module still off its direction finishes its turn rolling
  // under the cosine scaling, so waiting for it costs more than it saves
  // (docs/decisions/pre-alignment.md).
  if (at_rest_rule) {
    for (int i = 0; i < modules_; ++i) {
      int fastest = 0;
      planned_speeds_.row(i).maxCoeff(&fastest);
      if (planned_speeds_(i, fastest) <= threshold) continue;
      for (int k = 0; k <= fastest; ++k) steer_from_(i, k) = fastest;
    }
  }
  // A module whose steering is stuck is steered nowhere: it holds, and its wheel rolls with the
  // planned velocity's component along its angle (module_inputs' rule for a module with no
  // direction ahead), so neither the cosine scaling nor the pre-alignment waits for it.
  for (int i = 0; i < modules_; ++i) {
    if (steering_stuck(followed_faults_ != nullptr ? followed_faults_ : &module_faults(), i)) {
      steer_from_.row(i).setConstant(-1);
    }
  }
}

void KinematicBaseline::module_inputs(const Eigen::Ref<const Eigen::VectorXd>& steering_angles,
                                      Eigen::Ref<Eigen::MatrixXd> inputs) noexcept {
  const ModuleLimits& limits = kinematics_.layout().limits();
  const double dt = options_.dt;
  const bool end_stops = limits.has_steering_end_stops();
  const double threshold = std::max(options_.steer_speed_threshold, kinematics_.options().hold_speed_threshold);
  const double band = options_.flip_hysteresis;
  // While the wheels wait for a start (pre-alignment) on a vehicle with end stops, the at-rest rule
  // (plan_module_directions and the end-stop hold below).
  const bool at_rest_rule = pre_aligns_ && aligning_ && end_stops;
  plan_module_directions(threshold, at_rest_rule);
  angles_ = steering_angles;
  for (int i = 0; i < modules_; ++i) signs_[i] = heading_memory_.drive_sign(i) < 0 ? -1 : 1;
  for (int k = 0; k < horizon_; ++k) {
    // The 180 deg flip (choose_drive_direction): a module keeps its drive direction while the
    // steering error stays below 90 deg - hysteresis and takes the other one above 90 deg +
    // hysteresis (widened at low planned speed, below); never past an end stop. Inside that band
    // the two choices need about a quarter turn either way round, and modules choosing on their
    // own (by noise) would turn opposite ways with their wheels driving, and fight. So the modules
    // in the band all turn the same way round: the one of least turn for them (a flip charged 2 x
    // hysteresis more, so a lone module still flips only past 90 deg + hysteresis), plus the turns
    // of the decided modules they would turn against, each weighted by its planned speed. A tie
    // keeps every drive direction.
    constexpr double kUnavailable = 1e6;  // the cost of a way round a module cannot turn
    double cost_positive = 0.0, cost_negative = 0.0;
    for (int i = 0; i < modules_; ++i) {
      const int j = steer_from_(i, k);
      if (j < 0) continue;
      const double weight = planned_speeds_(i, j);
      // A direction planned at speed v is uncertain by about atan(threshold / v) (the threshold is
      // the speed noise makes of the feedback): the band widens by that much before a flip.
      const double widening = std::atan2(threshold, weight);
      const DriveDirection<double>& direction = directions_[i] =
          choose_drive_direction<double>(planned_angles_(i, j), angles_[i], signs_[i], FlipPolicy::kHysteresis, band,
                                         limits, widening, 0.0, at_rest_rule ? band + widening : kEndStopHold);
      signs_[i] = direction.sign;
      if (direction.in_band) {  // decided below
        const double same = direction.turn, other = direction.other_turn;
        const double kept = weight * std::abs(same);
        const double flipped = weight * (std::abs(other) + 2.0 * band);
        const double positive = std::min(same > 0.0 ? kept : kUnavailable, other > 0.0 ? flipped : kUnavailable);
        const double negative = std::min(same < 0.0 ? kept : kUnavailable, other < 0.0 ? flipped : kUnavailable);
        cost_positive += positive;
        cost_negative += negative;
        continue;
      }
      (direction.turn > 0.0 ? cost_negative : cost_positive) += weight * std::abs(direction.turn);
    }
    const int common_turn = cost_positive < cost_negative ? 1 : (cost_negative < cost_positive ? -1 : 0);
    for (int i = 0; i < modules_; ++i) {
      const int j = steer_from_(i, k);
      double turn = 0.0;  // no direction planned ahead: the module holds its angle
      if (j >= 0) {
        const DriveDirection<double>& direction = directions_[i];
        turn = direction.turn;
        if (direction.in_band && common_turn != 0 && (direction.turn > 0.0) != (common_turn > 0) &&
            (direction.other_turn > 0.0) == (common_turn > 0)) {
          signs_[i] = -signs_[i];
          turn = direction.other_turn;
        }
      }
      const double rate = steering_rate_toward<double>(turn, dt, limits, LimitShape::kHard);
      const double angle = end_stops ? angles_[i] + dt * rate : wrap_angle(angles_[i] + dt * rate);
      // At speed the wheel runs the planned speed in the chosen direction; below the threshold it
      // runs the planned velocity's component along its heading (either sign, no flip needed).
      signed_speeds_[i] = j == k ? signs_[i] * planned_speeds_(i, k)
                                 : planned_speeds_(i, k) * std::cos(planned_angles_(i, k) - angle);
      inputs(2 * i, k) = rate;
      turn_left_[i] = j >= 0 ? turn - dt * rate : 0.0;
      angles_[i] = angle;
    }
    wheel_speeds_at(k, inputs);
    if (k == 0) {
      first_step_misalignment_ = 0.0;
      for (int i = 0; i < modules_; ++i) {
        if (steer_from_(i, 0) >= 0) first_step_misalignment_ = std::max(first_step_misalignment_, std::abs(turn_left_[i]));
      }
    }
    if (k == 0) {
      for (int i = 0; i < modules_; ++i) planned_memory_.remember(i, angles_[i], signs_[i]);
    }
  }
}

bool KinematicBaseline::pre_align_holds() noexcept {
  if (aligning_ && first_step_misalignment_ <= options_.pre_align_tolerance) aligning_ = false;
  return aligning_;
}

void KinematicBaseline::set_reference(std::shared_ptr<const Reference> reference) {
  if (!reference) throw ConfigError("KinematicBaseline.reference: must not be null");
  reference_ = std::move(reference);
}

const ControlOutput& KinematicBaseline::stop_safely(const Eigen::Ref<const Eigen::VectorXd>& measured,
                                                    const char* reason) noexcept {
  fill_safe_stop(kinematics_.layout(), options_.dt, measured, &output_.modules);
  output_.source = CommandSource::kSafeStop;
  output_.reason = reason;
  twist_committed_ = false;
  latency_.record(output_.modules);
  detector_.commanded(output_.modules, step_t_);
  lost_angles_.commanded(output_.modules, step_t_);
  return output_;
}

const ControlOutput& KinematicBaseline::step(const Eigen::Ref<const Eigen::VectorXd>& raw_measured, double t,
                                             double measured_at) noexcept {
  output_.solve = SolveSummary{};
  output_.module_fault_found = false;
  step_t_ = t;
  const TimePoint start = clock().now();
  // An encoder that stopped reporting: its module's angle by the rates sent since its last reading.
  bool sensor_lost = false;
  const Eigen::Ref<const Eigen::VectorXd> measured =
      stand_in_for_lost_angles(lost_angles_, raw_measured, measured_at, &sensor_lost);
  if (measured.size() != 6 + modules_ || !measured.allFinite() || !std::isfinite(t) ||
      !is_plausible_state(measured, kinematics_.layout())) {
    return stop_safely(measured, "measured state rejected (wrong size, NaN/inf or implausible)");
  }
  // A steering that stopped following its commands is taken as a fault from this step on.
  output_.module_fault_found = find_stuck_steering(detector_, measured, measured_at) || sensor_lost;
  reference_->begin_cycle();
  if (const char* unusable = reference_->unusable(t)) {
    return stop_safely(measured, unusable);
  }
  // A measurement taken before t is rolled forward by the commands sent since: a deadbeat
  // steering law acting on a delayed angle would otherwise chase its own past and oscillate. The
  // observer, when on, filters it first.
  latency_.estimate(measured, measured_at, t, now_);
  hold_stuck_angles(measured, now_);
  // The time since a step that waited for the steering does not count on the reference's clock.
  const double reference_t = reference_hold_.reference_time(t);
  for (int k = 0; k < horizon_; ++k) {
    const ReferenceSample sample = reference_->sample(reference_t + (k + 1) * options_.dt);
    reference_poses_.col(k) = sample.pose_world;
    reference_twists_.col(k) = sample.twist_body;
  }
  const Eigen::Vector3d measured_twist = now_.segment<3>(3);
  if (!plan_twists(now_.head<3>(), measured_twist, twist_committed_ ? committed_twist_ : measured_twist, reference_poses_,
                   reference_twists_)) {
    return stop_safely(measured, "the kinematic plan failed");
  }
  module_inputs(now_.segment(6, modules_), inputs_);
  const bool pre_aligning = pre_aligns_ && pre_align_holds();
  reference_hold_.set_held(pre_aligning || awaiting_arrival_);
  commit_first_step();
  if (pre_aligning) {
    // The wheels wait for the steering; the next plan's ramp starts from rest, not from a twist
    // that was never driven.
    for (int i = 0; i < modules_; ++i) inputs_(2 * i + 1, 0) = 0.0;
    committed_twist_.setZero();
  }
  for (int i = 0; i < modules_; ++i) {
    ModuleCommand& command = output_.modules[i];
    command.steering_rate = inputs_(2 * i, 0);
    command.steering_angle = wrap_angle(now_[6 + i] + options_.dt * command.steering_rate);
    command.wheel_speed = inputs_(2 * i + 1, 0);
  }
  latency_.record(output_.modules);
  detector_.commanded(output_.modules, t);
  lost_angles_.commanded(output_.modules, t);
  output_.source = CommandSource::kOptimizer;
  output_.reason = pre_aligning ? "kinematic plan; the wheels wait while the modules pre-align" : "kinematic plan";
  output_.reference_delay_s = reference_hold_.delay_s();
  output_.solve.status = SolveStatus::kConverged;
  output_.solve.reason = "closed-form Gauss-Newton solve";
  output_.solve.iterations = options_.gauss_newton_iterations;
  output_.solve.solve_time_s = to_seconds(clock().now() - start);
  output_.step_time_s = output_.solve.solve_time_s;
  return output_;
}

}  // namespace swerve
