// The real-time promise on the shipped default controller file itself, not on hand-set options:
// after the first cycles step() allocates nothing, the SA polish (its L-BFGS memory) included.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "support/allocation_counter.hpp"  // the one .cpp of app_tests that includes it
#include "swerve/app/controller_config.hpp"
#include "swerve/app/vehicle_config.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/ocp/deadline.hpp"
#include "swerve/sim/simulator.hpp"

namespace swerve {
namespace {

std::string shipped(const std::string& path) { return std::string(SWERVE_SOURCE_DIR) + "/configs/" + path; }

TEST(ShippedDefaultController, StepAllocatesNothingWithThePolishIncluded) {
  if (!testing::AllocationCounter::available()) GTEST_SKIP() << "allocation counting unavailable (a sanitizer owns malloc)";
  ControllerConfig config = load_controller_config_file(shipped("controllers/default.yaml"));
  ASSERT_EQ(config.solver.backend, "sa");
  ASSERT_GT(config.solver.sa.polish_share, 0.0) << "the shipped file no longer polishes: this test lost its subject";
  // The annealing capped by iterations (not by the clock) so that it ends early and the polish
  // runs on every solve: a work clock of 0.1 us per read leaves the 20 ms budget all but unused.
  config.solver.sa.max_iterations = 150;
  const VehicleParams vehicle = load_vehicle_config_file(shipped("vehicles/agv_4wheel.yaml"));
  SpeedProfile profile;
  profile.speed = 1.0;
  profile.acceleration = 0.5;
  const auto reference = std::make_shared<PathReference>(make_line_curve({0.0, 0.0}, 0.0, 20.0), profile, 0.0);
  std::unique_ptr<TrackingController> controller = make_controller(config, vehicle, reference);
  const WorkClock clock(1e-7);
  controller->set_clock(clock);
  SimulatorOptions plant_options;
  plant_options.control_period = config.mpc.period();
  Simulator plant(vehicle, plant_options);
  Eigen::VectorXd start = Eigen::VectorXd::Zero(6 + vehicle.layout.size());
  start[1] = 0.05;  // off the line, so the plan has something to correct
  plant.reset(start);
  long allocations = 0;
  int polished = 0, cycles = 0;
  for (int k = 0; k < 40; ++k) {
    const double t = k * plant_options.control_period;
    const ControlOutput* out = nullptr;
    if (k < 3) {
      out = &controller->step(plant.measurement(), t);
    } else {
      const testing::AllocationCounter counter;
      out = &controller->step(plant.measurement(), t);
      allocations += counter.count();
      ++cycles;
      const std::string reason = out->solve.reason != nullptr ? out->solve.reason : "";
      if (reason.find("polish") != std::string::npos) ++polished;
    }
    ASSERT_TRUE(plant.advance(out->modules)) << "t = " << t;
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_GE(polished, cycles / 2) << "the polish ran on " << polished << " of " << cycles << " cycles";
}

}  // namespace
}  // namespace swerve
