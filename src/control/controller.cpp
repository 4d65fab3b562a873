#include "swerve/control/controller.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "swerve/core/config_error.hpp"
#include "swerve/kinematics/module_commands.hpp"
#include "swerve/kinematics/se2.hpp"
#include "swerve/control/safe_stop.hpp"

namespace swerve {
namespace {

// The outermost module's distance from the body origin (m).
double outermost_module_radius(const ModuleLayout& layout) {
  double radius = 0.0;
  for (const Eigen::Vector2d& p : layout.positions_body()) radius = std::max(radius, p.norm());
  return radius;
}

// `steering_rate_states`: how many steering rates the prediction carries, as its last states.
CostWeights cost_weights(const ControllerOptions& o, const ModuleLayout& layout, double vehicle_mass, int state_size,
                         int steering_rate_states) {
  const int modules = layout.size();
  CostWeights w;
  // ControllerOptions::weights_step: stage weights by dt / weights_step, weights on a change per
  // step and the terminal scale by its inverse; both exactly 1 when off or at that step.
  const StepRescale rescale = step_rescale(o.dt, o.weights_step);
  const double stage = rescale.stage;
  const double per_change = rescale.per_change;
  w.pose = stage * o.pose_weight;
  if (o.heading_weight_from_geometry) {
    const double lever = o.heading_lever * outermost_module_radius(layout);
    w.pose.z() = stage * 0.5 * (o.pose_weight.x() + o.pose_weight.y()) * lever * lever;
  }
  w.twist = stage * o.twist_weight;
  w.terminal_scale = per_change * o.terminal_scale;
  w.pose_huber_width = o.pose_huber_width;
  w.wear = o.effective_wear_weight(vehicle_mass);
  w.tube_penalty = stage * o.tracking_tolerance.penalty;
  // The steering effort on the mean over modules of the squared predicted steering rate, so one
  // weight means the same on 2 modules and on 10 (see ControllerOptions::steering_effort).
  w.state_effort = Eigen::VectorXd::Zero(state_size);
  if (steering_rate_states > 0) {
    w.state_effort.tail(steering_rate_states).setConstant(stage * o.steering_effort / steering_rate_states);
  }
  if (o.parameterization == InputParameterization::kBodyTwist) {
    w.effort = Eigen::VectorXd::Zero(3);
    w.rate = Eigen::VectorXd::Constant(3, per_change * o.twist_smoothness);
    return w;
  }
  w.effort = Eigen::VectorXd(2 * modules);
  w.rate = Eigen::VectorXd(2 * modules);
  for (int i = 0; i < modules; ++i) {
    w.effort.segment<2>(2 * i) << stage * o.steering_rate_effort, stage * o.wheel_speed_effort;
    w.rate.segment<2>(2 * i) << per_change * o.steering_rate_smoothness, per_change * o.wheel_speed_smoothness;
  }
  return w;
}

// Body twist: translation within the drive speed, rotation within what the outermost module can
// drive, and no module asked to change its velocity faster than the drive acceleration (per axis).
InputBounds twist_bounds(const ModuleLayout& layout, double dt) {
  const ModuleLimits& limits = layout.limits();
  const double max_radius = outermost_module_radius(layout);
  InputBounds b;
  b.upper = Eigen::Vector3d(limits.max_drive_speed, limits.max_drive_speed, limits.max_drive_speed / max_radius);
  b.lower = -b.upper;
  const double step = limits.max_drive_acceleration * dt;
  b.max_step = Eigen::Vector3d(step, step, step / max_radius);
  return b;
}

// Steering rate within its limit, wheel speed within the drive limit, wheel acceleration per step.
InputBounds input_bounds(const ModuleLayout& layout, double dt) {
  const ModuleLimits& limits = layout.limits();
  const int n = layout.size();
  const double max_wheel_speed = limits.max_drive_speed / layout.wheel_radius();
  const double max_wheel_step = limits.max_drive_acceleration * dt / layout.wheel_radius();
  InputBounds b;
  b.lower = b.upper = b.max_step = Eigen::VectorXd(2 * n);
  for (int i = 0; i < n; ++i) {
    b.lower.segment<2>(2 * i) << -limits.max_steering_rate, -max_wheel_speed;
    b.upper.segment<2>(2 * i) << limits.max_steering_rate, max_wheel_speed;
    b.max_step.segment<2>(2 * i) << std::numeric_limits<double>::infinity(), max_wheel_step;
  }
  return b;
}

// Validated before any member is built from them, so errors name ControllerOptions' own fields.
ControllerOptions validated(ControllerOptions options) {
  options.validate();
  return options;
}

BaselineOptions aligned(BaselineOptions baseline, const ControllerOptions& options) {
  baseline.horizon = options.horizon;
  baseline.dt = options.dt;
  // Its weights sit in the same file as the controller's and were set for the same step, unless
  // its options name their own: at another dt they are rescaled as the controller's are.
  if (baseline.weights_step == 0.0) baseline.weights_step = options.weights_step;
  return baseline;
}

}  // namespace

const char* to_string(InputParameterization parameterization) noexcept {
  return parameterization == InputParameterization::kBodyTwist ? "body_twist" : "module_rates";
}

const OptionFields<ControllerOptions>& ControllerOptions::sampling_fields() {
  return horizon_and_step_fields<ControllerOptions>();
}

const OptionFields<ControllerOptions>& ControllerOptions::timing_fields() {
  static const OptionFields<ControllerOptions> table{
      {"control_period", &ControllerOptions::control_period, Bound::non_negative(), {}, nullptr, "(s; 0: dt)"},
      {"solve_budget", &ControllerOptions::solve_budget, Bound::positive()},
      {"overrun_grace", &ControllerOptions::overrun_grace, Bound::non_negative()},
      {"deadline_margin", &ControllerOptions::deadline_margin, Bound::closed(0.0, 0.5), {}, nullptr,
       "(a share of solve_budget)"},
      {"baseline_guess", &ControllerOptions::baseline_guess},
      {"max_plan_age", &ControllerOptions::max_plan_age, Bound::at_least(0)},
  };
  return table;
}

const OptionFields<ControllerOptions>& ControllerOptions::weight_fields() {
  static const OptionFields<ControllerOptions> table{
      {"pose_weight", &ControllerOptions::pose_weight, Bound::non_negative(), {}, "pose"},
      {"twist_weight", &ControllerOptions::twist_weight, Bound::non_negative(), {}, "twist"},
      {"terminal_scale", &ControllerOptions::terminal_scale, Bound::non_negative()},
      {"weights_step", &ControllerOptions::weights_step, Bound::non_negative(), {}, "step",
       "(s: the dt the weights are set for; 0: off)"},
      {"pose_huber_width", &ControllerOptions::pose_huber_width, Bound::non_negative()},
      {"wear_weight", &ControllerOptions::wear_weight, Bound::non_negative(), {}, "wear"},
      {"wear_reference_mass", &ControllerOptions::wear_reference_mass, Bound::non_negative()},
      {"wear_mass_exponent", &ControllerOptions::wear_mass_exponent, Bound::positive()},
      {"steering_rate_effort", &ControllerOptions::steering_rate_effort, Bound::non_negative()},
      {"wheel_speed_effort", &ControllerOptions::wheel_speed_effort, Bound::non_negative()},
      {"steering_rate_smoothness", &ControllerOptions::steering_rate_smoothness, Bound::non_negative()},
      {"wheel_speed_smoothness", &ControllerOptions::wheel_speed_smoothness, Bound::non_negative()},
      {"twist_smoothness", &ControllerOptions::twist_smoothness, Bound::non_negative()},
      {"steering_effort", &ControllerOptions::steering_effort, Bound::non_negative(), {}, nullptr,
       "(per (rad/s)^2 of the modules' mean squared predicted steering rate)"},
      {"heading_weight_from_geometry", &ControllerOptions::heading_weight_from_geometry, Bound::any(), {},
       "heading_from_geometry"},
      {"heading_lever", &ControllerOptions::heading_lever, Bound::positive()},
  };
  return table;
}

void ControllerOptions::validate() const {
  check_fields("ControllerOptions", *this, sampling_fields());
  check_fields("ControllerOptions", *this, timing_fields());
  check_fields("ControllerOptions", *this, weight_fields());
  if (control_period > dt) {
    throw_invalid_field("ControllerOptions", "control_period", control_period,
                        "must not exceed dt (" + std::to_string(dt) + " s): a cycle must not skip a prediction step");
  }
  measurement_filter.validate();
  fault_detection.validate();
  friction_estimation.validate();
  wear_balancing.validate();
  if (wear_balancing.enabled && prediction.method != PredictionMethod::kSemiImplicit) {
    throw ConfigError("ControllerOptions.wear_balancing.enabled = true: needs prediction.method semi_implicit "
                      "(the RK4 prediction's stage wear is not split by module)");
  }
  stale_measurement.validate();
  work_budget.validate();
  tracking_tolerance.validate();
  prediction.validate();
}

Controller::Controller(const VehicleParams& vehicle, std::shared_ptr<const Reference> reference,
                       ControllerOptions options, const SolverFactory& make_solver, BaselineOptions baseline_options,
                       std::string name)
    : name_(std::move(name)), options_(validated(options)), layout_(vehicle.layout), reference_(std::move(reference)),
      baseline_(vehicle.layout, reference_, aligned(baseline_options, options_)), modules_(vehicle.layout.size()),
      monitor_(6 + vehicle.layout.size(), options_.stale_measurement, options_.period()), latency_(vehicle.layout, options_.period(), options_.measurement_filter,
               ActuatorLags::of(vehicle)),
      detector_(vehicle.layout, options_.period(), ActuatorLags::of(vehicle).steering, options_.fault_detection),
      lost_angles_(vehicle.layout, options_.period()) {
  if (!reference_) throw ConfigError("Controller.reference: must not be null");
  if (!make_solver) throw ConfigError("Controller.solver: no solver factory given");
  const bool twist = options_.parameterization == InputParameterization::kBodyTwist;
  const VehiclePredictionModel* module_model = nullptr;
  if (twist) {
    auto twist_model = std::make_unique<TwistPredictionModel>(vehicle, options_.prediction);
    twist_model_ = twist_model.get();
    module_model = &twist_model->module_model();
    model_ = std::move(twist_model);
  } else {
    auto vehicle_model = std::make_unique<VehiclePredictionModel>(vehicle, options_.prediction);
    module_model = vehicle_model.get();
    model_ = std::move(vehicle_model);
  }
  problem_ = std::make_unique<OcpProblem>(*model_, options_.horizon, options_.dt, cost_weights(options_, layout_, vehicle.mass, model_->state_size(),
                                                                       module_model->steering_rate_states()),
                                          twist ? twist_bounds(layout_, options_.dt) : input_bounds(layout_, options_.dt));
  wear_weight_ = problem_->weights().wear;
  model_data_ = model_->create_data();
  solver_ = make_solver(*problem_);
  if (!solver_) throw ConfigError("Controller.solver: the solver factory returned nothing");
  solution_.resize(problem_->state_size(), problem_->input_size(), options_.horizon);
  plan_.resize(problem_->state_size(), problem_->input_size(), options_.horizon);
  prepared_plan_.resize(problem_->state_size(), problem_->input_size(), options_.horizon);
  prepared_baseline_.resize(problem_->state_size(), problem_->input_size(), options_.horizon);
  prepared_policy_.resize(problem_->state_size(), problem_->input_size(), options_.horizon);
  baseline_inputs_ = Eigen::MatrixXd::Zero(2 * modules_, options_.horizon);
  baseline_guess_ = Eigen::MatrixXd::Zero(problem_->input_size(), options_.horizon);
  baseline_policy_guess_ = baseline_guess_;
  baseline_states_ = Eigen::MatrixXd::Zero(problem_->state_size(), options_.horizon + 1);
  tube_.emplace(options_.tracking_tolerance, *problem_);
  if (options_.work_budget.enabled) work_clock_ = std::make_unique<WorkBudgetClock>(options_.work_budget);
  applied_decision_ = Eigen::VectorXd::Zero(problem_->input_size());
  applied_input_ = Eigen::VectorXd::Zero(2 * modules_);
  fallback_input_ = Eigen::VectorXd::Zero(2 * modules_);
  module_bounds_ = input_bounds(layout_, options_.period());  // per cycle: the fallbacks' limits
  output_.modules = ModuleArray<ModuleCommand>(modules_);
  now_ = Eigen::VectorXd::Zero(6 + modules_);
  prediction_state_ = Eigen::VectorXd::Zero(problem_->state_size());
  // The prediction carries wheel speeds (PredictionOptions::drive_lag) or steering rates
  // (steering_lag): the controller estimates them from the commands it sent, through the same
  // first-order lags.
  actuators_.emplace(vehicle, module_model->wheel_speed_states() > 0, module_model->steering_rate_states() > 0);
  // One set of faults for the plans, the prediction and the baseline (on the heap: a move keeps it).
  size_module_faults(modules_);
  model_->observe_module_faults(&module_faults());
  baseline_.follow_module_faults(&module_faults());
  friction_scales_ = std::make_unique<std::array<double, kMaxModules>>();
  friction_scales_->fill(1.0);
  model_->observe_friction_scales(friction_scales_->data());
  wear_weights_ = std::make_unique<std::array<double, kMaxModules>>();
  wear_weights_->fill(1.0);
  const std::vector<double> shares = vehicle.static_load_shares();
  std::copy(shares.begin(), shares.end(), load_shares_.begin());
  if (options_.wear_balancing.enabled) model_->observe_wear_weights(wear_weights_->data());
  if (options_.friction_estimation.enabled) {
    friction_ = std::make_unique<FrictionEstimator>(vehicle, options_.prediction, options_.period(),
                                                    options_.friction_estimation);
    friction_->observe_module_faults(&module_faults());
  }
}

void Controller::set_friction_scale(double scale) {
  TrackingController::set_friction_scale(scale);  // the common checks
  if (friction_) friction_->set_scale(scale);
  use_friction_scale(scale);
}

void Controller::set_module_wear(const Eigen::Ref<const Eigen::VectorXd>& wear) {
  TrackingController::set_module_wear(wear);  // the common checks
  if (!options_.wear_balancing.enabled) return;
  std::array<double, kMaxModules> weights{};
  wear_balancing_weights(options_.wear_balancing, wear.data(), load_shares_.data(), modules_, weights.data());
  // A preparation linearised the wear at the old weights.
  for (int i = 0; i < modules_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (outdates_preparation((*wear_weights_)[k], weights[k])) {
      drop_preparation();
      break;
    }
  }
  std::copy(weights.begin(), weights.begin() + modules_, wear_weights_->begin());
}

void Controller::use_friction_scale(double scale) noexcept {
  // A preparation linearised the model at the old grip.
  if (outdates_preparation(friction_scale(), scale)) drop_preparation();
  friction_scales_->fill(scale);
}

bool Controller::outdates_preparation(double before, double after) noexcept {
  // A change within a few percent is left to the feedback's own Gauss-Newton step; a larger one is
  // prepared anew.
  constexpr double kPreparedTolerance = 0.05;
  return std::abs(after - before) > kPreparedTolerance * before;
}

void Controller::drop_preparation() noexcept {
  solver_->forget_preparation();
  prepared_t_ = std::numeric_limits<double>::quiet_NaN();
}

void Controller::module_faults_changed() noexcept {
  detector_.forget_healthy(module_faults());  // a fault cleared by hand may be found again
  // A preparation linearised the model without the change.
  drop_preparation();
  // Tracking first while a steering is stuck: the stuck tire is dragged by any motion off its
  // angle, and with the wear priced the plan bought its relief by leaving the path (on a 1 m lane
  // change, a vehicle that rolled on along the stuck angle and ended 1.3 m off it). The path is
  // the aisle; that tire's wear is the fault's cost. See docs/decisions/module-faults.md.
  // A dead drive drags nothing (its module still steers its free wheel along its contact velocity):
  // the wear stays priced.
  bool stuck = false;
  for (int i = 0; i < modules_; ++i) stuck = stuck || steering_stuck(&module_faults(), i);
  problem_->set_wear_weight(stuck ? 0.0 : wear_weight_);
}

void Controller::reset() noexcept {
  drop_preparation();
  plan_.valid = false;
  plan_age_ = 0;
  applied_input_.setZero();
  applied_decision_.setZero();
  previous_input_known_ = false;
  actuators_->forget();
  baseline_.reset();
  monitor_.reset();
  latency_.reset();
  detector_.reset();  // the faults found stay: they are the hardware's
  lost_angles_.reset();
  if (friction_) friction_->reset();  // the grip estimated stays: the floor did not change
  motion_commanded_since_ = std::numeric_limits<double>::infinity();
  reference_hold_.reset();
  output_.reference_delay_s = 0.0;
  for (int i = 0; i < modules_; ++i) output_.modules[i] = ModuleCommand{};
}

void Controller::apply_module_inputs(const Eigen::Ref<const Eigen::VectorXd>& module_inputs,
                                     const Eigen::Ref<const Eigen::VectorXd>& steering_angles) noexcept {
  // The inputs are already feasible; the angle target follows the rate over one period.
  applied_input_ = module_inputs;
  for (int i = 0; i < modules_; ++i) {
    // Every path (plan, baseline, fallback, safe stop) leaves a stuck steering alone.
    if (steering_stuck(&module_faults(), i)) applied_input_[InputIndex::steering_rate(i)] = 0.0;
    ModuleCommand& command = output_.modules[i];
    command.steering_rate = applied_input_[2 * i];
    command.wheel_speed = applied_input_[2 * i + 1];
    command.steering_angle = wrap_angle(steering_angles[i] + options_.period() * command.steering_rate);
  }
}

void Controller::assume_previous_input(const Eigen::Ref<const Eigen::VectorXd>& measured) noexcept {
  // Without a command of our own yet (start, reset, after a safe stop), the input the step bounds
  // and the smoothness cost start from is the one that keeps the vehicle doing what it does now:
  // its measured twist, or each wheel rolling at its contact speed with the steering at rest.
  for (int i = 0; i < modules_; ++i) {
    applied_input_[InputIndex::steering_rate(i)] = 0.0;
    applied_input_[InputIndex::wheel_speed(i)] = rolling_wheel_speed(layout_, measured, i);
  }
  if (twist_model_ != nullptr) {
    applied_decision_ = measured.segment<3>(StateIndex::kVx);
  } else {
    applied_decision_ = applied_input_;
  }
  // Keep it inside the box so the projection of every guess stays consistent with it.
  const InputBounds& bounds = problem_->bounds();
  applied_decision_ = applied_decision_.cwiseMax(bounds.lower).cwiseMin(bounds.upper);
  previous_input_known_ = true;
}

void Controller::apply_decision(const Eigen::Ref<const Eigen::MatrixXd>& plan, int column,
                                const Eigen::Ref<const Eigen::VectorXd>& state) noexcept {
  applied_decision_ = plan.col(column);
  if (twist_model_ != nullptr) {
    twist_model_->module_inputs(state, applied_decision_.head<3>(), options_.dt, applied_input_);
    steer_slow_modules_ahead(plan, column, state);
    apply_module_inputs(applied_input_, state.segment(StateIndex::kFirstSteering, modules_));
  } else {
    apply_module_inputs(applied_decision_, state.segment(StateIndex::kFirstSteering, modules_));
  }
}

void Controller::steer_slow_modules_ahead(const Eigen::Ref<const Eigen::MatrixXd>& plan, int column,
                                          const Eigen::Ref<const Eigen::VectorXd>& state) noexcept {
  // A module the plan moves slower than the baseline's steer threshold this step: the direction of
  // its contact velocity turns by dv / v per lateral dv, so at a few mm/s it is set by the last
  // digits the optimiser resolved, and the map turned it at full rate after them. As the baseline
  // does (BaselineOptions::steer_speed_threshold), it steers toward the first direction
  // the plan drives it faster than that, or holds, and its wheel rolls with the velocity's component
  // along its heading. See docs/decisions/low-speed-steering.md.
  // A plan that drives the module nowhere within the horizon while the reference does (a 90 deg
  // turn in place after a crab, modules at their end stops): the reference's direction is the
  // aim instead. Otherwise the modules hold, the horizon is too short for the re-steering the motion
  // needs first, and every plan stands still (the practical baseline's pre-alignment, while rolling
  // or at rest).
  const double threshold = baseline_.options().steer_speed_threshold;
  const ModuleLimits& limits = layout_.limits();
  const Eigen::Vector3d twist_now = plan.col(column).head<3>();
  for (int i = 0; i < modules_; ++i) {
    const Eigen::Vector2d r_body = layout_.position_body(i);
    const Eigen::Vector2d v_now = point_velocity<double>(twist_now, r_body);
    if (v_now.norm() >= threshold || steering_stuck(&module_faults(), i)) continue;
    const double angle = state[StateIndex::steering(i)];
    // The least steering rate that turns the module to velocity `v_ahead`'s direction in `time`.
    const auto rate_toward = [&](const Eigen::Vector2d& v_ahead, double time) {
      const DriveDirection<double> direction = choose_drive_direction<double>(
          std::atan2(v_ahead.y(), v_ahead.x()), angle, 0, FlipPolicy::kNearest, 0.0, limits, 0.0, kDirectionTieBand);
      return steering_rate_toward<double>(direction.turn, time, limits, LimitShape::kHard);
    };
    double rate = 0.0;
    bool aimed = false;
    for (Eigen::Index k = column + 1; k < plan.cols() && !aimed; ++k) {
      const Eigen::Vector2d v_ahead = point_velocity<double>(Eigen::Vector3d(plan.col(k).head<3>()), r_body);
      if (v_ahead.norm() < threshold) continue;
      // Aligned when the plan drives it that way, not before.
      rate = rate_toward(v_ahead, static_cast<double>(k - column) * options_.dt);
      aimed = true;
    }
    for (Eigen::Index k = column; k < plan.cols() && !aimed; ++k) {
      const Eigen::Vector2d v_ahead = point_velocity<double>(reference_twist_in_body(k, state), r_body);
      if (v_ahead.norm() < threshold) continue;
      // Reference column k is step k + 1's.
      rate = rate_toward(v_ahead, static_cast<double>(k + 1 - column) * options_.dt);
      aimed = true;
    }
    applied_input_[InputIndex::steering_rate(i)] = rate;
    applied_input_[InputIndex::wheel_speed(i)] = drive_wheel_speed<double>(
        rolling_speed<double>(v_now, angle), 0.0, false, limits, layout_.wheel_radius(), LimitShape::kHard);
  }
}

Eigen::Vector3d Controller::reference_twist_in_body(Eigen::Index column,
                                                   const Eigen::Ref<const Eigen::VectorXd>& state) const noexcept {
  // The reference's twist is in its own body frame; the vehicle's heading may differ from it.
  const Eigen::Vector3d twist_world =
      twist_body_to_world(problem_->reference_twists().col(column), problem_->reference_poses()(2, column));
  return twist_world_to_body(twist_world, state[StateIndex::kPsi]);
}

void Controller::fall_back(const Eigen::Ref<const Eigen::VectorXd>& measured, bool baseline_usable,
                           const char* why) noexcept {
  output_.reason = why;
  FallbackSituation situation;
  situation.plan_valid = plan_.valid;
  situation.plan_age = plan_age_;
  situation.max_plan_age = options_.max_plan_age;
  situation.horizon = options_.horizon;
  situation.baseline_usable = baseline_usable;
  situation.measured_usable = is_plausible_state(measured, layout_);
  const bool measured_usable = situation.measured_usable;
  const CommandSource rung = choose_fallback(situation);
  if (rung == CommandSource::kPreviousPlan) {
    // Without a usable measurement the plan's own predicted steering angles stand in.
    if (measured_usable) {
      apply_decision(plan_.inputs, 0, measured);
    } else {
      apply_decision(plan_.inputs, 0, plan_.states.col(0));
    }
    output_.source = CommandSource::kPreviousPlan;
    return;
  }
  if (rung == CommandSource::kBaseline) {
    // Within one step's change of the last command, then within the drives' limits, as the
    // optimiser's plans are. The limits come last and win: the last command can lie outside them
    // (assumed from a measured twist faster than the drives allow), and a step window around it
    // then lies outside too (the fuzzer found -78 rad/s commanded on a 20 rad/s drive that way).
    fallback_input_ = baseline_inputs_.col(0)
                          .cwiseMax(applied_input_ - module_bounds_.max_step)
                          .cwiseMin(applied_input_ + module_bounds_.max_step);
    set_fallback_input(fallback_input_);
    apply_module_inputs(fallback_input_, measured.segment(StateIndex::kFirstSteering, modules_));
    applied_decision_ = baseline_guess_.col(0);
    output_.source = CommandSource::kBaseline;
    return;
  }
  safe_stop(measured);
}

bool Controller::close_baseline_loop() noexcept {
  // The baseline's plan is a twist sequence for its kinematic model. Played open loop through the
  // prediction (drive lag, steering rate, tyre slip) it falls behind: from rest on curve_smooth the
  // prediction priced its tracking at ~10x the annealer's answer, so the annealer never started
  // near it, and its answer wore 2x the baseline's tyre in the first second. Its Riccati gains
  // close the loop on the predicted poses instead, as the baseline closes it on the measured ones.
  // Both are offered: on a hard start the closed loop catches up harder and can cost more (the
  // 3-wheel robot at t = 0: 69 against 37), and the solver starts from the cheaper.
  const PredictionModel& model = problem_->model();
  baseline_states_.col(0) = problem_->initial_state();
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  for (int k = 0; k < options_.horizon; ++k) {
    previous = baseline_.policy_twist(k, baseline_states_.col(k).head<3>(), previous);
    baseline_policy_guess_.col(k) = previous;
    double wear = 0.0;
    if (!model.step(*model_data_, baseline_states_.col(k), baseline_policy_guess_.col(k), options_.dt, baseline_states_.col(k + 1),
                    &wear)) {
      return false;
    }
  }
  return baseline_policy_guess_.allFinite();
}

bool Controller::pre_align() noexcept {
  if (!baseline_.pre_aligns() || !baseline_.pre_align_holds()) return false;
  // The baseline's steering toward the first direction of travel, the wheels at rest; the next
  // plan starts from rest, as the decision the smoothness cost starts from says.
  set_fallback_input(baseline_inputs_.col(0));
  for (int i = 0; i < modules_; ++i) fallback_input_[InputIndex::wheel_speed(i)] = 0.0;
  apply_module_inputs(fallback_input_, now_.segment(StateIndex::kFirstSteering, modules_));
  if (twist_model_ != nullptr) {
    applied_decision_.setZero();
  } else {
    applied_decision_ = fallback_input_;
  }
  previous_input_known_ = true;
  plan_.valid = false;  // a plan from before the stop is no guess for the start
  output_.source = CommandSource::kOptimizer;
  output_.reason = "pre-alignment: the wheels wait while the modules turn to their first direction of travel";
  return true;
}

void Controller::send_baseline_commands(const Eigen::Ref<const Eigen::VectorXd>& state) noexcept {
  // The baseline's own module commands (as the kinematic_baseline controller sends them), within
  // the drives' limits; the decision the smoothness cost starts from next cycle is its twist.
  set_fallback_input(baseline_inputs_.col(0));
  apply_module_inputs(fallback_input_, state.segment(StateIndex::kFirstSteering, modules_));
  applied_decision_ = baseline_guess_.col(0);
  output_.source = CommandSource::kTrackingFirst;
  output_.reason = "tracking first: the plan left the tracking tolerance, so the baseline's commands were sent";
}

bool Controller::motion_commanded() const noexcept {
  for (int i = 0; i < modules_; ++i) {
    const ModuleCommand& command = output_.modules[i];
    if (std::abs(command.wheel_speed) * layout_.wheel_radius() > options_.stale_measurement.moving_speed ||
        std::abs(command.steering_rate) > options_.stale_measurement.moving_speed) {
      return true;
    }
  }
  return false;
}

void Controller::refuse(const Eigen::Ref<const Eigen::VectorXd>& measured, const char* reason) noexcept {
  // Nothing this step can act on: no plan is kept, and the vehicle stops safely, saying why.
  output_.solve.status = SolveStatus::kInvalidInput;
  output_.solve.reason = reason;
  output_.reason = reason;
  plan_.valid = false;
  safe_stop(measured);
}

void Controller::safe_stop(const Eigen::Ref<const Eigen::VectorXd>& measured) noexcept {
  fill_safe_stop(layout_, options_.period(), measured, &output_.modules);
  for (int i = 0; i < modules_; ++i) {
    applied_input_[2 * i] = 0.0;
    applied_input_[2 * i + 1] = output_.modules[i].wheel_speed;
  }
  // What the drives do after a safe stop is best read from the next measurement.
  previous_input_known_ = false;
  output_.source = CommandSource::kSafeStop;
}

const ControlOutput& Controller::finish(TimePoint step_start) noexcept {
  latency_.record(output_.modules);
  detector_.commanded(output_.modules, step_t_);
  lost_angles_.commanded(output_.modules, step_t_);
  if (friction_) friction_->commanded(output_.modules, step_t_);
  output_.friction_scale = friction_scale();
  // The frozen-measurement check asks since when motion has been commanded without a break.
  if (!motion_commanded()) {
    motion_commanded_since_ = std::numeric_limits<double>::infinity();
  } else if (!std::isfinite(motion_commanded_since_) && std::isfinite(step_t_)) {
    motion_commanded_since_ = step_t_;
  }
  actuators_->record_sent(output_.modules);
  const TimePoint end = clock().now();
  output_.step_time_s = to_seconds(end - step_start);
  output_.work_budget_cut = work_clock_ != nullptr && work_clock_->guard_fired();
  if (solved_) {
    // Memory of the worst overshoot, halving every 100 steps.
    constexpr double kDecayPerStep = 0.99309;  // 0.5^(1/100)
    overshoot_s_ = std::max(to_seconds(end - solve_deadline_), kDecayPerStep * overshoot_s_);
  }
  return output_;
}

Duration Controller::solve_margin() const noexcept {
  // With a work budget the margin is kept in work, and the step's clock only guards: half of it
  // there, so a machine as fast as the budget's rates say never reaches the guard.
  const double kept = (work_clock_ ? 0.5 : 1.0) * options_.deadline_margin * options_.solve_budget;
  return to_duration(std::min(0.5 * options_.solve_budget, std::max(kept, 1.5 * overshoot_s_)));
}

Deadline Controller::solve_deadline(TimePoint step_start) noexcept {
  solve_deadline_ = step_start + to_duration(options_.solve_budget) - solve_margin();
  if (!work_clock_) return Deadline(solve_deadline_, clock());
  return work_clock_->begin(clock(), solve_deadline_,
                            to_duration((1.0 - options_.deadline_margin) * options_.solve_budget));
}

void Controller::set_reference(std::shared_ptr<const Reference> reference) {
  if (!reference) throw ConfigError("Controller.reference: must not be null");
  baseline_.set_reference(reference);
  reference_ = std::move(reference);
}

void Controller::update_problem(double t, double reference_t) noexcept {
  // In place: the state (with the actuators' estimate), the last applied input, the reference window.
  prediction_state_.head(6 + modules_) = now_;
  if (actuators_->active()) {
    // Commands more than four periods old are not followed (a gap, or time that jumped).
    actuators_->estimate(now_, t, 4.0 * options_.period());
    prediction_state_.segment(6 + modules_, actuators_->wheel_speeds().size()) = actuators_->wheel_speeds();
    prediction_state_.tail(actuators_->steering_rates().size()) = actuators_->steering_rates();
  }
  problem_->set_initial_state(prediction_state_);
  if (!previous_input_known_) assume_previous_input(now_);
  problem_->set_previous_input(applied_decision_);
  for (int k = 1; k <= options_.horizon; ++k) {
    const ReferenceSample sample = reference_->sample(reference_t + k * options_.dt);
    problem_->set_reference(k, sample.pose_world, sample.twist_body);
  }
}

bool Controller::plan_baseline(bool* policy_guess_usable) noexcept {
  // The baseline plan is both an initial guess and the second fallback. Its acceleration limit
  // starts from the twist commanded last cycle (see plan_twists). With module-rate decisions that
  // twist is not at hand, and the measured one stands in.
  const Eigen::Vector3d measured_twist = now_.segment<3>(StateIndex::kVx);
  const Eigen::Vector3d last_command =
      twist_model_ != nullptr ? Eigen::Vector3d(applied_decision_.head<3>()) : measured_twist;
  if (!baseline_.plan_twists(now_.head<3>(), measured_twist, last_command, problem_->reference_poses(),
                             problem_->reference_twists())) {
    return false;
  }
  baseline_.module_inputs(now_.segment(StateIndex::kFirstSteering, modules_), baseline_inputs_);
  baseline_.commit_first_step();
  if (twist_model_ != nullptr) {
    baseline_guess_ = baseline_.twist_plan();
    *policy_guess_usable = options_.baseline_guess && close_baseline_loop();
  } else {
    baseline_guess_ = baseline_inputs_;
  }
  problem_->project(baseline_guess_);
  return true;
}

namespace {
// s: two step times closer than this are the same step's, computed two ways.
constexpr double kSameStepTime = 1e-9;
}  // namespace

bool Controller::prepare(double t_next) noexcept {
  prepared_t_ = std::numeric_limits<double>::quiet_NaN();
  if (!solver_->has_preparation() || !solved_ || !plan_.valid || plan_age_ != 0 ||
      output_.source != CommandSource::kOptimizer || options_.tracking_tolerance.enabled() ||
      !std::isfinite(t_next) || !(t_next > step_t_)) {
    return false;
  }
  const TimePoint start = clock().now();
  const Deadline deadline(start + to_duration(options_.solve_budget) - solve_margin(), clock());
  model_->charge_work_to(&deadline.clock());
  // The next step's first guess is this plan moved on by a period: its state then is the start
  // predicted.
  const double steps = options_.period() / options_.dt;
  prepared_plan_.inputs = plan_.inputs;
  prepared_plan_.states = plan_.states;
  prepared_plan_.shift(steps);
  problem_->set_initial_state(prepared_plan_.states.col(0));
  problem_->set_previous_input(applied_decision_);
  const double reference_t = reference_hold_.reference_time_ahead(t_next);
  for (int k = 1; k <= options_.horizon; ++k) {
    const ReferenceSample sample = reference_->sample(reference_t + k * options_.dt);
    problem_->set_reference(k, sample.pose_world, sample.twist_body);
  }
  InitialGuesses guesses;
  guesses.add(&prepared_plan_.inputs);
  // This step's baseline guesses, moved on as the plan is: the preparation picks its start from
  // the same kinds of guess a whole solve does (the next step's own come from its measurement).
  const auto add_moved = [&](bool usable, const Eigen::MatrixXd& guess, Solution* moved) {
    if (!usable) return;
    moved->inputs = guess;
    moved->shift(steps);
    guesses.add(&moved->inputs);  // the solver projects each guess
  };
  add_moved(policy_guessed_, baseline_policy_guess_, &prepared_policy_);
  add_moved(baseline_guessed_, baseline_guess_, &prepared_baseline_);
  if (!solver_->prepare(*problem_, guesses, deadline)) return false;
  prepared_t_ = t_next;
  return true;
}

void Controller::begin_step() noexcept {
  solved_ = false;
  actuators_->begin_step();
  output_.solve = SolveSummary{};
  output_.measurement_stale = false;
  output_.module_fault_found = false;
  // The previous plan moves on by one cycle whatever happens now (period / dt of its steps).
  if (plan_.valid) {
    plan_.shift(options_.period() / options_.dt);
    ++plan_age_;
  }
}

const ControlOutput& Controller::step(const Eigen::Ref<const Eigen::VectorXd>& raw_measured, double t_measured,
                                      double measured_at) noexcept {
  // The time prepared for, when t is it but for rounding (k period against (k - 1) period + period),
  // so the reference window sampled now is the prepared one bit for bit.
  const double t = std::abs(t_measured - prepared_t_) <= kSameStepTime ? prepared_t_ : t_measured;
  // The budget covers the whole step (baseline plan, problem update, solve), not the solve alone.
  const TimePoint step_start = clock().now();
  step_t_ = t;
  if (!(t == prepared_t_)) solver_->forget_preparation();
  prepared_t_ = std::numeric_limits<double>::quiet_NaN();
  const TimePoint step_deadline = step_start + to_duration(options_.solve_budget);
  const Deadline deadline = solve_deadline(step_start);
  // The model charges its work to the deadline's clock as set now (set_clock may have changed it
  // since the last step): a work clock or a work budget then prices a proposal by the modules and
  // substeps it evaluates.
  model_->charge_work_to(&deadline.clock());
  begin_step();
  // An encoder that stopped reporting: its module's angle by the rates sent since its last reading.
  bool sensor_lost = false;
  const Eigen::Ref<const Eigen::VectorXd> measured =
      stand_in_for_lost_angles(lost_angles_, raw_measured, measured_at, &sensor_lost);
  output_.module_fault_found = sensor_lost;
  if (!is_plausible_state(measured, layout_) || !std::isfinite(t)) {
    monitor_.reset();
    output_.solve.status = SolveStatus::kInvalidInput;
    output_.solve.reason = "measured state rejected (wrong size, NaN/inf or implausible)";
    fall_back(measured, false, output_.solve.reason);
    return finish(step_start);
  }
  if (const char* stale = monitor_.check(measured, t, measured_at, motion_commanded_since_)) {
    // A stale measurement says nothing about where the vehicle is now: neither an old plan nor the
    // baseline can be trusted on it, so stop safely until fresh measurements return.
    output_.measurement_stale = true;
    refuse(measured, stale);
    return finish(step_start);
  }
  output_.module_fault_found = find_stuck_steering(detector_, measured, measured_at) || sensor_lost;
  // The grip from the last period's measured motion against its prediction, for this step's plans.
  if (friction_ && friction_->observe(measured, measured_at)) use_friction_scale(friction_->scale());
  reference_->begin_cycle();
  if (const char* unusable = reference_->unusable(t)) {
    // No trajectory, or only a stale one: nothing to follow that the planner still stands by.
    refuse(measured, unusable);
    return finish(step_start);
  }
  // A measurement taken before t is rolled forward by the commands sent since (Smith predictor),
  // after the observer's filtering when it is on.
  latency_.estimate(measured, measured_at, t, now_);
  hold_stuck_angles(measured, now_);
  // The time a pre-alignment held the reference does not count on the reference's clock.
  update_problem(t, reference_hold_.reference_time(t));
  bool policy_guess_usable = false;
  const bool baseline_usable = plan_baseline(&policy_guess_usable);
  const bool aligning = baseline_usable && pre_align();
  reference_hold_.set_held(aligning || (baseline_usable && baseline_.awaits_arrival()));
  output_.reference_delay_s = reference_hold_.delay_s();
  if (aligning) return finish(step_start);
  if (options_.tracking_tolerance.enabled()) {
    tube_->set(*problem_, *model_data_, baseline_usable ? &baseline_guess_ : nullptr);
  }
  if (deadline.passed()) {
    // The plan and the problem update alone used the budget: no time is left to solve.
    fall_back(now_, baseline_usable, "no time left to solve after the baseline plan and the problem update");
    return finish(step_start);
  }
  policy_guessed_ = policy_guess_usable;
  baseline_guessed_ = baseline_usable && options_.baseline_guess;
  InitialGuesses guesses;
  if (plan_.valid && plan_age_ == 1) guesses.add(&plan_.inputs);
  if (policy_guess_usable) guesses.add(&baseline_policy_guess_);  // the solver projects each guess
  if (baseline_usable && options_.baseline_guess) guesses.add(&baseline_guess_);

  solved_ = true;
  if (work_clock_) work_clock_->begin_solve();
  const SolveStatus status = solver_->solve(*problem_, guesses, deadline, &solution_, &output_.solve);
  const bool late = clock().now() > step_deadline + to_duration(options_.overrun_grace);
  if (has_solution(status) && solution_.valid && !late && problem_->is_feasible(solution_.inputs, 1e-6)) {
    plan_.inputs = solution_.inputs;
    plan_.states = solution_.states;
    plan_.cost = solution_.cost;
    plan_.valid = true;
    plan_age_ = 0;
    if (options_.tracking_tolerance.enabled() && baseline_usable && tube_->left(*problem_, plan_.states)) {
      send_baseline_commands(now_);
      return finish(step_start);
    }
    apply_decision(plan_.inputs, 0, now_);
    output_.source = CommandSource::kOptimizer;
    output_.reason = output_.solve.reason;
    return finish(step_start);
  }
  const char* why = late ? "the step overran its deadline"
                         : (has_solution(status) ? "the solver returned an infeasible or invalid plan"
                                                 : "the solver failed");
  fall_back(now_, baseline_usable, why);
  return finish(step_start);
}

}  // namespace swerve
