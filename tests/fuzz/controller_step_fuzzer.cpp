// Fuzz target: the wear-aware controller's step() on arbitrary measurements. One controller (4-module
// AGV, SA backend, line reference, a clock that advances 10 us per read) is built once; each input is
// a short sequence of steps decoded from the bytes. Whatever the measurement (wrong size, NaN, inf,
// 1e300, time running backwards), every command must be finite and within the layout's limits.
#include <Eigen/Core>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "fuzz_support.hpp"
#include "swerve/app/vehicle_config.hpp"
#include "swerve/control/controller.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/ocp/deadline.hpp"
#include "swerve/solvers/sa_solver.hpp"

namespace {

// Deterministic time: 10 us of "work" per read, so deadlines fall at the same point of every run.
class TickingClock final : public swerve::Clock {
 public:
  swerve::TimePoint now() const noexcept override {
    now_ += swerve::to_duration(10e-6);
    return now_;
  }

 private:
  mutable swerve::TimePoint now_{};
};

struct Harness {
  TickingClock clock;
  swerve::VehicleParams vehicle;
  std::unique_ptr<swerve::Controller> controller;
  double max_steering_rate = 0.0;
  double max_wheel_speed = 0.0;

  Harness()
      : vehicle(swerve::load_vehicle_config_file(std::string(SWERVE_SOURCE_DIR) +
                                                 "/configs/vehicles/agv_4wheel.yaml")) {
    swerve::SpeedProfile profile;
    profile.speed = 1.0;
    profile.acceleration = 1.0;
    auto reference = std::make_shared<swerve::PathReference>(swerve::make_line_curve({0.0, 0.0}, 0.0, 20.0),
                                                             profile, 0.0);
    swerve::SaOptions sa;
    sa.max_iterations = 10;  // the rollouts (the tire model) are ~all the time of a step
    sa.seed = 7;
    swerve::ControllerOptions options;
    options.horizon = 6;  // short: with 10 SA proposals, ~50 sanitized inputs a second
    controller = std::make_unique<swerve::Controller>(
        vehicle, reference, options,
        [sa](const swerve::OcpProblem& shape) { return std::make_unique<swerve::SimulatedAnnealingSolver>(shape, sa); });
    controller->set_clock(clock);
    const swerve::ModuleLimits& limits = vehicle.layout.limits();
    max_steering_rate = limits.max_steering_rate;
    max_wheel_speed = limits.max_drive_speed / vehicle.layout.wheel_radius();
  }
};

// Reads the input front to back; past its end every value is 0.
class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool empty() const { return position_ >= size_; }
  std::uint8_t byte() { return empty() ? std::uint8_t{0} : data_[position_++]; }
  double real() {
    unsigned char bytes[sizeof(double)] = {};
    for (unsigned char& b : bytes) b = byte();
    double value = 0.0;
    std::memcpy(&value, bytes, sizeof value);
    return value;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t position_ = 0;
};

constexpr int kMaxStepsPerInput = 6;
constexpr double kTolerance = 1e-9;

bool within(double value, double limit) { return std::isfinite(value) && std::abs(value) <= limit * (1.0 + kTolerance) + kTolerance; }

}  // namespace

// Input: up to kMaxStepsPerInput records of
//   flags (1 byte: bit 0 reset() before the step, bit 1 a wrong-sized measurement whose size is the
//   next byte mod 33), the measurement's doubles (6 + 4 = 10 unless wrong-sized), t, measured_at.
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Harness harness;
  swerve::Controller& controller = *harness.controller;
  const int modules = harness.vehicle.layout.size();
  controller.reset();  // every input starts from a fresh controller: findings replay alone
  Reader in(data, size);
  for (int k = 0; k < kMaxStepsPerInput && !in.empty(); ++k) {
    const std::uint8_t flags = in.byte();
    if ((flags & 1U) != 0) controller.reset();
    const int state_size = (flags & 2U) != 0 ? in.byte() % 33 : 6 + modules;
    Eigen::VectorXd measured(state_size);
    for (int i = 0; i < state_size; ++i) measured[i] = in.real();
    const double t = in.real();
    const double measured_at = in.real();
    const swerve::ControlOutput& out = controller.step(measured, t, measured_at);
    SWERVE_FUZZ_CHECK(out.modules.size() == modules, "%d commands for %d modules", out.modules.size(), modules);
    for (int i = 0; i < out.modules.size(); ++i) {
      const swerve::ModuleCommand& c = out.modules[i];
      SWERVE_FUZZ_CHECK(std::isfinite(c.steering_angle), "module %d: steering_angle = %g (source %d, %s)", i,
                        c.steering_angle, static_cast<int>(out.source), out.reason);
      SWERVE_FUZZ_CHECK(within(c.steering_rate, harness.max_steering_rate),
                        "module %d: steering_rate = %.17g, limit %g (source %d, %s)", i, c.steering_rate,
                        harness.max_steering_rate, static_cast<int>(out.source), out.reason);
      SWERVE_FUZZ_CHECK(within(c.wheel_speed, harness.max_wheel_speed),
                        "module %d: wheel_speed = %.17g, limit %g (source %d, %s)", i, c.wheel_speed,
                        harness.max_wheel_speed, static_cast<int>(out.source), out.reason);
    }
  }
  return 0;
}
