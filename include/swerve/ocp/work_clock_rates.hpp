// The work clock's default rates: what a read and a module evaluation cost on this repository's
// reference machine (the 2-core x86-64 build machine, Release build). With both, a work-clock run
// gives each solve about the proposals a wall-clock run there does (docs/decisions/work-clock-rates.md).
#pragma once

namespace swerve {

// A module evaluation in double (one module's forces and wear in the prediction step), as
// BM_Models_PredictionStep times it (its s_per_unit counter).
inline constexpr double kReferenceSecondsPerModuleEvaluation = 3.5e-7;
// A solver's clock read: the rest of a proposal (cost terms, projection, the move) beyond the model.
inline constexpr double kReferenceSecondsPerRead = 8e-6;

// The rates a run's work clock charges (the CLI's --work-clock and --work-clock-evaluation).
struct WorkClockRates {
  double per_read_s = 0.0;  // 0: no work clock, the steady (wall) clock
  double per_module_evaluation_s = kReferenceSecondsPerModuleEvaluation;
};

}  // namespace swerve
