// The one interface every optimiser backend implements: solve an OcpProblem from initial guesses
// before a wall-clock deadline, always returning the best feasible input sequence found and a
// status. The base class does the parts every backend shares (input checks, timing, the final
// NaN check), so backends only implement do_solve (non-virtual interface, as in Drake).
#pragma once

#include <Eigen/Core>

#include "swerve/ocp/ocp_problem.hpp"
#include "swerve/ocp/deadline.hpp"

namespace swerve {

enum class SolveStatus { kNotRun, kConverged, kBudgetExhausted, kInfeasible, kNumericalError, kInvalidInput };

// "converged", "budget_exhausted", ...: the same word in YAML, CSV and summary.json.
const char* to_string(SolveStatus status) noexcept;
// A usable plan came back (converged or stopped by its budget with a feasible answer).
inline bool has_solution(SolveStatus status) noexcept {
  return status == SolveStatus::kConverged || status == SolveStatus::kBudgetExhausted;
}

struct SolveSummary {
  SolveStatus status = SolveStatus::kNotRun;
  const char* reason = "solve() not called";  // static text: never allocated on the real-time path
  int iterations = -1;
  long rollouts = -1;
  CostBreakdown cost;           // of the returned plan
  double initial_cost = -1.0;   // of the best initial guess
  double solve_time_s = -1.0;   // on the deadline's clock
  // How far past its deadline the backend returned (0: on time). A backend stops so that it is
  // on time; an operating-system stall, or a step it could not interrupt (Ipopt's first iterate),
  // can still make it late, and then it is said here rather than left to the caller's clock.
  double late_s = 0.0;
  // What only one backend reports lives with that backend (e.g. IpoptSolver::last_details()).
};

// A plan over the horizon: inputs (nu x N) and the states they predict (nx x N+1).
struct Solution {
  Eigen::MatrixXd inputs;
  Eigen::MatrixXd states;
  double cost = 0.0;
  bool valid = false;

  void resize(int state_size, int input_size, int horizon);
  // Receding horizon: drop the first step and repeat the last (the warm start of the next cycle).
  void shift() noexcept;
  // Moves the plan on by `steps` (> 0) of its steps, a fraction when the controller's period is
  // shorter than the prediction step: column k becomes the plan linearly interpolated at k + steps,
  // the last column repeated past the end. shift(1) is shift(), bit for bit. Non-finite or <= 0:
  // unchanged.
  void shift(double steps) noexcept;
};

// Up to kMaxGuesses input sequences (nu x N) the solver starts from, the most promising first; it
// returns nothing worse than the best of those its deadline let it roll out (after projection onto
// the bounds), and the first usable one is always rolled out.
struct InitialGuesses {
  static constexpr int kMaxGuesses = 4;
  const Eigen::MatrixXd* sequences[kMaxGuesses] = {nullptr, nullptr, nullptr, nullptr};
  int count = 0;
  bool add(const Eigen::MatrixXd* sequence) noexcept {
    if (sequence == nullptr || count >= kMaxGuesses) return false;
    sequences[count++] = sequence;
    return true;
  }
};

// What one rollout with every stage's exact Jacobians costs against a plain rollout (measured: 4-7x
// on the swerve problems); the gradient backends budget their first evaluation with it.
inline constexpr int kJacobianRolloutCost = 8;

// The start every backend shares: the cheapest usable guess (right size, finite), projected onto
// the bounds, or zero inputs projected when no guess is usable. Holds its own scratch, sized for
// one problem shape at construction; choose() is noexcept and allocates nothing.
class StartPlan {
 public:
  explicit StartPlan(const OcpProblem& shape);

  // Rolls out the usable guesses in order and keeps the cheapest. The first usable guess is always
  // rolled out; each further one only while the deadline leaves room for it and one more rollout,
  // both priced at the dearest rollout so far: near standstill a rollout costs ~10x one in cruise,
  // and a solve that spent its budget on its candidates' rollouts returned late with no iteration.
  // Returns the start's cost (+inf when the model failed).
  double choose(const OcpProblem& problem, const InitialGuesses& guesses, const Deadline& deadline) noexcept;

  // The start chosen: inputs (nu x N), its rollout's states (nx x N+1), stage costs and wear (N).
  const Eigen::MatrixXd& inputs() const noexcept { return inputs_; }
  const Eigen::MatrixXd& states() const noexcept { return states_; }
  const Eigen::VectorXd& stage_costs() const noexcept { return stage_costs_; }
  const Eigen::VectorXd& stage_wear() const noexcept { return stage_wear_; }
  double cost() const noexcept { return cost_; }
  // The start's cost split into its parts, from its own rollout (no model step).
  CostBreakdown breakdown(const OcpProblem& problem) const noexcept {
    return problem.breakdown(inputs_, states_, stage_wear_);
  }
  // Of the last choose(): the rollouts done, the usable guesses left unrolled for want of time, and
  // the dearest rollout on the deadline's clock (the backends' first price of a full rollout).
  int rollouts() const noexcept { return rollouts_; }
  int skipped() const noexcept { return skipped_; }
  Duration longest_rollout() const noexcept { return longest_rollout_; }

 private:
  // Rolls candidate_inputs_ out on the candidate buffers and keeps it when cheaper than the best.
  void try_candidate(const OcpProblem& problem, const Deadline& deadline) noexcept;

  Eigen::MatrixXd inputs_, states_, candidate_inputs_, candidate_states_;
  Eigen::VectorXd stage_costs_, stage_wear_, candidate_stage_costs_, candidate_stage_wear_;
  double cost_ = 0.0;
  bool found_ = false;
  int rollouts_ = 0, skipped_ = 0;
  Duration longest_rollout_{};
  PredictionWorkspace workspace_;  // the candidates' step scratch
};

class Solver {
 public:
  virtual ~Solver() = default;
  virtual const char* name() const noexcept = 0;

  // noexcept: every failure is a status. `out` must have been resized for the problem (the
  // controller does this at construction); a problem of another shape than the one the solver was
  // built for is refused with kInvalidInput. Guesses of the wrong size or with NaN are skipped;
  // with no usable guess the solver starts from zero inputs projected onto the bounds.
  SolveStatus solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline, Solution* out,
                    SolveSummary* summary) noexcept;

  // The real-time iteration's preparation phase (Diehl, Bock & Schloeder, SIAM J. Control Optim.
  // 43(5), 2005): the work of the next solve that does not need its measurement, done before the
  // measurement arrives. `problem` is the next cycle's problem with its initial state and previous
  // input as predicted; the solve() that follows, on the same problem with the measured ones (the
  // same reference, tube and weights), then only does the feedback. Any other next problem gets a
  // whole solve. true when the backend prepared; false when it has no such phase (every backend but
  // rti), the problem was refused (as solve() refuses it) or the deadline stopped the preparation.
  // noexcept, allocation-free.
  bool prepare(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline) noexcept;
  // Drops a preparation the next solve() must not use (a cycle passed without a solve, so it was
  // made for a problem that is gone, though its reference may look the same at a standstill).
  virtual void forget_preparation() noexcept {}
  // Whether prepare() can do anything: a caller need not build the next problem otherwise.
  virtual bool has_preparation() const noexcept { return false; }

 protected:
  // Every backend is built for one problem shape (its buffers are sized for it), with the model's
  // scratch for `threads` threads.
  explicit Solver(const OcpProblem& shape, int threads = 1)
      : state_size_(shape.state_size()), input_size_(shape.input_size()), horizon_(shape.horizon()),
        workspace_(shape.model(), threads) {}
  // Thread `thread`'s scratch for the model of the problem being solved (solve() binds it).
  PredictionData& model_data(int thread = 0) noexcept { return workspace_.data(thread); }

 private:
  virtual SolveStatus do_solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline,
                               Solution* out, SolveSummary* summary) noexcept = 0;
  virtual bool do_prepare(const OcpProblem& /*problem*/, const InitialGuesses& /*guesses*/,
                          Deadline /*deadline*/) noexcept {
    return false;
  }
  // The problem checks solve() and prepare() share: nullptr when `problem` can be solved.
  const char* refusal(const OcpProblem& problem, const Deadline& deadline, TimePoint start) const noexcept;

  int state_size_, input_size_, horizon_;
  PredictionWorkspace workspace_;
};

}  // namespace swerve
