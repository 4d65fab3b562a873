// A vehicle program against the installed SwerveMPC: the loop a user writes. The controller is
// built from a vehicle file and the shipped controller file, resampled for a 50 Hz loop; a planner
// thread publishes a new trajectory every second into a TrajectoryReference; the control loop
// measures, steps the controller and sends its module commands, here to the library's simulated
// plant standing in for the drives.
//
//   swerve_consumer CONFIG_DIR [SECONDS]   (CONFIG_DIR: the installed share/swerve_mpc/configs)
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>
#include <thread>

#include "swerve/app/controller_config.hpp"
#include "swerve/app/vehicle_config.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/sim/simulator.hpp"
#include "swerve/version.hpp"

namespace {

constexpr double kControlPeriod = 0.02;  // s: a 50 Hz control loop
constexpr int kHorizon = 50;             // steps: the shipped config's 1 s of look-ahead
constexpr double kSolveBudget = 0.015;   // s of each 20 ms period for the whole controller step

// The planner: from the time it plans at, the next 4 s of one gentle left arc (radius 4 m at
// 0.5 m/s, from the origin at t = 0), heading along the path. Every replan continues the same arc,
// as a planner's would when nothing changed around the vehicle.
Eigen::MatrixXd plan_from(double t0) {
  constexpr int kSamples = 41;
  constexpr double kSpeed = 0.5, kRadius = 4.0;
  Eigen::MatrixXd rows(kSamples, 4);
  for (int i = 0; i < kSamples; ++i) {
    const double t = t0 + 0.1 * i;
    const double angle = kSpeed * t / kRadius;  // the same arc every time: replans agree
    rows.row(i) << t, kRadius * std::sin(angle), kRadius * (1.0 - std::cos(angle)), angle;
  }
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  std::cout << "SwerveMPC " << swerve::kVersion << "\n";
  if (argc < 2) return 0;
  const std::string configs = argv[1];
  const double seconds = argc > 2 ? std::atof(argv[2]) : 5.0;
  try {
    const swerve::VehicleParams vehicle = swerve::load_vehicle_config_file(configs + "/vehicles/agv_4wheel.yaml");
    auto trajectory = std::make_shared<swerve::TrajectoryReference>(64, /*max_age=*/2.0);
    if (!trajectory->publish(plan_from(0.0)).accepted()) return 1;
    // The shipped controller steps at 20 Hz; this vehicle's loop runs at 50 Hz, so the config is
    // loaded as a struct and resampled before the controller is built (the one-call form,
    // make_controller(vehicle_yaml, controller_yaml, trajectory), takes the file as it is).
    swerve::ControllerConfig config = swerve::load_controller_config_file(configs + "/controllers/default.yaml");
    config.set_sampling(kHorizon, kControlPeriod);
    config.mpc.solve_budget = kSolveBudget;
    const std::unique_ptr<swerve::TrackingController> controller =
        swerve::make_controller(config, vehicle, trajectory);

    // The planner thread replans once a second of vehicle time; the control loop never waits for it.
    std::atomic<double> vehicle_time{0.0};
    std::atomic<bool> running{true};
    std::atomic<int> replans{0};
    std::thread planner([&] {
      double next = 1.0;
      while (running.load()) {
        const double now = vehicle_time.load();
        if (now >= next) {
          if (trajectory->publish(plan_from(now)).accepted()) ++replans;
          next += 1.0;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    });

    swerve::SimulatorOptions plant_options;
    plant_options.control_period = kControlPeriod;
    swerve::Simulator plant(vehicle, plant_options);
    plant.reset(Eigen::VectorXd::Zero(6 + vehicle.layout.size()));
    double squared_error = 0.0;
    int steps = 0, safe_stops = 0;
    for (; plant.time() < seconds; ++steps) {
      const double t = plant.time();
      vehicle_time.store(t);
      const swerve::ControlOutput& out = controller->step(plant.measurement(), t);  // measure, decide
      if (out.source == swerve::CommandSource::kSafeStop) ++safe_stops;
      if (!plant.advance(out.modules)) break;                                       // send to the drives
      const swerve::ReferenceSample wanted = trajectory->sample(plant.time());
      squared_error += (plant.state().head<2>() - wanted.pose_world.head<2>()).squaredNorm();
    }
    running.store(false);
    planner.join();
    std::cout << "closed loop: " << steps << " steps, " << replans.load() << " replans, " << safe_stops
              << " safe stops, position RMSE " << std::sqrt(squared_error / std::max(steps, 1)) * 1e3
              << " mm, tire wear " << plant.frictional_energy() << " J\n";
  } catch (const swerve::ConfigError& error) {
    std::cerr << error.what() << "\n";
    return 1;
  }
  return 0;
}
