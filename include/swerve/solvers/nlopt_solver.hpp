// The NLopt backend (libnlopt-cxx-dev): single shooting over the whole input sequence, the
// OcpProblem's input boxes as NLopt bounds, a wall-clock deadline through set_maxtime and a stop
// check in the objective. It starts from the best initial guess and returns the best feasible
// point it evaluated (never worse than the start).
//   Gradient algorithms (LD_SLSQP by default, LD_MMA, LD_CCSAQ, LD_LBFGS) get the exact gradient
// of the cost (adjoint recursion over the model's Jet Jacobians, OcpDerivatives) and the per-step
// change bounds as linear inequality rows (LD_LBFGS takes bounds only: its answer is projected).
//   Derivative-free ones (LN_BOBYQA, LN_COBYLA, LN_SBPLX, LN_NELDERMEAD) are kept for comparison;
// they evaluate the projected sequence, so the change bounds hold by projection.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "swerve/core/option_fields.hpp"
#include "swerve/ocp/solver.hpp"

namespace swerve {

class OcpDerivatives;

struct NloptOptions {
  std::string algorithm = "LD_SLSQP";  // LD_SLSQP | LD_MMA | LD_CCSAQ | LD_LBFGS | LN_BOBYQA | ...
  double xtol_rel = 0.0;   // off: at 1e-8 SLSQP stopped early at a worse point of the swerve problem
  double ftol_rel = 1e-12;
  int max_evaluations = 200000;         // the deadline usually stops it first
  double initial_step_fraction = 0.1;   // first trust-region / simplex step / each input's half-range
  // The rules, read by the YAML loader too. Inline (no NLopt needed), so a program without this
  // backend still reads and checks a controller file's nlopt section.
  static const OptionFields<NloptOptions>& fields();
  void validate() const;                // ConfigError naming the field and value
};

inline const OptionFields<NloptOptions>& NloptOptions::fields() {
  static const OptionFields<NloptOptions> table{
      {"algorithm", &NloptOptions::algorithm, Bound::any(),
       {"LD_SLSQP", "LD_MMA", "LD_CCSAQ", "LD_LBFGS", "LN_BOBYQA", "LN_COBYLA", "LN_SBPLX", "LN_NELDERMEAD"},
       nullptr, "(LD_*: with the exact gradient)"},
      {"xtol_rel", &NloptOptions::xtol_rel, Bound::non_negative()},
      {"ftol_rel", &NloptOptions::ftol_rel, Bound::non_negative()},
      {"max_evaluations", &NloptOptions::max_evaluations, Bound::at_least(1)},
      {"initial_step_fraction", &NloptOptions::initial_step_fraction, Bound::half_open(0.0, 1.0)},
  };
  return table;
}

inline void NloptOptions::validate() const { check_fields("NloptOptions", *this, fields()); }

class NloptSolver final : public Solver {
 public:
  // Sizes every buffer for the problem's shape (NLopt itself allocates inside each solve). A
  // gradient algorithm on a model without Jacobians is a ConfigError.
  NloptSolver(const OcpProblem& problem_shape, NloptOptions options);
  ~NloptSolver() override;
  const char* name() const noexcept override { return "nlopt"; }
  const NloptOptions& options() const noexcept { return options_; }

  struct Evaluation;  // the objective's context (defined in the source)

 private:
  SolveStatus do_solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline, Solution* out,
                       SolveSummary* summary) noexcept override;

  NloptOptions options_;
  int nx_, nu_, horizon_;
  StartPlan start_;  // the cheapest guess, rolled out
  std::unique_ptr<Evaluation> evaluation_;
  std::unique_ptr<OcpDerivatives> derivatives_;  // gradient algorithms
  unsigned step_row_count_ = 0;
  std::vector<double> step_row_tolerances_;
  std::vector<double> x_, lower_, upper_, step_;
};

}  // namespace swerve
