// Which optimiser a controller uses (`controller.solver` in YAML) and the backends this build has,
// without linking any backend but the two with no dependency of their own: make_core_solver builds
// `sa` and `rti`. make_solver (solver_factory.hpp, SwerveMPC::solvers) builds every built backend.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "swerve/ocp/solver.hpp"
#include "swerve/solvers/ceres_solver.hpp"
#include "swerve/solvers/ipopt_solver.hpp"
#include "swerve/solvers/nlopt_solver.hpp"
#include "swerve/solvers/rti_solver.hpp"
#include "swerve/solvers/sa_solver.hpp"

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

// What builds a backend for a problem's shape: make_core_solver, make_solver, or a program's own.
using BackendFactory = std::function<std::unique_ptr<Solver>(const SolverConfig&, const OcpProblem&)>;

// `sa` or `rti` (they need nothing beyond Eigen). Throws ConfigError for another backend, saying
// that make_solver (SwerveMPC::solvers) builds it, and for invalid options.
std::unique_ptr<Solver> make_core_solver(const SolverConfig& config, const OcpProblem& problem);

}  // namespace swerve
