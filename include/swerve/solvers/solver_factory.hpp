// The one place a backend is chosen by name (`controller.solver.backend` in YAML): which backends
// this build has, and a factory that builds one for a problem's shape. An unbuilt backend is a
// ConfigError that says which ones were built.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "swerve/solvers/ceres_solver.hpp"
#include "swerve/solvers/ipopt_solver.hpp"
#include "swerve/solvers/nlopt_solver.hpp"
#include "swerve/solvers/rti_solver.hpp"
#include "swerve/solvers/sa_solver.hpp"
#include "swerve/ocp/solver.hpp"

namespace swerve {

struct SolverConfig {
  std::string backend = "sa";
  SaOptions sa;
  RtiOptions rti;
  NloptOptions nlopt;
  IpoptOptions ipopt;
  CeresOptions ceres;
  void validate() const;  // unknown or unbuilt backend, invalid backend options: ConfigError
};

// Backends compiled into this build, in a stable order ("sa", ...).
const std::vector<std::string>& built_backends();
// The same, as messages list them: "sa, nlopt, ipopt, ceres".
std::string built_backends_text();

// Throws ConfigError ("controller.solver.backend: 'ipopt' was not built (built: sa)").
std::unique_ptr<Solver> make_solver(const SolverConfig& config, const OcpProblem& problem);

}  // namespace swerve
