// Simulated annealing for the wear-aware OCP (the paper's real-time solver, arXiv 2506.04752),
// built for a fixed wall-clock budget: move-blocked offsets on top of the best initial guess,
// proposals kept inside the bounds by projection, incremental rollouts from the first changed
// step, step sizes adapted to the acceptance rate, and no allocation inside solve(). The end of the
// budget may go to a local polish of the best plan (projected L-BFGS on the exact gradient), where
// the annealer's random steps are slow to settle; when no exact gradient fits that share, the polish
// runs L-BFGS over the few knot offsets instead, on forward differences of incremental rollouts.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "swerve/core/option_fields.hpp"
#include "swerve/core/random.hpp"
#include "swerve/ocp/ocp_derivatives.hpp"
#include "swerve/ocp/solver.hpp"

namespace swerve {

struct SaOptions {
  int knots = 6;                           // move-blocking knots over the horizon (0: one per step)
  int max_iterations = 3000;               // proposals per solve; the deadline may stop it earlier
  double initial_acceptance = 0.3;         // T0 so that a typical uphill probe is accepted this often
  double final_temperature_ratio = 1e-3;   // T at max_iterations / T0 (geometric cooling)
  double step_fraction = 0.02;             // initial proposal sigma / each input's half-range
  double target_acceptance = 0.3;          // sigma grows above it and shrinks below it
  int adapt_interval = 10;                 // proposals between sigma updates (a 20 ms solve makes ~100)
  int reheat_interval = 0;                 // proposals between restarts from the best (0: never)
  double probability_one_group = 0.6;      // move one knot of one input group (one module)
  double probability_one_knot = 0.3;       // move one knot of every input; else the whole sequence
  std::uint64_t seed = 1;
  // Share of the time budget kept for the polish: projected L-BFGS steps on the exact gradient from
  // the best plan, each accepted only if it lowers the cost. The annealing leaves it that share
  // only while a gradient (as last timed) fits in it. 0: none. Needs a prediction model with
  // Jacobians (else no polish). Without a deadline, the polish follows the whole annealing schedule.
  double polish_share = 0.0;
  int polish_iterations = 30;              // at most this many polish steps (accepted or tried) per solve
  // When the exact gradient does not fit the polish's share (or the model has none): polish in the
  // knot space instead, L-BFGS over the nu x knots offsets on forward-difference gradients (one
  // rollout per offset, each from its knot's first step on). false: no polish then. Off by default:
  // on the shipped 10-module vehicle it left the closed-loop gap to the optimum where it was
  // (docs/benchmarks.md); it gives a model without Jacobians a polish.
  bool knot_polish = false;
  // Proposals drawn and rolled out together per annealing step, one per thread: the calling thread
  // and threads - 1 workers started with the solver, each rolling out on scratch of its own
  // (a PredictionWorkspace). The cheapest of each batch meets the Metropolis test. 1: one
  // proposal per step, no worker. The workers also linearise the polish's gradient, a share of the
  // stages each. For targets with a core to spare; the answer depends on the seed and the budget,
  // never on the threads' timing.
  int threads = 1;

  // Throws ConfigError naming the field and value.
  // The rules of the fields above (every one but seed), read by the YAML loader too.
  static const OptionFields<SaOptions>& fields();
  void validate() const;  // the table, and the two move probabilities' sum
};

class LbfgsMemory;  // solvers/sa/projected_lbfgs.hpp
class WorkerPool;   // solvers/sa/worker_pool.hpp

class SimulatedAnnealingSolver final : public Solver {
 public:
  // Sizes every buffer for the problem's shape; solve() then allocates nothing.
  SimulatedAnnealingSolver(const OcpProblem& problem_shape, SaOptions options);
  ~SimulatedAnnealingSolver() override;  // stops and joins the workers
  const char* name() const noexcept override { return "sa"; }
  const SaOptions& options() const noexcept { return options_; }

 private:
  SolveStatus do_solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline, Solution* out,
                       SolveSummary* summary) noexcept override;

  // Chooses the start among the guesses (StartPlan) and makes it the current plan; returns its
  // cost (not finite: the model failed on every guess).
  double start_from_guesses(const OcpProblem& problem, const InitialGuesses& guesses, const Deadline& deadline) noexcept;
  struct PolishResult {
    bool polished = false;  // at least one step taken
    bool exact = false;     // by the exact polish (else the knot polish)
  };
  struct BudgetPlan;
  // The polish phase of `plan` on the best plan *out: the exact polish, or the knot polish when no
  // gradient fits. `longest_proposal`: the slowest proposal of the annealing.
  PolishResult polish_best(const OcpProblem& problem, const Deadline& deadline, const BudgetPlan& plan,
                           Duration full_rollout, Duration longest_proposal, Solution* out, long* rollouts) noexcept;
  // The summary's reason for how the solve ended.
  static const char* solve_reason(bool deadline_hit, const PolishResult& polish) noexcept;

  // How a solve spends its budget: the annealing until anneal_end (its progress measured over
  // loop_budget seconds), then the exact polish or, when no gradient fits, the knot polish.
  struct BudgetPlan {
    bool exact_polish = false, knot_polish_allowed = false, polishing = false;
    TimePoint anneal_end{};
    double loop_budget = 0.0;
  };
  // The plan from the slowest gradients seen (each decayed by 1/16 here) and the time of a full
  // rollout; reads no clock.
  BudgetPlan plan_budget(const Deadline& deadline, TimePoint loop_start, Duration full_rollout) noexcept;
  // The acceptance rule: kProbeMoves greedy probes whose mean uphill step sets T0 (so that it is
  // accepted with probability initial_acceptance), then Metropolis at T0 ratio^progress. `draw` is
  // a uniform draw in [0, 1), used only once calibrated and uphill.
  struct Schedule {
    int probes = 0, uphill_count = 0;
    double uphill_sum = 0.0, calibration_cost = 0.0;
    double initial_temperature = std::numeric_limits<double>::infinity();
    bool accepts(double delta, double progress, double initial_acceptance, double final_temperature_ratio,
                 double draw) noexcept;
  };
  // Draws a batch (one proposal here, one per worker), rolls it out and leaves the cheapest in the
  // candidate buffers with its cost in *candidate_cost; false when the projection undid every move.
  bool evaluate_batch(const OcpProblem& problem, long* rollouts, double* candidate_cost) noexcept;
  // The candidate becomes the current plan (and the best one, with *out, when it is cheaper).
  void take_candidate(double candidate_cost, double* current_cost, double* best_cost, Solution* out) noexcept;
  // The current plan restarts from `best` with zero offsets; returns its cost (one rollout).
  double restart_from_best(const OcpProblem& problem, const Solution& best) noexcept;

  // The polish (see SaOptions::polish_share) of out->inputs until `stop`; returns its steps and
  // updates *out (inputs, states, cost) and *rollouts; -1 when not even a first gradient fits.
  // `full_rollout` is what one rollout took this solve (the time guard's unit before a gradient
  // has been timed).
  int polish(const OcpProblem& problem, Deadline deadline, TimePoint stop, Duration full_rollout, Solution* out,
             long* rollouts) noexcept;
  // The knot-space polish (see SaOptions::knot_polish) of out->inputs until `stop`, from the best
  // plan as the new base; same contract as polish(). `proposal` is the slowest proposal seen.
  int knot_polish(const OcpProblem& problem, Deadline deadline, TimePoint stop, Duration proposal, Solution* out,
                  long* rollouts) noexcept;
  // What one knot-space gradient costs in full rollouts: nu per knot, each from the knot's first step.
  double knot_gradient_rollouts() const noexcept;
  // Forward differences of the cost over every knot offset at knots_ (whose plan, rollout and cost
  // are the current ones) into *gradient (nu x K). false when `stop` comes first or the model fails.
  bool knot_gradient(const OcpProblem& problem, double cost, Deadline deadline, TimePoint stop, Duration* proposal,
                     long* rollouts, Eigen::MatrixXd* gradient) noexcept;
  // The L-BFGS direction -H g over the first n entries of the memory (Nocedal & Wright Alg. 7.4),
  // g and the direction nu x columns; with no pair stored, a first step of 2 % of the largest input
  // range along -g. false when it is no descent direction (the memory is then forgotten).
  bool lbfgs_direction(const Eigen::MatrixXd& gradient, Eigen::MatrixXd* direction) noexcept;
  // Draws a proposal around the current plan (knots_, raw_, inputs_) into *knots, *raw and
  // *inputs (projected); returns the first step whose input changed (N: the projection undid it).
  int propose(const OcpProblem& problem, Eigen::MatrixXd* knots, Eigen::MatrixXd* raw,
              Eigen::MatrixXd* inputs) noexcept;
  // Rebuilds raw inputs = base + interpolated knot offsets on steps [first, last].
  void interpolate(const Eigen::MatrixXd& knots, int first, int last, Eigen::MatrixXd* raw) const noexcept;

  // A batch's further proposals (threads - 1), each with its buffers and its rollout's scratch.
  // Its buffers also serve the polish's gradient: the share of stages [first_stage, last_stage)
  // that worker linearises, and how many it did (-1: the model failed).
  struct Proposal {
    Eigen::MatrixXd knots, raw, inputs, states;
    Eigen::VectorXd stage_costs, stage_wear, x_next;
    int changed = 0;
    double cost = 0.0;
    int first_stage = 0, last_stage = 0, done_stages = 0;
  };
  enum class WorkerJob { kProposal, kLinearise };
  // A worker's part of the job in flight: roll out its proposal, or linearise its share of stages.
  void run_worker_job(std::size_t index) noexcept;
  // Rolls out proposals_[index] on its own scratch (from its changed step on) into its cost.
  void roll_out_proposal(std::size_t index) noexcept;
  // The first step in [first, last] whose input in `inputs` differs from the current plan's
  // (inputs_); N when none does.
  int first_changed_step(const Eigen::MatrixXd& inputs, int first, int last) const noexcept;
  // Rolls `inputs` out from step `changed` on, sharing the current plan's prefix (its states,
  // stage costs and wear before `changed`); returns the cost. Reads only the current plan, so
  // proposals may roll out this way on several threads, each on its own `data` and buffers.
  double roll_out_from(const OcpProblem& problem, PredictionData& data, int changed, const Eigen::MatrixXd& inputs,
                       Eigen::MatrixXd& states, Eigen::VectorXd& stage_costs,
                       Eigen::VectorXd& stage_wear) const noexcept;
  // The polish's exact gradient at `inputs`. One thread: OcpDerivatives::cost_and_gradient (which
  // rewrites `states`). With workers: `states` must be the rollout of `inputs`, and the stages are
  // split between the threads (stages_per_thread() each). Returns the cost (+inf: the model failed;
  // NaN: given up at `give_up`) and in *done the share of the stages linearised (of the slowest share).
  double exact_gradient(const OcpProblem& problem, const Eigen::MatrixXd& inputs, Eigen::MatrixXd& states,
                        Eigen::MatrixXd* gradient, const Deadline& give_up, double* done) noexcept;
  int stages_per_thread() const noexcept;

  SaOptions options_;
  int nx_, nu_, horizon_, knot_count_, group_size_;
  RandomStream random_;  // the proposals' and the Metropolis test's draws, from options_.seed

  std::vector<int> knot_left_;        // per step: the knot at or before it
  std::vector<double> knot_weight_;   // per step: weight of the knot after it
  std::vector<int> knot_first_step_;  // per knot: the first and last step it influences
  std::vector<int> knot_last_step_;

  StartPlan start_;                                      // the cheapest guess, rolled out
  Eigen::MatrixXd base_;                                 // nu x N
  Eigen::MatrixXd knots_, candidate_knots_;              // nu x K offsets
  Eigen::MatrixXd raw_, candidate_raw_;                  // nu x N before projection
  Eigen::MatrixXd inputs_, candidate_inputs_;            // nu x N projected
  Eigen::MatrixXd states_, candidate_states_;            // nx x N+1
  Eigen::VectorXd stage_costs_, candidate_stage_costs_;  // N
  // N: each stage's wear, of the current plan, the candidate and the best plan (out->states), so
  // the answer's cost is reported from its own rollout (OcpProblem::breakdown), not a new one.
  Eigen::VectorXd stage_wear_, candidate_stage_wear_, best_stage_wear_;
  Eigen::VectorXd best_stage_costs_;                     // N: the best plan's, for the knot polish
  Eigen::VectorXd sigma_, reference_step_;               // nu

  // The polish: exact gradients, and the L-BFGS memory over the flattened inputs (nu N).
  std::unique_ptr<OcpDerivatives> derivatives_;          // null: the model has no Jacobians
  Eigen::MatrixXd gradient_, candidate_gradient_;       // nu x N
  Eigen::MatrixXd direction_;                            // nu x N
  std::unique_ptr<LbfgsMemory> lbfgs_;                   // pairs over up to nu N entries
  Duration longest_gradient_{0};                         // the slowest gradient seen (kept across solves)
  // The knot polish: forward-difference gradients over the offsets (nu x K), and the slowest seen.
  Eigen::MatrixXd knot_gradient_, candidate_knot_gradient_, knot_direction_, previous_knots_;
  Duration longest_knot_gradient_{0};

  // Batched proposals (SaOptions::threads): their buffers, the workers, and the problem of the batch
  // in flight. Every thread steps the model on its own data: model_data(0) this thread's,
  // model_data(w + 1) worker w's.
  std::vector<Proposal> proposals_;
  std::unique_ptr<WorkerPool> workers_;
  const OcpProblem* batch_problem_ = nullptr;
  // The job in flight, and what a gradient's shares read: the plan, its rollout, the give-up time.
  WorkerJob worker_job_ = WorkerJob::kProposal;
  const Eigen::MatrixXd* job_inputs_ = nullptr;
  const Eigen::MatrixXd* job_states_ = nullptr;
  const Deadline* job_stop_ = nullptr;
  Eigen::VectorXd x_next_;  // the calling thread's next state while it linearises its share
};

}  // namespace swerve
