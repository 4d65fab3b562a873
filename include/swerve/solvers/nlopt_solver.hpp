// The NLopt backend (libnlopt-cxx-dev): single shooting over the whole input sequence with one of
// NLopt's derivative-free local algorithms (BOBYQA by default), the OcpProblem's input boxes as
// NLopt bounds and its per-step change bounds by projection, a wall-clock deadline through
// set_maxtime and a stop check in the objective. It starts from the best initial guess and returns
// the best point it evaluated. Gradient algorithms (LD_*) need exact derivatives of the prediction
// model, which it does not provide yet, so they are rejected at configuration.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "swerve/solvers/solver.hpp"

namespace swerve {

struct NloptOptions {
  std::string algorithm = "LN_BOBYQA";  // LN_BOBYQA | LN_COBYLA | LN_SBPLX | LN_NELDERMEAD
  double xtol_rel = 1e-8;
  double ftol_rel = 1e-12;
  int max_evaluations = 200000;         // the deadline usually stops it first
  double initial_step_fraction = 0.1;   // first trust-region / simplex step / each input's half-range
  void validate() const;                // ConfigError naming the field and value
};

class NloptSolver final : public Solver {
 public:
  // Sizes every buffer for the problem's shape (NLopt itself allocates inside each solve).
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
  std::unique_ptr<Evaluation> evaluation_;
  std::vector<double> x_, lower_, upper_, step_;
};

}  // namespace swerve
