// The prediction model's rollout, the unit of work of every optimiser backend (issue 16): full
// N = 20 rollouts of the twist-parameterised prediction (TwistPredictionModel's step) per second,
// for 4, 8, 10 and 16 modules, and the vehicle-model evaluations each stage costs. Two motions:
// cruise (0.8 m/s along an arc, the annealer's proposals as small twist perturbations around it)
// and start (from rest towards 0.5 m/s, where the slow-motion substeps apply). lags:1 is the
// shipped default's prediction (drive_lag and steering_lag: the wheel speeds and steering rates as
// lagged states, rolling and at rest at the start); lags:0 the actuators that follow at once.
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "support/model_fixtures.hpp"
#include "swerve/ocp/vehicle_prediction_model.hpp"

namespace swerve {
namespace {

constexpr int kHorizon = 20;
constexpr double kDt = 0.05;
constexpr int kProposals = 64;  // distinct twist sequences, cycled

struct RolloutCase {
  VehicleParams params;
  VehiclePredictionModel model;
  std::unique_ptr<PredictionData> data;  // the model's step scratch
  Eigen::VectorXd start, x, x_next;
  std::vector<std::array<Eigen::Vector3d, kHorizon>> proposals;

  static PredictionOptions options(bool lags) {
    PredictionOptions options;
    options.drive_lag = lags;
    options.steering_lag = lags;
    return options;
  }

  RolloutCase(int modules, bool from_rest, bool lags)
      : params(testing::make_params(
            ModuleLayout::multi_axle(modules / 2, 0.6, 0.5, 0.1, ModuleLimits{2.0, 2.0, 3.0, -kPi, kPi}))),
        model(params, options(lags)),
        data(model.create_data()) {
    const int nx = model.state_size();
    start = Eigen::VectorXd::Zero(nx);
    const Eigen::Vector3d cruise(0.8, 0.0, 0.8 / 3.0);
    if (!from_rest) {
      start.segment<3>(StateIndex::kVx) = cruise;
      for (int i = 0; i < modules; ++i) {
        const Eigen::Vector2d& p = params.layout.position_body(i);
        start[StateIndex::steering(i)] = std::atan2(cruise.y() + cruise.z() * p.x(), cruise.x() - cruise.z() * p.y());
        if (model.wheel_speed_states() > 0) {  // rolling
          const Eigen::Vector2d v = point_velocity<double>(cruise, p);
          start[StateIndex::prefix_size(modules) + i] = v.norm() / params.layout.wheel_radius();
        }
      }
    }
    x = x_next = start;
    std::mt19937_64 random(7);
    std::normal_distribution<double> noise(0.0, 1.0);
    proposals.resize(kProposals);
    for (auto& twists : proposals) {
      for (int k = 0; k < kHorizon; ++k) {
        const Eigen::Vector3d target = from_rest ? Eigen::Vector3d(0.5 * (k + 1) / kHorizon, 0.0, 0.0) : cruise;
        twists[static_cast<std::size_t>(k)] =
            target + Eigen::Vector3d(0.02 * noise(random), 0.02 * noise(random), 0.02 * noise(random));
      }
    }
  }

  bool rollout(int proposal, double* wear) {
    x = start;
    *wear = 0.0;
    for (int k = 0; k < kHorizon; ++k) {
      double stage_wear = 0.0;
      if (!model.twist_step(*data, x, proposals[static_cast<std::size_t>(proposal)][static_cast<std::size_t>(k)], kDt,
                            x_next, &stage_wear)) {
        return false;
      }
      *wear += stage_wear;
      x.swap(x_next);
    }
    return true;
  }
};

void BM_Prediction_Rollout(benchmark::State& state) {
  RolloutCase rollout_case(static_cast<int>(state.range(0)), state.range(1) != 0, state.range(2) != 0);
  const long evaluations_before = VehiclePredictionModel::model_evaluations(*rollout_case.data);
  long rollouts = 0;
  double wear = 0.0;
  for (auto _ : state) {
    if (!rollout_case.rollout(static_cast<int>(rollouts % kProposals), &wear)) {
      state.SkipWithError("rollout failed");
      break;
    }
    benchmark::DoNotOptimize(wear);
    ++rollouts;
  }
  state.counters["rollouts_per_s"] = benchmark::Counter(static_cast<double>(rollouts), benchmark::Counter::kIsRate);
  state.counters["evals_per_stage"] =
      rollouts > 0 ? static_cast<double>(VehiclePredictionModel::model_evaluations(*rollout_case.data) - evaluations_before) /
                         (static_cast<double>(rollouts) * kHorizon)
                   : 0.0;
}
BENCHMARK(BM_Prediction_Rollout)
    ->ArgsProduct({{4, 8, 10, 16}, {0, 1}, {0, 1}})
    ->ArgNames({"modules", "from_rest", "lags"})
    ->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace swerve
