// A vehicle program with the sampling-based optimiser alone (package component `controllers`): the
// controller comes from the shipped files through make_controller with make_core_solver, tracks a
// straight line for two seconds on the library's simulated plant, and a controller file naming a
// backend this program did not link is refused, saying how to get it.
//
//   swerve_controllers_only CONFIG_DIR   (the installed share/swerve_mpc/configs)
#include <cmath>
#include <iostream>
#include <memory>
#include <string>

#include "swerve/app/controller_config.hpp"
#include "swerve/app/vehicle_config.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/sim/simulator.hpp"

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  const std::string configs = argv[1];
  try {
    const swerve::VehicleParams vehicle = swerve::load_vehicle_config_file(configs + "/vehicles/agv_4wheel.yaml");
    auto line = std::make_shared<swerve::TrajectoryReference>(16);
    Eigen::MatrixXd rows(2, 4);
    rows << 0.0, 0.0, 0.0, 0.0,  //
        4.0, 2.0, 0.0, 0.0;      // 0.5 m/s along x
    if (!line->publish(rows).accepted()) return 1;
    swerve::ControllerConfig config = swerve::load_controller_config_file(configs + "/controllers/default.yaml");
    const auto controller = swerve::make_controller(config, vehicle, line, swerve::make_core_solver);

    swerve::SimulatorOptions plant_options;
    plant_options.control_period = config.mpc.period();
    swerve::Simulator plant(vehicle, plant_options);
    plant.reset(Eigen::VectorXd::Zero(6 + vehicle.layout.size()));
    int steps = 0, optimised = 0;
    double squared_error = 0.0;
    for (; plant.time() < 2.0; ++steps) {
      const swerve::ControlOutput& out = controller->step(plant.measurement(), plant.time());
      if (out.source == swerve::CommandSource::kOptimizer) ++optimised;
      if (!plant.advance(out.modules)) return 1;
      squared_error += (plant.state().head<2>() - line->sample(plant.time()).pose_world.head<2>()).squaredNorm();
    }
    std::cout << "controllers only: " << steps << " steps, " << optimised << " from the optimiser, position RMSE "
              << std::sqrt(squared_error / steps) * 1e3 << " mm\n";

    config.solver.backend = "nlopt";  // built into the library, not linked into this program
    try {
      swerve::make_controller(config, vehicle, line, swerve::make_core_solver);
      return 1;
    } catch (const swerve::ConfigError& error) {
      std::cout << "nlopt: " << error.what() << "\n";
    }
  } catch (const swerve::ConfigError& error) {
    std::cerr << error.what() << "\n";
    return 1;
  }
  return 0;
}
