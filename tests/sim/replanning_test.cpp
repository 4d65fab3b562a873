// The library in a vehicle loop with a planner on its own thread (issue 18): the 4-module AGV with
// the wear-aware controller steps at 50 Hz for 60 s of simulated time on the plant simulator, while
// a planner thread replans at 20 Hz into a TrajectoryReference: each plan is the next 3 s of the
// planner's path (a sine curve) sampled every 0.1 s from the time it plans at. Asserted: the
// controller takes the plans up (never stopping for want of one), and it tracks as well as the same
// controller following the planner's path directly. The controller runs on a WorkClock, so its
// solves do not depend on the machine; the threads do run concurrently.
#include <gtest/gtest.h>

#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "support/fake_clocks.hpp"
#include "swerve/app/vehicle_config.hpp"
#include "swerve/control/controller.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/sim/simulator.hpp"
#include "swerve/solvers/sa_solver.hpp"

namespace swerve {
namespace {

constexpr double kControlPeriod = 0.02;  // 50 Hz
constexpr double kPlanPeriod = 0.05;     // 20 Hz
// Sanitized builds run ~50x slower (SWERVE_TEST_TIME_SCALE): a shorter run there.
constexpr double kDuration = SWERVE_TEST_TIME_SCALE > 1 ? 6.0 : 60.0;

struct Outcome {
  double rmse = 0.0;
  int safe_stops = 0;
  int steps = 0;
  long versions = 0;
};

std::shared_ptr<const PathReference> planner_path() {
  SpeedProfile profile;
  profile.speed = 0.6;
  profile.acceleration = 0.5;
  return std::make_shared<PathReference>(make_sine_curve(1.0, 12.0, 60.0), profile, 0.0);
}

// The planner's plan at t0: 31 samples (t, x, y, psi) of its path over the next 3 s.
Eigen::MatrixXd plan_at(const PathReference& path, double t0) {
  Eigen::MatrixXd rows(31, 4);
  for (int i = 0; i < 31; ++i) {
    const double t = t0 + 0.1 * i;
    const Eigen::Vector3d pose = path.sample(t).pose_world;
    rows.row(i) << t, pose.x(), pose.y(), pose.z();
  }
  return rows;
}

// Runs the loop following `path` directly, or (`replanned`) through a planner thread.
Outcome run(bool replanned) {
  const VehicleParams vehicle =
      load_vehicle_config_file(std::string(SWERVE_SOURCE_DIR) + "/configs/vehicles/agv_4wheel.yaml");
  const auto path = planner_path();
  const auto trajectory = std::make_shared<TrajectoryReference>(64, /*max_age=*/0.5);
  if (replanned && !trajectory->publish(plan_at(*path, 0.0)).accepted()) return {};
  testing::WorkClock clock(10e-6);
  ControllerOptions options;
  options.dt = kControlPeriod;
  options.solve_budget = 0.005;
  options.pose_weight = {10.0, 10.0, 200.0};
  SaOptions sa;
  sa.knots = 3;
  sa.max_iterations = 30;  // proposals per solve: the cost of a 60 s run, not its subject
  Controller controller(vehicle, replanned ? std::shared_ptr<const Reference>(trajectory) : path, options,
                        [sa](const OcpProblem& p) { return std::make_unique<SimulatedAnnealingSolver>(p, sa); });
  controller.set_clock(clock);
  SimulatorOptions sim;
  sim.control_period = kControlPeriod;
  Simulator plant(vehicle, sim);
  Eigen::VectorXd start = Eigen::VectorXd::Zero(6 + vehicle.layout.size());
  start.head<3>() = path->sample(0.0).pose_world;
  plant.reset(start);

  // The planner publishes the plan of each 20 Hz mark once the vehicle's clock has passed it. The
  // loop lets it fall at most one mark behind (a test harness's pacing: the controller itself
  // never waits), so the planner plans and publishes while the controller steps.
  std::mutex pacing;
  std::condition_variable tick;       // the loop's clock moved on (planner waits on it)
  std::condition_variable published;  // a plan was published (the harness waits on it)
  double vehicle_time = 0.0;
  long published_mark = 0;
  bool running = true;
  std::thread planner;
  if (replanned) {
    planner = std::thread([&] {
      long mark = 0;
      std::unique_lock<std::mutex> lock(pacing);
      while (true) {
        tick.wait(lock, [&] { return !running || std::floor(vehicle_time / kPlanPeriod + 1e-9) > static_cast<double>(mark); });
        if (!running) return;
        mark = static_cast<long>(std::floor(vehicle_time / kPlanPeriod + 1e-9));
        lock.unlock();  // plan and publish while the control loop runs on
        if (!trajectory->publish(plan_at(*path, static_cast<double>(mark) * kPlanPeriod)).accepted()) {
          ADD_FAILURE() << "plan refused";
        }
        lock.lock();
        published_mark = mark;
        published.notify_one();
      }
    });
  }
  Outcome out;
  double squared = 0.0;
  for (; plant.time() < kDuration - 1e-9; ++out.steps) {
    const double t = plant.time();
    if (replanned) {
      std::unique_lock<std::mutex> lock(pacing);
      vehicle_time = t;
      tick.notify_one();
      const long needed = static_cast<long>(std::floor(t / kPlanPeriod + 1e-9)) - 1;
      published.wait(lock, [&] { return published_mark >= needed; });
    }
    const ControlOutput& command = controller.step(plant.measurement(), t);
    if (command.source == CommandSource::kSafeStop) ++out.safe_stops;
    if (!plant.advance(command.modules)) break;
    squared += (plant.state().head<2>() - path->sample(plant.time()).pose_world.head<2>()).squaredNorm();
  }
  {
    const std::lock_guard<std::mutex> lock(pacing);
    running = false;
  }
  tick.notify_one();
  if (planner.joinable()) planner.join();
  out.rmse = std::sqrt(squared / std::max(out.steps, 1));
  out.versions = trajectory->version();
  return out;
}

TEST(Replanning, APlannerThreadAt20HzKeepsTheControllerTrackingAsWellAsAFixedPath) {
  const Outcome fixed = run(false);
  const Outcome replanned = run(true);
  const int expected_steps = static_cast<int>(std::lround(kDuration / kControlPeriod));
  ASSERT_EQ(fixed.steps, expected_steps);
  ASSERT_EQ(replanned.steps, expected_steps);
  EXPECT_EQ(replanned.safe_stops, 0);
  // Plans are taken up as they come: most 20 Hz marks reach the controller before the next one.
  EXPECT_GE(replanned.versions, static_cast<long>(0.5 * kDuration / kPlanPeriod));
  EXPECT_LE(replanned.rmse, 1.1 * fixed.rmse + 0.002) << "fixed path: " << fixed.rmse << " m";
  std::printf("replanning: fixed path RMSE %.2f mm; replanned %.2f mm, %ld plans taken up\n", fixed.rmse * 1e3,
              replanned.rmse * 1e3, replanned.versions);
}

}  // namespace
}  // namespace swerve
