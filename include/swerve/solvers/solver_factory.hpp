// The one place a backend is chosen by name among every backend built (`controller.solver.backend`
// in YAML): a factory that builds one for a problem's shape. An unbuilt backend is a ConfigError that
// says which ones were built. SwerveMPC::solvers; solver_config.hpp has the configuration and the
// factory of the two dependency-free backends.
#pragma once

#include <memory>

#include "swerve/solvers/solver_config.hpp"

namespace swerve {

// Throws ConfigError ("controller.solver.backend: 'ipopt' was not built (built: sa)").
std::unique_ptr<Solver> make_solver(const SolverConfig& config, const OcpProblem& problem);

}  // namespace swerve
