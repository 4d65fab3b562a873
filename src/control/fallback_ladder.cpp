#include "swerve/control/fallback_ladder.hpp"

namespace swerve {

CommandSource choose_fallback(const FallbackSituation& s) noexcept {
  // The previous plan, shifted plan_age times, still has a stage for this cycle.
  if (s.plan_valid && s.plan_age <= s.max_plan_age && s.plan_age < s.horizon) return CommandSource::kPreviousPlan;
  if (s.baseline_usable && s.measured_usable) return CommandSource::kBaseline;
  return CommandSource::kSafeStop;
}

}  // namespace swerve
