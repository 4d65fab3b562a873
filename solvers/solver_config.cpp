#include "swerve/solvers/solver_config.hpp"

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
  // Every backend's rules are in its options' header, so no backend library is needed to check them.
  if (backend == "sa") sa.validate();
  if (backend == "rti") rti.validate();
  if (backend == "nlopt") nlopt.validate();
  if (backend == "ipopt") ipopt.validate();
  if (backend == "ceres") ceres.validate();
}

std::unique_ptr<Solver> make_core_solver(const SolverConfig& config, const OcpProblem& problem) {
  config.validate();
  if (config.backend == "sa") return std::make_unique<SimulatedAnnealingSolver>(problem, config.sa);
  if (config.backend == "rti") return std::make_unique<RtiSolver>(problem, config.rti);
  throw ConfigError("controller.solver.backend: '" + config.backend +
                    "' is built but not in this factory, which has sa and rti: link SwerveMPC::solvers and build "
                    "controllers with swerve::make_solver");
}

}  // namespace swerve
