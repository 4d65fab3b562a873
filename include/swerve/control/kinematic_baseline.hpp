// The paper's comparison controller (arXiv 2506.04752; docs/paper.md, assumption 9): the same
// tracking problem on the kinematic model, without tire dynamics and without wear. A body-twist MPC
//   min sum_k |pose_k+1 - ref|^2_Q (terminal x terminal_scale) + |u_k - u_ref,k|^2_R + |u_k - u_k-1|^2_S
//   (u_-1: the measured twist)
//   pose_k+1 = pose_k + dt [R(psi_k) (vx, vy); r]
// solved exactly each cycle by Gauss-Newton on the heading (the problem is linear-quadratic once
// the headings are fixed, and solved in O(N) by a Riccati recursion), then per-module inverse kinematics with the 180 deg flip; the steering
// reaches its target under the module's rate limit and the wheels run at the IK speed. It is
// tuned for tracking and knows nothing of wear, as the paper defines it.
#pragma once

#include <Eigen/Core>
#include <Eigen/Dense>

#include <memory>

#include "swerve/core/option_fields.hpp"
#include "swerve/kinematics/kinematics.hpp"
#include "swerve/control/steering_fault_detector.hpp"
#include "swerve/kinematics/module_commands.hpp"
#include "swerve/kinematics/module_heading_memory.hpp"
#include "swerve/control/latency_compensator.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/control/reference_hold.hpp"
#include "swerve/control/tracking_controller.hpp"

namespace swerve {

struct BaselineOptions {
  int horizon = 20;
  double dt = 0.05;
  Eigen::Vector3d pose_weight{10.0, 10.0, 5.0};
  double terminal_scale = 10.0;
  Eigen::Vector3d twist_weight{0.05, 0.05, 0.05};  // R on the deviation from the reference twist
  Eigen::Vector3d rate_weight{0.5, 0.5, 0.5};      // S on the change of twist between steps
  // s: the step the weights above were set for; 0: off (as written at any dt). At another dt, Q
  // and R scale by dt / weights_step, S and terminal_scale by weights_step / dt (step_rescale):
  // the baseline run at a target's shorter control period keeps the balance it was tuned for,
  // instead of pricing a change of twist 2.5x lower per second at 20 ms than at 50 ms.
  double weights_step = 0.0;
  int gauss_newton_iterations = 3;
  bool cosine_scaling = false;       // the paper's baseline drives at the IK speed
  // The practical controller's pieces (configs/controllers/practical_baseline.yaml), off for the
  // paper's baseline:
  // - common_scaling (with cosine_scaling): every module's wheel speed scales by the cosine of the
  //   least aligned module's steering error, not by its own, so the modules keep the common centre
  //   of rotation the plan has while they steer. Team 254's and PathPlanner's setpoint generators
  //   limit the chassis step for the same reason (SetpointGenerator's body-first mode).
  // - pre_align: at a start (the vehicle slower than steer_speed_threshold with nothing planned or
  //   the reference standing still, or at a dwell it has arrived at, however it still moves), the
  //   wheels wait until every module is within pre_align_tolerance (rad)
  //   of its first direction of travel, as teams turn the modules before a path starts; the
  //   reference is held meanwhile, so the run is late by the time it took
  //   (ControlOutput::reference_delay_s), not off the path.
  // - pre_align_only_with_end_stops: pre_align only on a vehicle whose modules have steering end
  //   stops. There a module cannot swing across its range while it rolls, so a re-steer that needs
  //   it (an in-place turn after a crab at the stop) has to wait at rest. Without end stops the
  //   wear-aware controller wears less when it steers while rolling
  //   (docs/decisions/pre-alignment.md).
  // - wait_for_arrival (with pre_align): at a dwell (the reference standing still) the vehicle has
  //   not arrived at, the reference waits while the vehicle closes its residual error, and only
  //   then do the modules pre-align for the next leg (arm_pre_alignment). Off here and in the
  //   practical baseline: its heading regulation at a stop is underdamped on the 8-module carrier,
  //   and the wait let it swing (docs/decisions/pre-alignment.md).
  bool common_scaling = false;
  bool pre_align = false;
  bool wait_for_arrival = false;
  bool pre_align_only_with_end_stops = false;
  double pre_align_tolerance = 0.1;
  double flip_hysteresis = 0.1;      // rad around 90 deg, as in KinematicsOptions
  // m/s: a module planned slower than this does not steer toward its planned direction (under
  // sensor noise that direction is noise); it steers toward the next direction planned faster, or
  // holds, and its wheel drives the planned velocity's component along its heading.
  double steer_speed_threshold = 0.03;
  MeasurementFilterOptions measurement_filter;  // off by default (gains 1), as the wear-aware controller's
  // The stuck-steering detector of the baseline run as a controller of its own (step()), as the
  // wear-aware controller's (ControllerOptions::fault_detection).
  FaultDetectionOptions fault_detection;
  // The rules of the fields the YAML file sets (horizon and dt come from the controller's).
  static const OptionFields<BaselineOptions>& fields();
  void validate() const;             // throws ConfigError naming the field and value
};

class KinematicBaseline final : public TrackingController {
 public:
  // `lags`: the vehicle's drive lags, which its latency compensation rolls commands through.
  KinematicBaseline(const ModuleLayout& layout, std::shared_ptr<const Reference> reference, BaselineOptions options,
                    ActuatorLags lags = {});
  const char* name() const noexcept override { return "kinematic_baseline"; }
  using TrackingController::step;
  // The baseline trusts its measurement (the paper's controller); the staleness checks are the
  // wear-aware controller's. A measurement taken before t (measured_at < t) is rolled forward to t
  // by the commands sent since (LatencyCompensator).
  const ControlOutput& step(const Eigen::Ref<const Eigen::VectorXd>& measured_state, double t,
                            double measured_at) noexcept override;
  void reset() noexcept override;
  void set_reference(std::shared_ptr<const Reference> reference) override;

  // The planning core, also used by the wear-aware controller for its initial guess.
  // Plans body twists (3 x N) from `pose_world` moving at `twist_body` for reference poses/twists
  // (3 x N, for steps 1..N), within the drive speed and acceleration limits. The change-of-twist
  // cost starts from the measured `twist_body`; the acceleration limit from `last_command`, the
  // twist commanded last cycle. Drives that follow their commands through a lag measure behind
  // them, and a limit restarted from the measurement each cycle let the plan reach ~40 % of the
  // drive acceleration (the 8-module carrier, 0.1 s drive lag, took 3 s instead of 0.75 s to reach
  // 0.6 m/s). The cost stays on the measurement: started from the command too, it let the plan run
  // ahead of the lagging vehicle and overshoot (offset60_smooth: 164 mm RMSE against 24 mm).
  bool plan_twists(const Eigen::Vector3d& pose_world, const Eigen::Vector3d& twist_body,
                   const Eigen::Vector3d& last_command,
                   const Eigen::Ref<const Eigen::MatrixXd>& reference_poses,
                   const Eigen::Ref<const Eigen::MatrixXd>& reference_twists) noexcept;
  const Eigen::MatrixXd& twist_plan() const noexcept { return twists_; }
  // The last plan as a policy: stage k's twist at the pose `pose_world` (reached by whatever model
  // the caller rolls out), after `previous_twist` (stage k-1's; unused at k = 0), by the plan's
  // Riccati gains and within the same drive limits. At the poses the plan predicts it returns the
  // plan. A caller that closes this loop through a model with lags (the wear-aware controller's
  // prediction) gets the baseline's tracking there; the open-loop plan drifts off it. Valid after
  // plan_twists() returned true; NaN for k outside [0, N) or a non-finite pose or twist.
  Eigen::Vector3d policy_twist(int k, const Eigen::Vector3d& pose_world, const Eigen::Vector3d& previous_twist) const noexcept;
  // Module inputs (2n x N: steering rate, wheel speed per module) that execute the twist plan from
  // the steering angles `steering_angles` (n), under the steering-rate limit.
  void module_inputs(const Eigen::Ref<const Eigen::VectorXd>& steering_angles, Eigen::Ref<Eigen::MatrixXd> inputs) noexcept;
  // The plan's first step was sent: its drive directions become the flip hysteresis' memory, and
  // its twist the next plan's last_command in step().
  void commit_first_step() noexcept {
    heading_memory_ = planned_memory_;
    committed_twist_ = twists_.col(0);
    twist_committed_ = true;
  }
  // Inside another controller (the wear-aware one's baseline): read that controller's module faults
  // instead of this one's own; null: its own again. Not owned: `faults` must outlive this.
  void follow_module_faults(const ModuleFaults* faults) noexcept { followed_faults_ = faults; }
  const BaselineOptions& options() const noexcept { return options_; }
  // Whether starts from rest pre-align on this vehicle (pre_align, and pre_align_only_with_end_stops).
  bool pre_aligns() const noexcept { return pre_aligns_; }
  // pre_align: whether the wheels wait this step (a start from rest whose modules are still more
  // than pre_align_tolerance from their first direction of travel). After plan_twists() and
  // module_inputs() of this step; the wear-aware controller asks it too.
  bool pre_align_holds() noexcept;
  // pre_align: whether the reference waits this step for the vehicle to arrive at a dwell (the
  // reference standing still, the vehicle not yet arrived()): while it closes in, until it has
  // stood one horizon short of the pose (arm_pre_alignment). The controller keeps tracking
  // meanwhile; only the reference's clock stops. After plan_twists().
  bool awaits_arrival() const noexcept { return awaiting_arrival_; }

 private:
  void module_faults_changed() noexcept override { detector_.forget_healthy(module_faults()); }
  // The drive limits: the per-step change of module speed the drive acceleration allows; `to`, or
  // the twist towards it from `from` that changes no module's velocity by more than `most`; and
  // `twist` within the drive speed, reached from `previous` within that change.
  double drive_change_per_step() const noexcept;
  Eigen::Vector3d limit_change(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double most) const noexcept;
  Eigen::Vector3d within_drive_limits(const Eigen::Vector3d& previous, const Eigen::Vector3d& twist) const noexcept;
  // The wheel speeds of plan step k (inputs' odd rows) from the signed speeds and the steering left
  // after the step (signed_speeds_, turn_left_): each module's own cosine, or with common_scaling
  // the least aligned module's for all.
  void wheel_speeds_at(int k, Eigen::Ref<Eigen::MatrixXd> inputs) const noexcept;
  // module_inputs' first part: the twist plan's module angles and speeds (planned_angles_,
  // planned_speeds_) and the step each module's steering aims at (steer_from_), by the at-rest rule
  // while the wheels wait for a start.
  void plan_module_directions(double threshold, bool at_rest_rule) noexcept;
  // plan_twists' last part: arms the pre-alignment at a start, from the vehicle's pose and twist,
  // the plan just made and the reference's pose and twist at its first step.
  void arm_pre_alignment(const Eigen::Vector3d& pose_world, const Eigen::Vector3d& twist_body,
                         const Eigen::Vector3d& reference_pose, const Eigen::Vector3d& reference_twist) noexcept;
  // The speed below which a module is at rest for the pre-alignment: steer_speed_threshold, or the
  // kinematics' hold speed if higher.
  double rest_speed() const noexcept;
  // Whether a body twist moves no module (and no point within the farthest module's radius) as fast
  // as `speed`; at_rest: slower than rest_speed(), at rest for the pre-alignment.
  bool slower_than(const Eigen::Vector3d& twist_body, double speed) const noexcept;
  bool at_rest(const Eigen::Vector3d& twist_body) const noexcept { return slower_than(twist_body, rest_speed()); }
  // Whether the vehicle at `pose_world` has arrived at `reference_pose` for the pre-alignment: its
  // error one the plan could close slower than rest_speed() within its horizon. The motion that
  // closes it is below the steer threshold, where the modules do not steer after it anyway.
  bool arrived(const Eigen::Vector3d& pose_world, const Eigen::Vector3d& reference_pose) const noexcept;
  // Safe-stop commands with `reason`; the ramp restarts from the measured twist next step.
  const ControlOutput& stop_safely(const Eigen::Ref<const Eigen::VectorXd>& measured, const char* reason) noexcept;
  BaselineOptions options_;
  Kinematics kinematics_;
  const ModuleFaults* followed_faults_ = nullptr;  // follow_module_faults (not owned)
  std::shared_ptr<const Reference> reference_;
  int modules_, horizon_;
  ModuleHeadingMemory heading_memory_;                // the flip decisions of the command last sent
  ModuleHeadingMemory planned_memory_;                // the decisions module_inputs made for step 0
  Eigen::MatrixXd twists_;                            // 3 x N
  Eigen::Vector3d committed_twist_ = Eigen::Vector3d::Zero();  // the twist of the last command sent
  bool twist_committed_ = false;                      // false until a plan was sent (start, reset, safe stop)
  Eigen::MatrixXd reference_poses_, reference_twists_;  // 3 x N
  Eigen::MatrixXd inputs_;                            // 2n x N
  Eigen::MatrixXd planned_angles_, planned_speeds_;   // n x N: inverse kinematics of the twist plan
  Eigen::MatrixXi steer_from_;                        // n x N: the step each module's steering aims at
  Eigen::VectorXd angles_;                            // n: steering angles along the plan
  ModuleArray<DriveDirection<double>> directions_;    // n: each module's way round at the plan step being built
  Eigen::VectorXi signs_;                             // n: drive directions along the plan
  Eigen::VectorXd turn_left_, signed_speeds_;         // n: at the plan step being built
  double max_module_radius_ = 0.0;                    // m: the farthest module from the body origin
  double first_step_misalignment_ = 0.0;              // rad: the largest steering error left after step 0
  bool pre_aligns_ = false;                           // options_ on this vehicle (pre_aligns())
  bool aligning_ = true;                              // pre_align: the wheels wait for the steering
  bool awaiting_arrival_ = false;                     // awaits_arrival()
  int arrival_wait_steps_ = 0;                        // steps this dwell has waited for the vehicle
  int stalled_wait_steps_ = 0;                        // those of them with the vehicle at rest
  ReferenceHold reference_hold_;                      // pre-alignment holds the reference
  using Matrix6 = Eigen::Matrix<double, 6, 6>;
  using Vector6 = Eigen::Matrix<double, 6, 1>;
  Eigen::VectorXd weights_, target_;                  // 3N: pose weights and targets of steps 1..N
  Eigen::Vector3d twist_weight_, rate_weight_;        // R and S at this dt (BaselineOptions::weights_step)
  Eigen::VectorXd headings_;                          // N: the headings the rotations are taken at
  Eigen::MatrixXd feedback_;                          // 3 x 6N: the Riccati gains K_k
  Eigen::MatrixXd feedforward_;                       // 3 x N
  Eigen::Vector3d twist_body_ = Eigen::Vector3d::Zero();  // the last plan's measured twist (its u_-1)
  Eigen::Vector3d ramp_start_ = Eigen::Vector3d::Zero();  // where its drive-limit ramp starts

  ModuleStates module_states_;
  LatencyCompensator latency_;
  SteeringFaultDetector detector_;  // run by step() alone
  LostSteeringAngles lost_angles_;  // step()'s stand-in for an encoder that stopped reporting
  double step_t_ = 0.0;             // this step's t
  Eigen::VectorXd now_;                               // 6 + n: the measurement rolled forward to t
  ControlOutput output_;
};

}  // namespace swerve
