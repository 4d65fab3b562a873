#include "swerve/models/integrators.hpp"

#include "integrators_impl.hpp"

namespace swerve {

const char* to_string(IntegratorMethod method) {
  switch (method) {
    case IntegratorMethod::kEuler: return "euler";
    case IntegratorMethod::kRk4: return "rk4";
  }
  return "unknown";
}

template class DiscreteDynamics<double>;

}  // namespace swerve
