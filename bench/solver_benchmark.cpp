// The optimiser backends behind the one Solver interface (issue 9), on the swerve problem of the
// conformance suite (body-twist inputs, reference 0.2 m aside at 0.5 m/s) for 4 and 8 modules and
// N in {10, 20, 40}:
//   BM_Solver_Cold: a fresh solver from the last input held over the horizon;
//   BM_Solver_Warm: receding horizon, each iteration one cycle on (the state the plan predicted,
//                   the reference one step on) from the shifted plan.
// Each solve runs to its backend's own convergence test (Ipopt tol 1e-6, SLSQP ftol 1e-12, Ceres
// 1e-10, SA its 3000 proposals), no deadline. Counters: per-solve p50/p99, iterations per solve,
// time per iteration, cost. Goal (issues 9, 17): Ipopt warm, 4 modules, N = 20: p99 <= 10 ms.
//   BM_Solver_CostAtBudget: the cost each backend reaches warm within 2, 5, 10 and 20 ms, against
// a tight Ipopt reference (4 and 10 modules, N = 20).
//   BM_Solver_RtiCycle: the real-time iteration per cycle, its time and gap to each cycle's optimum.
//   BM_Solver_RtiPreparedCycle: the same split into preparation and feedback, each timed, with a
// measured start that differs from the predicted one.
//   BM_Solver_GapToIpoptReference: a scenario's closed loop (0 curve, 1 offset60, 2 curve_smooth)
// with the default SA controller at a solve budget of budget_ms and an SA polish share of
// polish_pct % (knot_polish: whether the knot-space polish stands in where the exact gradient does
// not fit) and SA threads proposals per step; every 40th cycle the same
// problem is solved by Ipopt to tol 1e-9 without a deadline (from SA's plan and from the held
// input) and SA's cost is compared with the best.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

#include "support/swerve_problems.hpp"
#include "swerve/app/scenario_config.hpp"
#include "swerve/control/controller.hpp"
#include "swerve/sim/metrics.hpp"
#include "swerve/sim/simulator.hpp"
#include "swerve/solvers/rti_solver.hpp"
#include "swerve/solvers/solver_factory.hpp"

namespace swerve {
namespace {

using namespace std::chrono_literals;

const char* const kBackends[] = {"sa", "nlopt", "ipopt", "ceres", "rti"};
constexpr int kBackendCount = 5;

SolverConfig converging(const std::string& backend) {
  SolverConfig config;
  config.backend = backend;
  config.ipopt.max_iterations = 3000;
  config.ceres.max_iterations = 3000;
  config.rti.max_iterations = 3000;
  return config;
}

struct Samples {
  std::vector<double> seconds, iterations, costs;
  void add(double s, const SolveSummary& summary, double cost) {
    seconds.push_back(s);
    iterations.push_back(summary.iterations);
    costs.push_back(cost);
  }
  void report(benchmark::State& state) const {
    double total_iterations = 0.0, total_time = 0.0;
    for (std::size_t i = 0; i < seconds.size(); ++i) {
      total_iterations += iterations[i];
      total_time += seconds[i];
    }
    state.counters["p50_ms"] = 1e3 * percentile(seconds, 50.0);
    state.counters["p99_ms"] = 1e3 * percentile(seconds, 99.0);
    state.counters["iterations"] = total_iterations / static_cast<double>(seconds.size());
    state.counters["ms_per_iteration"] = total_iterations > 0 ? 1e3 * total_time / total_iterations : 0.0;
    double cost = 0.0;
    for (double c : costs) cost += c;
    state.counters["cost"] = cost / static_cast<double>(costs.size());
  }
};

// Times one solve for the benchmark's manual clock and records it.
void timed_solve(benchmark::State& state, Solver& solver, const OcpProblem& problem, const InitialGuesses& guesses,
                 Solution* solution, Samples* samples) {
  SolveSummary summary;
  const auto start = SolverClock::now();
  solver.solve(problem, guesses, start + 600s, solution, &summary);
  const double seconds = std::chrono::duration<double>(SolverClock::now() - start).count();
  state.SetIterationTime(seconds);
  samples->add(seconds, summary, solution->cost);
}

void BM_Solver_Cold(benchmark::State& state) {
  const std::string backend = kBackends[state.range(0)];
  const int modules = static_cast<int>(state.range(1));
  const int horizon = static_cast<int>(state.range(2));
  testing::SwerveTestProblem s(testing::SwerveScene::kSidestep, horizon, -1.0, modules);
  const Eigen::MatrixXd held = s.problem.previous_input().replicate(1, horizon);
  InitialGuesses guesses;
  guesses.add(&held);
  Solution solution;
  solution.resize(s.problem.state_size(), s.problem.input_size(), horizon);
  Samples samples;
  for (auto _ : state) {
    std::unique_ptr<Solver> solver = make_solver(converging(backend), s.problem);
    timed_solve(state, *solver, s.problem, guesses, &solution, &samples);
  }
  samples.report(state);
  state.SetLabel(backend);
}

// Receding horizon: one untimed solve, then per benchmark iteration one cycle on (the state the
// plan predicted, the reference one step on) from the shifted plan.
void run_warm_cycles(benchmark::State& state, Solver& solver, testing::SwerveTestProblem& s) {
  const int horizon = s.problem.horizon();
  Solution solution;
  solution.resize(s.problem.state_size(), s.problem.input_size(), horizon);
  Eigen::MatrixXd guess = s.problem.previous_input().replicate(1, horizon);
  InitialGuesses guesses;
  guesses.add(&guess);
  SolveSummary summary;
  solver.solve(s.problem, guesses, SolverClock::now() + 600s, &solution, &summary);  // cycle 0, untimed
  Samples samples;
  int cycle = 0;
  for (auto _ : state) {
    s.next_cycle(++cycle, &solution);
    guess = solution.inputs;
    timed_solve(state, solver, s.problem, guesses, &solution, &samples);
  }
  samples.report(state);
}

void BM_Solver_Warm(benchmark::State& state) {
  const std::string backend = kBackends[state.range(0)];
  const int modules = static_cast<int>(state.range(1));
  const int horizon = static_cast<int>(state.range(2));
  testing::SwerveTestProblem s(testing::SwerveScene::kSidestep, horizon, -1.0, modules);
  std::unique_ptr<Solver> solver = make_solver(converging(backend), s.problem);
  run_warm_cycles(state, *solver, s);
  state.SetLabel(backend);
}

void solver_grid(benchmark::internal::Benchmark* b) {
  b->ArgNames({"backend", "modules", "N"});
  for (int backend = 0; backend < kBackendCount; ++backend) {
    for (int modules : {4, 8}) {
      for (int horizon : {10, 20, 40}) b->Args({backend, modules, horizon});
    }
  }
}
BENCHMARK(BM_Solver_Cold)->Apply(solver_grid)->Iterations(3)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Solver_Warm)->Apply(solver_grid)->Iterations(10)->UseManualTime()->Unit(benchmark::kMillisecond);

// Ipopt's Hessian (issue 17): the exact one (per-stage forward differences of the Jet gradients)
// against Ipopt's L-BFGS, each with its warm-start settings (see IpoptOptions), warm as above, on
// 4 and 10 modules at N = 20, 20 cycles.
void BM_Solver_IpoptHessian(benchmark::State& state) {
  const bool exact = state.range(0) == 0;
  const bool learnt = state.range(0) == 2;
  const int modules = static_cast<int>(state.range(1));
  const int horizon = static_cast<int>(state.range(2));
  testing::SwerveTestProblem s(testing::SwerveScene::kSidestep, horizon, -1.0, modules);
  SolverConfig config = converging("ipopt");
  if (learnt) {
    config.ipopt.hessian = "stage-quasi-newton";
  } else if (!exact) {
    config.ipopt.hessian = "limited-memory";
    config.ipopt.warm_start_multipliers = false;
    config.ipopt.warm_mu_init = 1e-4;
  }
  std::unique_ptr<Solver> solver = make_solver(config, s.problem);
  run_warm_cycles(state, *solver, s);
  state.SetLabel(exact ? "exact" : learnt ? "stage-quasi-newton" : "limited-memory");
}
BENCHMARK(BM_Solver_IpoptHessian)
    ->ArgNames({"hessian", "modules", "N"})
    ->ArgsProduct({{0, 1, 2}, {4, 10}, {20}})
    ->Iterations(20)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// Anytime quality (issue 17): what each backend reaches within a budget. Receding horizon on the
// conformance suite's sidestep problem (N = 20), the same sequence of problems for every backend:
// each cycle starts one step on along the tight reference plan (Ipopt, exact Hessian, tol 1e-9, no
// deadline, warm from the shifted plan), and the backend, with its library defaults, solves from
// that shifted plan with a deadline budget_ms away. Counters: the cost gap to the reference
// (median, p90, max, in %) and the shifted plan's (median), the largest overrun past the
// deadline, iterations per solve.
void BM_Solver_CostAtBudget(benchmark::State& state) {
  const std::string backend = kBackends[state.range(0)];
  const int modules = static_cast<int>(state.range(1));
  const Duration budget = std::chrono::milliseconds(state.range(2));
  const int horizon = 20;
  testing::SwerveTestProblem s(testing::SwerveScene::kSidestep, horizon, -1.0, modules);
  SolverConfig reference_config = converging("ipopt");
  reference_config.ipopt.tol = 1e-9;
  std::unique_ptr<Solver> reference_solver = make_solver(reference_config, s.problem);
  SolverConfig config;
  config.backend = backend;
  std::unique_ptr<Solver> solver = make_solver(config, s.problem);
  Solution reference, trial;
  reference.resize(s.problem.state_size(), s.problem.input_size(), horizon);
  trial.resize(s.problem.state_size(), s.problem.input_size(), horizon);
  Eigen::MatrixXd guess = s.problem.previous_input().replicate(1, horizon);
  InitialGuesses guesses;
  guesses.add(&guess);
  SolveSummary summary;
  // Cycle 0, untimed: the reference cold, and the backend once so its warm state exists.
  reference_solver->solve(s.problem, guesses, SolverClock::now() + 600s, &reference, &summary);
  solver->solve(s.problem, guesses, SolverClock::now() + budget, &trial, &summary);
  std::vector<double> gaps, start_gaps;
  double iterations = 0.0, late_ms = 0.0;
  int cycle = 0;
  for (auto _ : state) {
    s.next_cycle(++cycle, &reference);
    guess = reference.inputs;
    if (!has_solution(reference_solver->solve(s.problem, guesses, SolverClock::now() + 600s, &reference, &summary))) {
      state.SkipWithError("the reference solve failed");
      return;
    }
    const auto start = SolverClock::now();
    const auto deadline = start + budget;
    const bool solved = has_solution(solver->solve(s.problem, guesses, deadline, &trial, &summary));
    const auto end = SolverClock::now();
    state.SetIterationTime(std::chrono::duration<double>(end - start).count());
    if (!solved) {
      state.SkipWithError("the backend returned no plan");
      return;
    }
    gaps.push_back(100.0 * (trial.cost / reference.cost - 1.0));
    start_gaps.push_back(100.0 * (summary.initial_cost / reference.cost - 1.0));
    iterations += summary.iterations;
    late_ms = std::max(late_ms, 1e3 * std::chrono::duration<double>(end - deadline).count());
  }
  state.counters["gap_p50_pct"] = percentile(gaps, 50.0);
  state.counters["gap_p90_pct"] = percentile(gaps, 90.0);
  state.counters["gap_max_pct"] = gaps.empty() ? 0.0 : *std::max_element(gaps.begin(), gaps.end());
  state.counters["start_gap_p50_pct"] = percentile(start_gaps, 50.0);
  state.counters["late_max_ms"] = late_ms;
  state.counters["iterations"] = gaps.empty() ? 0.0 : iterations / static_cast<double>(gaps.size());
  state.SetLabel(backend);
}
BENCHMARK(BM_Solver_CostAtBudget)
    ->ArgNames({"backend", "modules", "budget_ms"})
    ->ArgsProduct({{0, 1, 2, 3, 4}, {4, 10}, {2, 5, 10, 20}})
    ->Iterations(10)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// The real-time iteration (rti, its defaults: one SQP iteration per cycle) on the receding-horizon
// sidestep sequence of BM_Solver_Warm, 4 and 10 modules, N = 20: the time of each cycle (p50, p99),
// and each cycle's cost against a Gauss-Newton SQP run to convergence on the same problem from the
// same shifted plan (untimed): the gap's median and maximum in %. Goal: 10 modules, <= 2 ms a cycle.
// The receding-horizon sidestep cycles both real-time-iteration benchmarks run: the rti backend
// with its library defaults, a Gauss-Newton SQP to convergence as each cycle's reference, the plan
// the reference solved at cycle 0, and the guess (the shifted plan from cycle 1 on).
struct RtiCycles {
  static constexpr int kHorizon = 20;
  testing::SwerveTestProblem s;
  std::unique_ptr<Solver> solver, reference;
  Solution plan, converged;
  Eigen::MatrixXd guess;
  InitialGuesses guesses;
  SolveSummary summary;

  explicit RtiCycles(int modules) : s(testing::SwerveScene::kSidestep, kHorizon, -1.0, modules) {
    SolverConfig config;
    config.backend = "rti";
    solver = make_solver(config, s.problem);
    SolverConfig reference_config = converging("rti");
    reference_config.rti.tolerance = 1e-12;
    reference_config.rti.stage_quasi_newton = false;
    reference = make_solver(reference_config, s.problem);
    plan.resize(s.problem.state_size(), s.problem.input_size(), kHorizon);
    converged.resize(s.problem.state_size(), s.problem.input_size(), kHorizon);
    guess = s.problem.previous_input().replicate(1, kHorizon);
    guesses.add(&guess);
    reference->solve(s.problem, guesses, SolverClock::now() + 600s, &plan, &summary);  // cycle 0, untimed
  }
  // The next cycle on the plan: its predicted state, its shifted inputs the guess.
  void next(int cycle) {
    s.next_cycle(cycle, &plan);
    guess = plan.inputs;
  }
  // The gap (%) of the plan to the converged solve of the current problem.
  double gap() {
    reference->solve(s.problem, guesses, SolverClock::now() + 600s, &converged, &summary);
    return 100.0 * (plan.cost / converged.cost - 1.0);
  }
};

void BM_Solver_RtiCycle(benchmark::State& state) {
  RtiCycles c(static_cast<int>(state.range(0)));
  std::vector<double> seconds, gaps;
  int cycle = 0;
  for (auto _ : state) {
    c.next(++cycle);
    const auto start = SolverClock::now();
    c.solver->solve(c.s.problem, c.guesses, start + 600s, &c.plan, &c.summary);
    const double elapsed = std::chrono::duration<double>(SolverClock::now() - start).count();
    state.SetIterationTime(elapsed);
    seconds.push_back(elapsed);
    gaps.push_back(c.gap());
  }
  state.counters["p50_ms"] = 1e3 * percentile(seconds, 50.0);
  state.counters["p99_ms"] = 1e3 * percentile(seconds, 99.0);
  state.counters["gap_p50_pct"] = percentile(gaps, 50.0);
  state.counters["gap_max_pct"] = gaps.empty() ? 0.0 : *std::max_element(gaps.begin(), gaps.end());
}
BENCHMARK(BM_Solver_RtiCycle)
    ->ArgNames({"modules"})
    ->Arg(4)
    ->Arg(10)
    ->Iterations(40)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// The same cycles split as the real-time iteration runs them: the preparation on the predicted
// start (the plan's next state) before the measurement, and the feedback on the measured start,
// which differs from the prediction (pushed 1 cm sideways, alternating). Times both phases; the
// gap is the feedback's plan to a converged solve of the measured problem. The feedback's mean QP
// iterations and rollouts, and its p99 after the first 10 cycles (the settled one), are counted too.
void BM_Solver_RtiPreparedCycle(benchmark::State& state) {
  RtiCycles c(static_cast<int>(state.range(0)));
  std::vector<double> preparations, feedbacks, cycles, gaps;
  int cycle = 0, prepared = 0;
  long qp_iterations = 0, feedback_rollouts = 0;
  // While the stage curvature is learnt the line search cuts steps (3 to 8 rollouts a feedback);
  // the settled figure leaves those cycles out.
  constexpr int kLearningCycles = 10;
  std::vector<double> settled_feedbacks;
  for (auto _ : state) {
    c.next(++cycle);
    const auto start = SolverClock::now();
    prepared += c.solver->prepare(c.s.problem, c.guesses, start + 600s) ? 1 : 0;
    const auto measured_at = SolverClock::now();
    Eigen::VectorXd measured = c.s.problem.initial_state();  // untimed: the measurement arriving
    measured[1] += cycle % 2 == 0 ? 0.01 : -0.01;
    c.s.problem.set_initial_state(measured);
    const auto feedback_start = SolverClock::now();
    c.solver->solve(c.s.problem, c.guesses, feedback_start + 600s, &c.plan, &c.summary);
    const auto end = SolverClock::now();
    qp_iterations += static_cast<const RtiSolver&>(*c.solver).last_details().qp_iterations;
    feedback_rollouts += c.summary.rollouts;
    const double preparation = std::chrono::duration<double>(measured_at - start).count();
    const double feedback = std::chrono::duration<double>(end - feedback_start).count();
    state.SetIterationTime(preparation + feedback);
    preparations.push_back(preparation);
    feedbacks.push_back(feedback);
    if (cycle > kLearningCycles) settled_feedbacks.push_back(feedback);
    cycles.push_back(preparation + feedback);
    gaps.push_back(c.gap());
  }
  state.counters["prepared_pct"] = 100.0 * prepared / static_cast<double>(std::max(cycle, 1));
  state.counters["feedback_qp_iterations"] = static_cast<double>(qp_iterations) / std::max(cycle, 1);
  state.counters["feedback_rollouts"] = static_cast<double>(feedback_rollouts) / std::max(cycle, 1);
  state.counters["preparation_p50_ms"] = 1e3 * percentile(preparations, 50.0);
  state.counters["preparation_p99_ms"] = 1e3 * percentile(preparations, 99.0);
  state.counters["feedback_p50_ms"] = 1e3 * percentile(feedbacks, 50.0);
  state.counters["feedback_p99_ms"] = 1e3 * percentile(feedbacks, 99.0);
  state.counters["feedback_settled_p99_ms"] = 1e3 * percentile(settled_feedbacks, 99.0);
  state.counters["cycle_p99_ms"] = 1e3 * percentile(cycles, 99.0);
  state.counters["gap_p50_pct"] = percentile(gaps, 50.0);
  state.counters["gap_max_pct"] = gaps.empty() ? 0.0 : *std::max_element(gaps.begin(), gaps.end());
}
BENCHMARK(BM_Solver_RtiPreparedCycle)
    ->ArgNames({"modules"})
    ->Arg(4)
    ->Arg(10)
    ->Iterations(200)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// The paper's pair and one gentle, planner-like reference (issue 15's set).
const char* const kGapScenarios[] = {"curve", "offset60", "curve_smooth"};

void BM_Solver_GapToIpoptReference(benchmark::State& state) {
  const std::string name = kGapScenarios[state.range(0)];
  const ScenarioConfig scenario =
      load_scenario_config_file(std::string(SWERVE_SOURCE_DIR "/configs/scenarios/") + name + ".yaml");
  const ScenarioController* wear_mpc = nullptr;
  for (const ScenarioController& c : scenario.controllers) {
    if (c.name == "wear_mpc") wear_mpc = &c;
  }
  if (wear_mpc == nullptr) {
    state.SkipWithError((name + ".yaml has no wear_mpc controller").c_str());
    return;
  }
  ControllerConfig config = wear_mpc->config;
  config.mpc.solve_budget = 1e-3 * static_cast<double>(state.range(1));
  config.solver.sa.polish_share = 0.01 * static_cast<double>(state.range(2));
  config.solver.sa.knot_polish = state.range(3) != 0;
  config.solver.sa.threads = static_cast<int>(state.range(4));
  std::vector<double> gaps;
  double solves = 0.0, rollouts = 0.0, exact_polished = 0.0, knot_polished = 0.0;
  for (auto _ : state) {
    std::unique_ptr<TrackingController> tracker = make_controller(config, scenario.vehicle, scenario.reference);
    auto* controller = dynamic_cast<Controller*>(tracker.get());
    Simulator plant(scenario.vehicle, scenario.simulator);
    plant.reset(scenario.initial_state);
    SolverConfig reference_config = converging("ipopt");
    reference_config.ipopt.tol = 1e-9;
    std::unique_ptr<Solver> ipopt = make_solver(reference_config, controller->problem());
    const OcpProblem& problem = controller->problem();
    Solution reference_plan;
    reference_plan.resize(problem.state_size(), problem.input_size(), problem.horizon());
    const double period = scenario.simulator.control_period;
    const int steps = static_cast<int>(std::ceil(scenario.duration / period - 1e-9));
    for (int k = 0; k < steps; ++k) {
      const ControlOutput& output = controller->step(plant.measurement(), k * period);
      if (output.solve.status != SolveStatus::kNotRun) {
        ++solves;
        rollouts += static_cast<double>(output.solve.rollouts);
        const std::string reason = output.solve.reason;
        if (reason.find("over the knots") != std::string::npos || reason.find("knot polish") != std::string::npos) {
          ++knot_polished;
        } else if (reason.find("polish") != std::string::npos) {
          ++exact_polished;
        }
      }
      if (k % 40 == 5 && output.source == CommandSource::kOptimizer) {
        const Eigen::MatrixXd sa_plan = controller->plan().inputs;
        const double sa_cost = controller->plan().cost;
        const Eigen::MatrixXd held = problem.previous_input().replicate(1, problem.horizon());
        double best = sa_cost;
        for (const Eigen::MatrixXd* start : {&sa_plan, &held}) {
          InitialGuesses guesses;
          guesses.add(start);
          SolveSummary summary;
          if (has_solution(ipopt->solve(problem, guesses, SolverClock::now() + 600s, &reference_plan, &summary))) {
            best = std::min(best, reference_plan.cost);
          }
        }
        gaps.push_back(100.0 * (sa_cost / best - 1.0));
      }
      if (!plant.advance(output.modules)) break;
    }
  }
  state.counters["cycles"] = static_cast<double>(gaps.size());
  // Of every solve: rollouts, and the share that ended with an exact or a knot polish.
  state.counters["rollouts"] = solves > 0 ? rollouts / solves : 0.0;
  state.counters["exact_pct"] = solves > 0 ? 100.0 * exact_polished / solves : 0.0;
  state.counters["knot_pct"] = solves > 0 ? 100.0 * knot_polished / solves : 0.0;
  double mean = 0.0;
  for (double g : gaps) mean += g;
  state.counters["gap_mean_pct"] = gaps.empty() ? 0.0 : mean / static_cast<double>(gaps.size());
  state.counters["gap_p50_pct"] = percentile(gaps, 50.0);
  state.counters["gap_p90_pct"] = percentile(gaps, 90.0);
  state.counters["gap_max_pct"] = gaps.empty() ? 0.0 : *std::max_element(gaps.begin(), gaps.end());
}
// The default controller (polish 30 %, no knot polish, one thread) on every scenario and budget;
// on the curve, without the polish, with the knot polish, and with a second thread.
void gap_cases(benchmark::internal::Benchmark* b) {
  for (int scenario : {0, 1, 2}) {
    for (int budget : {20, 10, 5}) {
      b->Args({scenario, budget, 30, 0, 1});
      b->Args({scenario, budget, 30, 0, 2});
      if (scenario == 0) {
        b->Args({scenario, budget, 0, 0, 1});
        b->Args({scenario, budget, 30, 1, 1});
        b->Args({scenario, budget, 60, 1, 1});
      }
    }
  }
}
BENCHMARK(BM_Solver_GapToIpoptReference)
    ->Apply(gap_cases)
    ->ArgNames({"scenario", "budget_ms", "polish_pct", "knot_polish", "threads"})
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

}  // namespace
}  // namespace swerve
