// What every controller of SwerveMPC returns each cycle, and the interface the simulator and a
// vehicle's control loop call: `step(measured_state, t)`, noexcept, allocation-free.
#pragma once

#include <Eigen/Core>

#include "swerve/kinematics/module_state.hpp"
#include "swerve/solvers/solver.hpp"

namespace swerve {

// One module's command for its low-level drives (the paper's hierarchical design).
struct ModuleCommand {
  double steering_angle = 0.0;  // rad, body frame: the angle the steering should reach this cycle
  double steering_rate = 0.0;   // rad/s
  double wheel_speed = 0.0;     // rad/s of the wheel (signed)
};

// Where the applied commands came from, worst last.
enum class CommandSource { kOptimizer, kPreviousPlan, kBaseline, kSafeStop };
const char* to_string(CommandSource source) noexcept;  // "optimizer", "previous_plan", ...

struct ControlOutput {
  ModuleArray<ModuleCommand> modules;
  CommandSource source = CommandSource::kSafeStop;
  const char* reason = "";     // static text
  SolveSummary solve;          // of this cycle's solve (status kNotRun when none ran)
};

class TrackingController {
 public:
  virtual ~TrackingController() = default;
  virtual const char* name() const noexcept = 0;
  // `measured_state`: pose_world (x, y, psi), v_body (vx, vy, r), steering angles delta_1..n.
  virtual const ControlOutput& step(const Eigen::Ref<const Eigen::VectorXd>& measured_state, double t) noexcept = 0;
  // Forget plans and remembered inputs (a new run from a new state).
  virtual void reset() noexcept = 0;
};

}  // namespace swerve
