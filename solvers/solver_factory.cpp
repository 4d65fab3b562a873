#include "swerve/solvers/solver_factory.hpp"

#include <algorithm>

#include "swerve/core/config_error.hpp"

namespace swerve {

const std::vector<std::string>& built_backends() {
  static const std::vector<std::string> backends = {"sa", "rti", "nlopt"
#ifdef SWERVE_HAS_IPOPT
                                                     ,
                                                     "ipopt"
#endif
#ifdef SWERVE_HAS_CERES
                                                     ,
                                                     "ceres"
#endif
  };
  return backends;
}

std::string built_backends_text() {
  std::string list;
  for (const std::string& name : built_backends()) list += (list.empty() ? "" : ", ") + name;
  return list;
}

void SolverConfig::validate() const {
  const auto& built = built_backends();
  if (std::find(built.begin(), built.end(), backend) == built.end()) {
    throw ConfigError("controller.solver.backend: '" + backend + "' was not built (built: " + built_backends_text() + ")");
  }
  if (backend == "sa") sa.validate();
  if (backend == "rti") rti.validate();
  if (backend == "nlopt") nlopt.validate();
  // An unbuilt backend was refused above; its options' rules live in its own library.
#ifdef SWERVE_HAS_IPOPT
  if (backend == "ipopt") ipopt.validate();
#endif
#ifdef SWERVE_HAS_CERES
  if (backend == "ceres") ceres.validate();
#endif
}

std::unique_ptr<Solver> make_solver(const SolverConfig& config, const OcpProblem& problem) {
  config.validate();
  if (config.backend == "sa") return std::make_unique<SimulatedAnnealingSolver>(problem, config.sa);
  if (config.backend == "rti") return std::make_unique<RtiSolver>(problem, config.rti);
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
