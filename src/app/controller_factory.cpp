// make_controller with every built backend: the overloads without a solver factory, here in
// SwerveMPC::scenarios, which links them all (controller_config.hpp).
#include "swerve/app/controller_config.hpp"
#include "swerve/solvers/solver_factory.hpp"

namespace swerve {

std::unique_ptr<TrackingController> make_controller(const ControllerConfig& config, const VehicleParams& vehicle,
                                                    std::shared_ptr<const Reference> reference) {
  return make_controller(config, vehicle, std::move(reference), make_solver);
}

std::unique_ptr<TrackingController> make_controller(const std::string& vehicle_yaml, const std::string& controller_yaml,
                                                    std::shared_ptr<const Reference> reference) {
  return make_controller(vehicle_yaml, controller_yaml, std::move(reference), make_solver);
}

}  // namespace swerve
