// What every controller of SwerveMPC returns each cycle, and the interface the simulator and a
// vehicle's control loop call: `step(measured_state, t)`, noexcept, allocation-free.
#pragma once

#include <Eigen/Core>

#include <memory>

#include "swerve/core/option_fields.hpp"
#include "swerve/control/lost_steering_angles.hpp"
#include "swerve/control/steering_fault_detector.hpp"
#include "swerve/kinematics/module_faults.hpp"
#include "swerve/kinematics/module_state.hpp"
#include "swerve/ocp/solver.hpp"

namespace swerve {

// The sampling rule every controller's options share (ControllerOptions, BaselineOptions): a
// horizon of 1 to kMaxHorizon steps of dt > 0 each. One table, so the two cannot drift apart.
template <typename Options>
const OptionFields<Options>& horizon_and_step_fields() {
  static const OptionFields<Options> table{
      {"horizon", &Options::horizon, Bound::closed(1, kMaxHorizon)},
      {"dt", &Options::dt, Bound::positive()},
  };
  return table;
}

// Per-step cost weights set for a step of `weights_step` seconds, used at a step of dt (both
// controllers' `weights_step`; 0: off, both factors 1). A stage cost summed over the steps is a
// Riemann sum of a cost per second, so it scales by dt / weights_step; a cost on the change
// between steps (|u_k - u_k-1|^2, the change growing with dt) and the terminal scale, which
// stands for the cost past the horizon (not per step), scale by weights_step / dt.
struct StepRescale {
  double stage = 1.0;
  double per_change = 1.0;
};
inline StepRescale step_rescale(double dt, double weights_step) noexcept {
  if (!(weights_step > 0.0) || !(dt > 0.0)) return {};
  return {dt / weights_step, weights_step / dt};
}

class Reference;

// Where the applied commands came from, worst last. kTrackingFirst: the solve succeeded, but its
// plan left the tracking tolerance, so the kinematic baseline's commands were sent instead.
enum class CommandSource { kOptimizer, kTrackingFirst, kPreviousPlan, kBaseline, kSafeStop };
const char* to_string(CommandSource source) noexcept;  // "optimizer", "tracking_first", "previous_plan", ...

struct ControlOutput {
  ModuleArray<ModuleCommand> modules;
  CommandSource source = CommandSource::kSafeStop;
  const char* reason = "";     // static text
  SolveSummary solve;          // of this cycle's solve (status kNotRun when none ran)
  double step_time_s = -1.0;   // the whole step(), on the controller's clock (< 0 before the first)
  bool measurement_stale = false;  // the measurement was judged stale this cycle (see Controller)
  // s the controller's reference clock runs behind t: it tracks the reference at t - this. 0 except
  // where a controller holds the reference while it prepares (the practical baseline's
  // pre-alignment); the delay is the run's completion time lost, and its tracking is judged there.
  double reference_delay_s = 0.0;
  // The step's clock cut a work-budgeted solve short (ControllerOptions::work_budget): the machine
  // ran slower than the budget's rates, and this answer depends on its speed.
  bool work_budget_cut = false;
  // This step's detector found a module fault (TrackingController::module_faults() says which).
  bool module_fault_found = false;
  // The floor's grip the controller's prediction used, as a multiple of the tire's mu (1: the
  // tire's own; controllers without a tire model report 1).
  double friction_scale = 1.0;
};

class TrackingController {
 public:
  TrackingController() = default;
  virtual ~TrackingController() = default;
  // A copy has faults of its own (copied); a move takes them along, so a moved controller's
  // prediction model keeps reading the faults it was given.
  // A moved-from controller may only be destroyed or assigned to.
  TrackingController(const TrackingController& other)
      : clock_(other.clock_),
        faults_(std::make_unique<ModuleFaults>(other.faults_ ? *other.faults_ : ModuleFaults())) {}
  TrackingController& operator=(const TrackingController& other) {
    clock_ = other.clock_;
    faults_ = std::make_unique<ModuleFaults>(other.faults_ ? *other.faults_ : ModuleFaults());
    return *this;
  }
  TrackingController(TrackingController&&) noexcept = default;
  TrackingController& operator=(TrackingController&&) noexcept = default;
  virtual const char* name() const noexcept = 0;
  // `measured_state`: pose_world (x, y, psi), v_body (vx, vy, r), steering angles delta_1..n, taken
  // at `measured_at` (s, the same time base as t; a measurement older than the controller accepts
  // is stale).
  virtual const ControlOutput& step(const Eigen::Ref<const Eigen::VectorXd>& measured_state, double t,
                                    double measured_at) noexcept = 0;
  // Between steps, after the commands went out: the work of the step at t_next that needs no
  // measurement (the real-time iteration's preparation; Controller with the rti backend). The
  // step at t_next then only does the rest, its feedback. true when something was prepared; the
  // default has no such work. noexcept, allocation-free.
  virtual bool prepare(double /*t_next*/) noexcept { return false; }
  // A measurement taken now.
  const ControlOutput& step(const Eigen::Ref<const Eigen::VectorXd>& measured_state, double t) noexcept {
    return step(measured_state, t, t);
  }
  // Forget plans and remembered inputs (a new run from a new state).
  virtual void reset() noexcept = 0;
  // Follow another reference from the next step on: a replanned trajectory, for single-threaded
  // use (a planner on its own thread publishes into a TrajectoryReference instead). Plans, warm
  // starts and flip memory are kept; the next window is sampled from the new reference. Not for
  // the real-time path: releasing the old reference may free it. Throws ConfigError for null.
  virtual void set_reference(std::shared_ptr<const Reference> reference) = 0;

  // A module fault taken from the next step on (ModuleFault::kNone clears it): a stuck steering
  // gets no steering rate and its wheel rolls along its angle; the wear-aware controller's plans
  // and prediction take it too, and a dead drive's free wheel in the prediction (its commands are
  // unchanged: its steering still keeps it rolling without drag). Throws ConfigError naming the module when the vehicle has no such
  // module (or the fault is not a ModuleFault). Between steps, on the thread that calls step() and
  // prepare(): not from the real-time path, and not concurrently with it.
  void set_module_fault(int module, ModuleFault fault);
  // The floor's grip as a multiple of the vehicle's tire mu, known (a map of the floor): a
  // controller whose prediction has tires takes it (Controller::set_friction_scale); one without
  // (the kinematic baseline) has nothing to take it into, and only checks it. Throws ConfigError
  // unless finite and within (0, 10].
  virtual void set_friction_scale(double scale);
  // Each module's accumulated tire wear (wear units, e.g. from the tread each has left), for wear
  // balancing (Controller with WearBalancingOptions::enabled); a controller without it only checks
  // it. Throws ConfigError naming the entry unless there is one per module, each finite and >= 0.
  // Between steps, like set_module_fault.
  virtual void set_module_wear(const Eigen::Ref<const Eigen::VectorXd>& wear);
  // Every module's fault: those set above and those the controller's own detector found.
  const ModuleFaults& module_faults() const noexcept { return *faults_; }

  // The clock step() is timed and its deadline kept on: the steady clock unless a test or a
  // simulated-time host injects another. Not owned; it must outlive the controller.
  void set_clock(const Clock& clock) noexcept { clock_ = &clock; }
  const Clock& clock() const noexcept { return *clock_; }

 protected:
  // Every derived constructor: one entry per module, all healthy.
  void size_module_faults(int modules) { *faults_ = ModuleFaults(modules, ModuleFault::kNone); }
  // `detector` on the measurement (6 + n) taken at `measured_at`: the modules it newly finds stuck
  // become kStuckSteering faults from this step on; true when one did.
  bool find_stuck_steering(SteeringFaultDetector& detector, const Eigen::Ref<const Eigen::VectorXd>& measured,
                           double measured_at) noexcept;
  // `angles` on the measurement (6 + n) taken at `measured_at`: when it stands in for steering
  // angles that were not finite, the repaired measurement, and each module it stood in for that was
  // healthy becomes a kSteeringSensorLost fault (*found: whether one did); otherwise `measured`.
  Eigen::Ref<const Eigen::VectorXd> stand_in_for_lost_angles(LostSteeringAngles& angles,
                                                             const Eigen::Ref<const Eigen::VectorXd>& measured,
                                                             double measured_at, bool* found) noexcept;
  // After the latency compensation rolled a measurement forward by the rates sent: a stuck module
  // did not turn, whatever was sent before its fault was known. `now` (6 + n) takes the measured
  // angles (6 + n) of the stuck modules.
  void hold_stuck_angles(const Eigen::Ref<const Eigen::VectorXd>& measured, Eigen::Ref<Eigen::VectorXd> now) const noexcept;
  // After the faults changed: what a controller built of others passes on (the wear-aware one to
  // its baseline). The faults live on the heap, so a moved controller's model keeps reading them.
  virtual void module_faults_changed() noexcept {}

 private:
  const Clock* clock_ = &steady_clock();
  std::unique_ptr<ModuleFaults> faults_ = std::make_unique<ModuleFaults>();
};

}  // namespace swerve
