// The wear-aware controller's fallback ladder: what it sends in a cycle whose solve gave no plan
// it may act on (failed, late, infeasible, or no time left to solve). Its rungs, in order:
//   1. the previous plan, while it still covers this cycle and is at most max_plan_age cycles old;
//   2. the kinematic baseline's commands, when the baseline planned and the measurement is usable
//      (they are computed from it);
//   3. a safe stop.
#pragma once

#include "swerve/control/tracking_controller.hpp"

namespace swerve {

struct FallbackSituation {
  bool plan_valid = false;      // a previous plan exists
  int plan_age = 0;             // cycles since it was solved (it has been shifted as often)
  int max_plan_age = 0;         // ControllerOptions::max_plan_age
  int horizon = 0;              // the plan's stages
  bool baseline_usable = false;  // the baseline planned this cycle
  bool measured_usable = false;  // the measurement is plausible
};

// The rung the situation allows: kPreviousPlan, kBaseline or kSafeStop.
CommandSource choose_fallback(const FallbackSituation& situation) noexcept;

}  // namespace swerve
