// The wear-aware receding-horizon controller: each step() updates the optimal control problem in
// place from the measured state and the reference, solves it from the shifted previous plan and
// the kinematic baseline's plan before a wall-clock deadline, and returns module commands. On a
// failed, late or invalid solve it falls back (previous plan while it is fresh, then the baseline,
// then a safe stop) and says why. step() is noexcept; with the SA backend (and in every fallback,
// the kinematic baseline included) it allocates nothing after construction. Ipopt, NLopt and Ceres
// allocate inside their libraries on every solve (measured at 4 modules, N = 20: Ipopt ~15 000,
// Ceres ~2 000, NLopt 13 allocations per step): choose SA where a hard no-allocation rule holds.
#pragma once

#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "swerve/core/option_fields.hpp"
#include "swerve/models/vehicle_params.hpp"
#include "swerve/control/actuator_estimator.hpp"
#include "swerve/control/fallback_ladder.hpp"
#include "swerve/control/friction_estimator.hpp"
#include "swerve/control/kinematic_baseline.hpp"
#include "swerve/control/latency_compensator.hpp"
#include "swerve/control/measurement_monitor.hpp"
#include "swerve/ocp/ocp_problem.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/control/reference_hold.hpp"
#include "swerve/control/steering_fault_detector.hpp"
#include "swerve/control/tracking_controller.hpp"
#include "swerve/control/tracking_tube.hpp"
#include "swerve/control/wear_balancing.hpp"
#include "swerve/ocp/twist_prediction_model.hpp"
#include "swerve/ocp/vehicle_prediction_model.hpp"
#include "swerve/ocp/work_budget.hpp"

namespace swerve {

// What the optimiser searches over. kBodyTwist (default): a body twist per step, turned into module
// commands by TwistPredictionModel, so every candidate is kinematically consistent. kModuleRates:
// the paper's inputs, a steering rate and a wheel speed per module (2n per step).
enum class InputParameterization { kBodyTwist, kModuleRates };
const char* to_string(InputParameterization parameterization) noexcept;  // "body_twist", "module_rates"

// Tracking-tolerance mode (ControllerOptions::tracking_tolerance): the tracking error the user
// accepts. The controller then minimises wear inside a tube around the reference (TrackingTube:
// the tolerance, or the baseline's own predicted error where larger); a solved plan that leaves
// it is not sent, the baseline's commands are (CommandSource::kTrackingFirst). Both bounds 0: off
// (the wear weight alone trades tracking for wear).

struct ControllerOptions {
  int horizon = 20;                  // N (docs/paper.md, assumption 7)
  double dt = 0.05;                  // s: the prediction's step
  // s between step() calls; 0: dt. A prediction step longer than the period looks as far ahead with
  // fewer steps (cheaper rollouts; the dt axis of the tuning search); the previous plan then moves on by
  // period / dt of a step each cycle (Solution::shift(double)). At most dt.
  double control_period = 0.0;
  double period() const noexcept { return control_period > 0.0 ? control_period : dt; }
  double solve_budget = 0.02;        // s of wall clock for the whole step(): baseline plan, problem update, solve
  double overrun_grace = 0.002;      // s past the deadline before an answer counts as late
  // Share of solve_budget kept free at the end of each step, for the work after the solve and for
  // an operating-system stall. The controller widens the margin to 1.5x the largest overshoot past
  // the solver's deadline it has measured (that memory halving every 100 steps), so one stall
  // does not become a run of deadline misses. At most half the budget.
  double deadline_margin = 0.05;
  // When enabled, the solve stops at solve_budget x (1 - deadline_margin) counted in work at the
  // target's rates (WorkBudgetClock), so its answer is the same on every machine and in every run;
  // the step's clock is then only the guard, half of the margin later (see solve_margin()).
  WorkBudgetOptions work_budget;
  Eigen::Vector3d pose_weight{10.0, 10.0, 5.0};
  // When true the heading weight is the position weight times (heading_lever R)^2, R the distance
  // of the outermost module from the body origin: a heading error then costs what the displacement
  // it causes at heading_lever R costs, so one config serves a 2-module robot and a 5-axle carrier.
  // heading_lever 1 weighs it at the outermost module; the default config's 2.5 corrects heading as fast
  // as the kinematic baseline does (see configs/controllers/default.yaml).
  bool heading_weight_from_geometry = false;
  double heading_lever = 1.0;        // > 0; used only with heading_weight_from_geometry
  // Pseudo-Huber width of the pose cost (m; 0: quadratic). Errors beyond it are priced at the
  // quadratic's slope at the width, so a higher pose weight stiffens the tracking of small errors
  // without making a hard start's large ones dominate the wear (see CostWeights::pose_huber_width).
  double pose_huber_width = 0.0;
  Eigen::Vector3d twist_weight{0.0, 0.0, 0.0};
  double terminal_scale = 10.0;
  // s: the prediction step the per-step weights were set for; 0: off (the weights as written at
  // any dt). When set, a dt other than it rescales them so that the same motion costs the same
  // per second of the horizon: the stage weights (pose, twist, efforts, the tube's penalty) by
  // dt / weights_step, the smoothness weights on the change per step by weights_step / dt (a
  // change per step grows with dt), and terminal_scale by weights_step / dt (the terminal weight
  // stands for the cost past the horizon, which does not depend on the step). The wear is
  // energy per step and sums to the same over the horizon at any dt.
  double weights_step = 0.0;
  double wear_weight = 1.0;          // lambda; 0 gives the dynamic controller without wear
  // When > 0, the wear weight is the one for a vehicle of this mass (kg), and the controller uses
  // wear_weight * wear_reference_mass / mass on its own vehicle. Frictional-power wear of the same
  // motion grows with the mass (forces grow with m, and so does each tire's cornering and slip
  // stiffness, so the slips stay the same), while the tracking cost does not: one wear weight
  // then buys the same tracking on a 50 kg robot and a 2 t carrier. 0: off.
  double wear_reference_mass = 0.0;
  // The power of (wear_reference_mass / mass) the wear weight scales by: 1 is the argument above;
  // > 1 also weighs what the argument leaves out (see configs/controllers/default.yaml). > 0.
  double wear_mass_exponent = 1.0;
  double steering_rate_effort = 0.01;
  double wheel_speed_effort = 0.0;
  double steering_rate_smoothness = 0.05;
  double wheel_speed_smoothness = 0.01;
  PredictionOptions prediction;
  InputParameterization parameterization = InputParameterization::kBodyTwist;
  double twist_smoothness = 1.0;     // S on the change of the body twist per step (kBodyTwist)
  // A price on the steering rates the prediction carries (PredictionOptions::steering_lag, on a
  // vehicle whose steering lags): the modules' mean squared predicted steering rate per step, times
  // this. Body-twist inputs do not show the steering rates they command, and a steering swing that
  // the lag turns back within a period moves the predicted pose by almost nothing: without a
  // price the optimiser traded such swings for the last micro-metre of tracking, and in closed
  // loop they became a period-2 limit cycle (docs/decisions/steering-effort.md). 0: no price, and
  // none either without steering-rate states.
  double steering_effort = 0.0;
  // Also start the solver from the kinematic baseline's plan: as planned, and with body-twist
  // inputs also run as a policy through the prediction (see close_baseline_loop).
  bool baseline_guess = true;
  int max_plan_age = 5;              // cycles a previous plan may stand in for a failed solve
  StalenessOptions stale_measurement;  // when a measurement is too old or frozen to act on
  TrackingTolerance tracking_tolerance;  // off by default
  MeasurementFilterOptions measurement_filter;  // off by default (gains 1)
  // The stuck-steering detector (SteeringFaultDetector); a module it finds is taken as
  // set_module_fault(i, kStuckSteering) would.
  FaultDetectionOptions fault_detection;
  // The floor's grip estimated online (FrictionEstimator) and given to the prediction; off by
  // default (docs/decisions/friction-estimation.md).
  FrictionEstimationOptions friction_estimation;
  // Each module's wear weighed by its accumulated wear (set_module_wear); off by default. Needs the
  // semi-implicit prediction.
  WearBalancingOptions wear_balancing;
  // The rules of the fields, read by the YAML loader too: the sampling (horizon, dt; shared with the
  // baseline), the timing and replanning fields, and the cost weights (their YAML keys under
  // `weights:`). The nested options have tables of their own.
  static const OptionFields<ControllerOptions>& sampling_fields();
  static const OptionFields<ControllerOptions>& timing_fields();
  static const OptionFields<ControllerOptions>& weight_fields();
  void validate() const;             // throws ConfigError naming the field and value
  // The wear weight the cost uses on a vehicle of `vehicle_mass` kg: wear_weight, scaled by
  // (wear_reference_mass / vehicle_mass)^wear_mass_exponent when wear_reference_mass > 0.
  double effective_wear_weight(double vehicle_mass) const noexcept {
    return wear_reference_mass > 0.0 ? wear_weight * std::pow(wear_reference_mass / vehicle_mass, wear_mass_exponent)
                                     : wear_weight;
  }
};

class Controller final : public TrackingController {
 public:
  using SolverFactory = std::function<std::unique_ptr<Solver>(const OcpProblem&)>;

  // Throws ConfigError for invalid options or parameters. The baseline options' horizon and dt
  // are overridden by the controller's so both plan over the same window, and their weights_step,
  // when 0, is the controller's (both sets of weights were set for the same step).
  Controller(const VehicleParams& vehicle, std::shared_ptr<const Reference> reference, ControllerOptions options,
             const SolverFactory& make_solver, BaselineOptions baseline_options = BaselineOptions{},
             std::string name = "wear_mpc");

  const char* name() const noexcept override { return name_.c_str(); }
  using TrackingController::step;
  const ControlOutput& step(const Eigen::Ref<const Eigen::VectorXd>& measured_state, double t,
                            double measured_at) noexcept override;
  void reset() noexcept override;
  // With a backend that has a preparation phase (rti): the next step's problem as this step's plan
  // predicts it (its state at t_next, the reference window there, the input just sent) handed to
  // the solver's prepare(), so that step only runs the feedback. Nothing is prepared after a step
  // whose commands did not come from a fresh plan, or with a tracking tolerance (its tube is set
  // from the next step's baseline plan, which needs the measurement). A step at any other t than
  // t_next drops the preparation. Leaves problem() holding the predicted problem until then.
  bool prepare(double t_next) noexcept override;
  void set_reference(std::shared_ptr<const Reference> reference) override;

  // The grip known (TrackingController::set_friction_scale): the prediction takes it from the next
  // step on, and with friction_estimation on the estimate continues from it (then it must also be
  // within the estimate's bounds). Between steps, like set_module_fault.
  void set_friction_scale(double scale) override;
  // The grip the prediction uses now: set above, or estimated (1 until either).
  double friction_scale() const noexcept { return (*friction_scales_)[0]; }
  // With wear_balancing enabled, the prediction weighs module i's wear by wear_balancing_weights()
  // of `wear` from the next step on; otherwise only checked (TrackingController::set_module_wear).
  void set_module_wear(const Eigen::Ref<const Eigen::VectorXd>& wear) override;
  // Module i's weight on its wear in the prediction now (1 until set_module_wear with balancing);
  // NaN for a module the vehicle does not have.
  double wear_weight_of(int module) const noexcept {
    if (module < 0 || module >= modules_) return std::numeric_limits<double>::quiet_NaN();
    return (*wear_weights_)[static_cast<std::size_t>(module)];
  }

  const OcpProblem& problem() const noexcept { return *problem_; }
  const Solution& plan() const noexcept { return plan_; }
  const ControllerOptions& options() const noexcept { return options_; }
  const Solver& solver() const noexcept { return *solver_; }

 private:
  // Sends decision column `column` of `plan` (twist or module rates) from `state` (a measured or
  // predicted state, read for its steering angles).
  void apply_decision(const Eigen::Ref<const Eigen::MatrixXd>& plan, int column,
                      const Eigen::Ref<const Eigen::VectorXd>& state) noexcept;
  // Twist decisions: modules the plan's column `column` moves slower than the baseline's steer
  // threshold steer toward the plan's next faster direction for them, or hold (applied_input_).
  void steer_slow_modules_ahead(const Eigen::Ref<const Eigen::MatrixXd>& plan, int column,
                                const Eigen::Ref<const Eigen::VectorXd>& state) noexcept;
  void assume_previous_input(const Eigen::Ref<const Eigen::VectorXd>& measured) noexcept;
  // The reference's twist at problem column `column` in the body frame of `state`'s heading.
  Eigen::Vector3d reference_twist_in_body(Eigen::Index column, const Eigen::Ref<const Eigen::VectorXd>& state) const noexcept;
  // Updates the problem for a step at t from now_: initial state (with the actuator estimate),
  // previous input, the reference over the horizon from reference_t (t less the time it was held).
  void update_problem(double t, double reference_t) noexcept;
  // BaselineOptions::pre_align: whether the wheels wait this step while the modules turn to their
  // first direction of travel (a start from rest, as the practical baseline does); if so, sends
  // the baseline's steering with the wheels at rest.
  bool pre_align() noexcept;
  // Plans the baseline from now_ (the second fallback) and makes its plan the initial guess;
  // *policy_guess_usable when its policy, closed through the prediction, is a guess too. false
  // when the baseline cannot plan.
  bool plan_baseline(bool* policy_guess_usable) noexcept;
  void apply_module_inputs(const Eigen::Ref<const Eigen::VectorXd>& module_inputs,
                           const Eigen::Ref<const Eigen::VectorXd>& steering_angles) noexcept;
  void fall_back(const Eigen::Ref<const Eigen::VectorXd>& measured, bool baseline_usable, const char* why) noexcept;
  // Body-twist inputs: baseline_policy_guess_ from the baseline's plan run as a policy through the
  // prediction model (baseline_states_ its rollout); false when the model failed.
  bool close_baseline_loop() noexcept;
  void send_baseline_commands(const Eigen::Ref<const Eigen::VectorXd>& state) noexcept;
  // fallback_input_ = `input` within the drives' limits (module_bounds_).
  void set_fallback_input(const Eigen::Ref<const Eigen::VectorXd>& input) noexcept {
    fallback_input_ = input.cwiseMax(module_bounds_.lower).cwiseMin(module_bounds_.upper);
  }
  void safe_stop(const Eigen::Ref<const Eigen::VectorXd>& measured) noexcept;
  void module_faults_changed() noexcept override;
  // What every step resets before it looks at the measurement (the output's flags, the solve's
  // summary), and the previous plan moved on by one period.
  void begin_step() noexcept;
  // The prediction's grip from now on (every module); a change of more than 5 % drops an rti
  // preparation, which was linearised at the old one.
  void use_friction_scale(double scale) noexcept;
  // Whether a value the prediction uses changing from `before` to `after` (a grip, a wear weight)
  // makes an rti preparation linearised at `before` worth preparing anew: more than 5 %.
  static bool outdates_preparation(double before, double after) noexcept;
  // Forgets the solver's preparation and the step it was for.
  void drop_preparation() noexcept;
  // A stale measurement or an unusable reference: kInvalidInput with `reason`, the plan dropped, a
  // safe stop.
  void refuse(const Eigen::Ref<const Eigen::VectorXd>& measured, const char* reason) noexcept;
  bool motion_commanded() const noexcept;
  const ControlOutput& finish(TimePoint step_start) noexcept;
  // The time kept free at the end of this step: the solver's deadline is the budget less it
  // (see deadline_margin).
  Duration solve_margin() const noexcept;
  // This step's solver deadline: on the step's clock, or with a work budget on work_clock_ (the
  // step's clock its guard).
  Deadline solve_deadline(TimePoint step_start) noexcept;

  std::string name_;
  ControllerOptions options_;
  ModuleLayout layout_;
  std::unique_ptr<PredictionModel> model_;
  const TwistPredictionModel* twist_model_ = nullptr;  // model_ when parameterised by the body twist
  std::unique_ptr<OcpProblem> problem_;
  std::unique_ptr<PredictionData> model_data_;  // the scratch of the baseline plan's rollouts
  std::unique_ptr<Solver> solver_;
  std::shared_ptr<const Reference> reference_;
  KinematicBaseline baseline_;
  int modules_;
  Solution solution_, plan_;
  int plan_age_ = 0;
  Solution prepared_plan_;  // plan_ moved on by one period: the prediction prepare() starts from
  // This step's baseline guesses moved on by one period (prepare()'s other guesses), and whether
  // this step had them.
  Solution prepared_baseline_, prepared_policy_;
  bool baseline_guessed_ = false, policy_guessed_ = false;
  double prepared_t_ = std::numeric_limits<double>::quiet_NaN();  // the step the solver prepared for
  Eigen::MatrixXd baseline_inputs_;  // 2n x N
  Eigen::MatrixXd baseline_guess_;   // nu x N: the baseline plan in the optimiser's inputs
  Eigen::MatrixXd baseline_policy_guess_;  // nu x N (body twists): the plan's loop closed through the prediction
  Eigen::VectorXd applied_decision_; // nu: the decision applied last cycle
  Eigen::VectorXd applied_input_;    // 2n: the module inputs sent last cycle
  Eigen::VectorXd fallback_input_;   // 2n
  InputBounds module_bounds_;        // the drives' limits on module inputs
  bool previous_input_known_ = false;  // false until a command of ours reaches the drives
  MeasurementMonitor monitor_;
  Eigen::MatrixXd baseline_states_;  // nx x N+1: the baseline's policy rolled out (close_baseline_loop)
  std::optional<TrackingTube> tube_;  // tracking_tolerance's (made with the problem)
  LatencyCompensator latency_;       // rolls a delayed measurement forward to t
  SteeringFaultDetector detector_;   // commands sent against the steering angles measured
  LostSteeringAngles lost_angles_;   // the stand-in for an encoder that stopped reporting
  std::unique_ptr<FrictionEstimator> friction_;  // with options_.friction_estimation enabled
  // The grip each module's tires see in the prediction (observed by model_; on the heap, so a
  // moved controller's model keeps reading it).
  std::unique_ptr<std::array<double, kMaxModules>> friction_scales_;
  // Each module's weight on its own wear (observed by model_ with wear balancing; on the heap as
  // friction_scales_), and its share of the static load (the weights' mean is load-weighted).
  std::unique_ptr<std::array<double, kMaxModules>> wear_weights_;
  std::array<double, kMaxModules> load_shares_{};
  double wear_weight_ = 0.0;         // the cost's wear weight without faults (with one: 0, tracking first)
  Eigen::VectorXd now_;              // 6 + n: the measurement rolled forward to t
  Eigen::VectorXd prediction_state_;  // nx: now_, then the estimated wheel speeds and steering rates
  // The wheel speeds and steering rates the prediction starts from (made with the model, which
  // says which it carries).
  std::optional<ActuatorEstimator> actuators_;
  double overshoot_s_ = 0.0;         // decaying maximum of step end - solver deadline (s)
  TimePoint solve_deadline_{};       // this step's on the step's clock (a work budget's guard), when a solve ran
  // With options_.work_budget enabled; held by pointer so that a moved controller's model and
  // solver never see a clock that moved.
  std::unique_ptr<WorkBudgetClock> work_clock_;
  bool solved_ = false;              // whether this step ran the solver
  double step_t_ = 0.0;              // s: this step's t
  ReferenceHold reference_hold_;     // pre-alignment holds the reference (ControlOutput::reference_delay_s)
  // s: the t from which every command sent asked some module to move (+inf: the last did not).
  double motion_commanded_since_ = std::numeric_limits<double>::infinity();
  ControlOutput output_;
};

}  // namespace swerve
