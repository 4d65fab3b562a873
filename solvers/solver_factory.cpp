#include "swerve/solvers/solver_factory.hpp"

#include "swerve/core/config_error.hpp"

namespace swerve {

std::unique_ptr<Solver> make_solver(const SolverConfig& config, const OcpProblem& problem) {
  config.validate();
  if (config.backend == "sa" || config.backend == "rti") return make_core_solver(config, problem);
  if (config.backend == "nlopt") return std::make_unique<NloptSolver>(problem, config.nlopt);
#ifdef SWERVE_HAS_IPOPT
  if (config.backend == "ipopt") return std::make_unique<IpoptSolver>(problem, config.ipopt);
#endif
#ifdef SWERVE_HAS_CERES
  if (config.backend == "ceres") return std::make_unique<CeresSolver>(problem, config.ceres);
#endif
  throw ConfigError("controller.solver.backend: '" + config.backend + "' has no factory entry");
}

}  // namespace swerve
