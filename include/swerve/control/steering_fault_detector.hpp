// Finds a steering that stopped following its commands: over a window of control periods, the
// angle change the commands asked of a module (its steering rates run through the steering's lag,
// within its end stops) against the change its measured angle made. A module asked to turn far
// that turns a small share of it, window after window, is stuck. Fixed capacity: no allocation
// after construction.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstddef>

#include "swerve/core/option_fields.hpp"
#include "swerve/core/stamped_history.hpp"
#include "swerve/kinematics/module_faults.hpp"
#include "swerve/kinematics/module_layout.hpp"
#include "swerve/kinematics/module_state.hpp"

namespace swerve {

struct FaultDetectionOptions {
  bool enabled = true;
  // rad: the least turn the window's commands (through the steering's lag) must ask of a module
  // before it is judged. Five standard deviations of the change steering-encoder noise makes of two
  // angles (crab90_noisy's 0.02 rad noise: 0.03 rad), and below what a controller asks of a module
  // stuck a few degrees off its target (the command is the remaining turn per period, up to the
  // rate limit).
  double min_commanded_turn = 0.15;
  // The share of the commanded turn (run through the steering's first-order rate lag) a healthy
  // module makes at least: the rest is what that model misses (noise, the rate limit).
  double max_followed_share = 0.25;
  // Control periods per window, at least: the window is lengthened to what asks min_commanded_turn
  // of a module at half its steering-rate limit (window_periods()).
  int window_cycles = 3;
  // Windows running that must agree. Each measurement ends a window, so they overlap: 2 windows
  // of 3 periods span 4 periods.
  int confirm_cycles = 2;
  static const OptionFields<FaultDetectionOptions>& fields();
  void validate() const;  // throws ConfigError naming the field and value
};

// One value per module with the time it belongs to (s).
struct StampedModuleValues {
  double t = 0.0;
  std::array<double, kMaxModules> values{};
};

// Pushes the steering rates of `commands`, sent at `t`, onto `history` (a non-finite rate as 0: the
// drive holds on it); nothing for a non-finite t or commands not for `modules` modules.
template <int Capacity>
void record_steering_rates(const ModuleArray<ModuleCommand>& commands, double t, int modules,
                           StampedHistory<StampedModuleValues, Capacity>* history) noexcept {
  if (!std::isfinite(t) || commands.size() != modules) return;
  StampedModuleValues& sent = history->push(t);
  for (int i = 0; i < modules; ++i) {
    const double rate = commands[i].steering_rate;
    sent.values[static_cast<std::size_t>(i)] = std::isfinite(rate) ? rate : 0.0;
  }
}

class SteeringFaultDetector {
 public:
  // `steering_lag`: the steering drives' time constant (s; 0: none). Throws ConfigError for
  // invalid options, a non-positive period, a negative lag or a layout of no modules.
  SteeringFaultDetector(const ModuleLayout& layout, double control_period, double steering_lag,
                        FaultDetectionOptions options);

  // The measured steering angles (n) taken at `measured_at` (s). Returns true when it found a
  // module newly stuck (stuck() says which). Non-finite input is ignored. noexcept, no allocation.
  bool observe(const Eigen::Ref<const Eigen::VectorXd>& steering_angles, double measured_at) noexcept;
  // The steering rates sent at `t` (s), acting over the next period.
  void commanded(const ModuleArray<ModuleCommand>& commands, double t) noexcept;
  bool stuck(int module) const noexcept {
    return module >= 0 && module < modules_ && stuck_[static_cast<std::size_t>(module)];
  }
  // Forget the history and every verdict (a new run).
  void reset() noexcept;
  // Forget the verdict on one module (its fault was cleared); out of range: nothing.
  void forget(int module) noexcept {
    if (module < 0 || module >= modules_) return;
    stuck_[static_cast<std::size_t>(module)] = false;
    agreeing_[static_cast<std::size_t>(module)] = 0;
  }
  const FaultDetectionOptions& options() const noexcept { return options_; }
  // The control periods each window spans on this vehicle (see FaultDetectionOptions::window_cycles).
  int window_periods() const noexcept { return window_; }
  // Forgets the verdict on every module `faults` has healthy (a fault cleared by hand).
  void forget_healthy(const ModuleArray<ModuleFault>& faults) noexcept {
    for (int i = 0; i < faults.size(); ++i) {
      if (faults[i] == ModuleFault::kNone) forget(i);
    }
  }

 private:
  static constexpr int kHistory = 128;  // periods kept: windows of up to 120 periods
  using History = StampedHistory<StampedModuleValues, kHistory>;

  FaultDetectionOptions options_;
  ModuleLimits limits_;
  int modules_;
  double period_;
  double steering_lag_;  // s: the steering drives' time constant (0: none)
  int window_;                                       // periods per window
  History angles_, rates_;  // the angles measured and the steering rates sent
  std::array<int, kMaxModules> agreeing_{};  // consecutive windows judged stuck
  std::array<bool, kMaxModules> stuck_{};
};

}  // namespace swerve
