// Per-cycle cost of swerve kinematics for 4- and 8-module layouts (targets: command and forward
// kinematics <= 200 ns at 4 modules, <= 400 ns at 8, on the build machine).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>

#include "swerve/kinematics/icr.hpp"
#include "swerve/kinematics/kinematics.hpp"
#include "swerve/kinematics/odometry.hpp"
#include "swerve/kinematics/setpoint_generator.hpp"

namespace swerve {
namespace {

// 4 modules: a 0.6 x 0.4 rectangle; 8 modules: a 4-axle carrier. Both centred (closed-form FK);
// pass a negative count for the same layouts moved off-centre (pseudo-inverse FK).
ModuleLayout bench_layout(int64_t count) {
  const ModuleLayout layout =
      std::abs(count) == 8 ? ModuleLayout::multi_axle(4, 0.4, 0.7, 0.05) : ModuleLayout::rectangle(0.6, 0.4, 0.05);
  return count < 0 ? layout.recentered({0.1, 0.05}) : layout;
}

// A command that keeps changing, so no call sees the same input twice in a row.
Eigen::Vector3d command_at(int64_t i) {
  const double t = 0.01 * static_cast<double>(i % 1000);
  return {1.5 * std::cos(t), 1.2 * std::sin(t), 2.0 * std::sin(0.7 * t)};
}

void report(benchmark::State& state) {
  state.counters["calls_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

// IK + desaturate + singularity hold + flip optimisation; second argument 1 = with measured module
// angles (flip decided against them, cosine scaling), 0 = against the remembered headings.
void BM_Kinematics_Command(benchmark::State& state) {
  const Kinematics kinematics(bench_layout(state.range(0)));
  ModuleHeadingMemory memory(kinematics.size());
  ModuleStates states(kinematics.size()), measured(kinematics.size());
  const ModuleStates* measured_or_null = state.range(1) != 0 ? &measured : nullptr;
  int64_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        kinematics.command(command_at(i++), &memory, &states, Eigen::Vector2d::Zero(), measured_or_null));
    benchmark::ClobberMemory();
  }
  report(state);
}
BENCHMARK(BM_Kinematics_Command)->ArgsProduct({{4, 8}, {0, 1}});

void BM_Kinematics_Forward(benchmark::State& state) {
  const Kinematics kinematics(bench_layout(state.range(0)));
  ModuleStates states;
  kinematics.inverse({0.7, -0.3, 1.1}, &states);
  Eigen::Vector3d twist;
  int64_t i = 0;
  for (auto _ : state) {
    states[0].speed += 1e-9 * static_cast<double>(i++ & 1);
    benchmark::DoNotOptimize(kinematics.forward(states, &twist));
    benchmark::DoNotOptimize(twist);
  }
  report(state);
}
BENCHMARK(BM_Kinematics_Forward)->Arg(4)->Arg(8)->Arg(-4)->Arg(-8);

void BM_Kinematics_ForwardWeighted(benchmark::State& state) {
  const Kinematics kinematics(bench_layout(state.range(0)));
  ModuleStates states;
  kinematics.inverse({0.7, -0.3, 1.1}, &states);
  ModuleWeights weights(kinematics.size(), 1.0);
  weights[1] = 0.2;
  Eigen::Vector3d twist;
  for (auto _ : state) {
    benchmark::DoNotOptimize(kinematics.forward(states, weights, &twist));
    benchmark::DoNotOptimize(twist);
  }
  report(state);
}
BENCHMARK(BM_Kinematics_ForwardWeighted)->Arg(4)->Arg(8);

void BM_Kinematics_SecondOrder(benchmark::State& state) {
  const Kinematics kinematics(bench_layout(state.range(0)));
  ModuleStates states;
  kinematics.inverse({0.7, -0.3, 1.1}, &states);
  ModuleAccelerations accelerations;
  int64_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(kinematics.second_order({0.7, -0.3, 1.1}, command_at(i++), states, &accelerations));
    benchmark::ClobberMemory();
  }
  report(state);
}
BENCHMARK(BM_Kinematics_SecondOrder)->Arg(4)->Arg(8);

void BM_Kinematics_OdometryUpdate(benchmark::State& state) {
  const Kinematics kinematics(bench_layout(state.range(0)));
  ModulePositions wheels(kinematics.size());
  Odometry odometry(kinematics, wheels);
  for (auto _ : state) {
    for (ModulePosition& w : wheels) w.distance += 0.01;
    benchmark::DoNotOptimize(odometry.update(wheels));
  }
  report(state);
}
BENCHMARK(BM_Kinematics_OdometryUpdate)->Arg(4)->Arg(8);

void BM_Kinematics_EstimateIcr(benchmark::State& state) {
  const Kinematics kinematics(bench_layout(state.range(0)));
  ModuleStates states;
  kinematics.inverse({0.7, -0.3, 1.1}, &states);
  IcrEstimate icr;
  for (auto _ : state) {
    benchmark::DoNotOptimize(estimate_icr(kinematics, states, &icr));
    benchmark::ClobberMemory();
  }
  report(state);
}
BENCHMARK(BM_Kinematics_EstimateIcr)->Arg(4)->Arg(8);

void BM_Kinematics_SetpointStep(benchmark::State& state) {
  const Kinematics kinematics(bench_layout(state.range(0)));
  const SetpointGenerator generator(kinematics, ProfileLimits{});
  Setpoint setpoint = generator.stopped();
  Setpoint next = setpoint;
  int64_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(generator.step(setpoint, command_at(i++ * 37), 0.02, &next));
    setpoint = next;
  }
  report(state);
}
BENCHMARK(BM_Kinematics_SetpointStep)->Arg(4)->Arg(8);

}  // namespace
}  // namespace swerve
