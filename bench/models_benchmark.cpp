// Physical models: one derivative evaluation, one RK4 step (1 substep, with the wear quadrature)
// and the Jet Jacobian of that step (dF/dx, dF/du, wear gradient), for 4, 8 and 16 modules, in
// double. Goals (issue 6): <= 200 ns per module per derivative; Jacobian <= 15x one step. And the
// optimisers' prediction step (semi-implicit, both actuator lags as states, body twist input) with
// its Jacobian, the pair every gradient backend evaluates per stage.
#include <benchmark/benchmark.h>

#include <algorithm>

#include "swerve/models/dynamics_jacobian.hpp"
#include "swerve/models/integrators.hpp"
#include "swerve/models/semi_implicit_step_jacobian.hpp"
#include "swerve/models/vehicle_model.hpp"
#include "swerve/ocp/vehicle_prediction_model.hpp"

namespace swerve {
namespace {

VehicleParams bench_params(int modules) {
  VehicleParams params(ModuleLayout::multi_axle(modules / 2, 1.04, 1.69, 0.325));  // paper-like
  params.mass = 80.0 * modules;
  params.yaw_inertia = 290.0 * modules;
  params.cog_height = 0.6;
  params.plant.relaxation_length = 0.1;
  params.plant.load_transfer = true;
  return params;
}

// A moving, slipping, steering state (every tire in its nonlinear range somewhere).
void bench_point(const VehicleModel<double>& model, Eigen::VectorXd* x, Eigen::VectorXd* u) {
  *x = Eigen::VectorXd::Zero(model.state_size());
  *u = Eigen::VectorXd::Zero(model.input_size());
  (*x)(StateIndex::kVx) = 1.0;
  (*x)(StateIndex::kVy) = 0.1;
  (*x)(StateIndex::kYawRate) = 0.2;
  for (int i = 0; i < model.modules(); ++i) {
    (*x)(StateIndex::steering(i)) = 0.05 * i;
    (*u)(InputIndex::steering_rate(i)) = 0.3;
    (*u)(InputIndex::wheel_speed(i)) = 3.2 + 0.05 * i;
  }
  if (model.state_size() > StateIndex::prefix_size(model.modules())) {
    *x = model.complete_state(x->head(StateIndex::prefix_size(model.modules())));
  }
}

void BM_Models_Derivative(benchmark::State& state) {
  const int modules = static_cast<int>(state.range(0));
  const VehicleModel<double> model(bench_params(modules), Fidelity::kIdeal);
  Eigen::VectorXd x;
  Eigen::VectorXd u;
  bench_point(model, &x, &u);
  Eigen::VectorXd x_dot(model.state_size());
  double wear = 0.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(model.derivative(x, u, x_dot, nullptr, &wear));
    benchmark::DoNotOptimize(x_dot.data());
  }
  state.counters["modules"] = modules;
  state.counters["module_evals"] = benchmark::Counter(static_cast<double>(modules), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_Models_Derivative)->Arg(4)->Arg(8)->Arg(16);

void BM_Models_DerivativePlant(benchmark::State& state) {
  const int modules = static_cast<int>(state.range(0));
  const VehicleModel<double> model(bench_params(modules), Fidelity::kPlant);
  Eigen::VectorXd x;
  Eigen::VectorXd u;
  bench_point(model, &x, &u);
  Eigen::VectorXd x_dot(model.state_size());
  for (auto _ : state) {
    benchmark::DoNotOptimize(model.derivative(x, u, x_dot));
    benchmark::DoNotOptimize(x_dot.data());
  }
  state.counters["module_evals"] = benchmark::Counter(static_cast<double>(modules), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_Models_DerivativePlant)->Arg(4)->Arg(8)->Arg(16);

void BM_Models_Rk4Step(benchmark::State& state) {
  const int modules = static_cast<int>(state.range(0));
  const VehicleModel<double> model(bench_params(modules), Fidelity::kIdeal);
  const DiscreteDynamics<double> dynamics(model);
  Eigen::VectorXd x;
  Eigen::VectorXd u;
  bench_point(model, &x, &u);
  Eigen::VectorXd next(model.state_size());
  double wear = 0.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(dynamics.step(x, u, 0.005, 1, next, &wear));
    benchmark::DoNotOptimize(next.data());
  }
}
BENCHMARK(BM_Models_Rk4Step)->Arg(4)->Arg(8)->Arg(16);

void BM_Models_Rk4StepJacobian(benchmark::State& state) {
  const int modules = static_cast<int>(state.range(0));
  const VehicleParams params = bench_params(modules);
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  DynamicsJacobian jacobian(params, Fidelity::kIdeal);
  Eigen::VectorXd x;
  Eigen::VectorXd u;
  bench_point(model, &x, &u);
  const int nx = model.state_size();
  const int nu = model.input_size();
  Eigen::VectorXd next(nx);
  Eigen::MatrixXd a(nx, nx);
  Eigen::MatrixXd b(nx, nu);
  Eigen::VectorXd gradient(nx + nu);
  double wear = 0.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(jacobian.discrete(x, u, 0.005, 1, next, a, b, &wear, gradient.data()));
    benchmark::DoNotOptimize(a.data());
  }
  state.counters["directions"] = nx + nu;
}
BENCHMARK(BM_Models_Rk4StepJacobian)->Arg(4)->Arg(8)->Arg(16);

// The prediction step at dt = 0.05 s from bench_point's motion (lagged wheels at their commands),
// commanded a slightly different twist: range(1) = 0 the double step, 1 with its Jacobian.
void BM_Models_PredictionStep(benchmark::State& state) {
  const int modules = static_cast<int>(state.range(0));
  const bool with_jacobian = state.range(1) != 0;
  const VehicleParams params = bench_params(modules);
  PredictionOptions options;
  options.drive_lag = true;
  options.steering_lag = true;
  const SemiImplicitStep<double> step(params, options);
  SemiImplicitStep<double>::Data data(step);
  const SemiImplicitStepJacobian jacobian(params, options);
  SemiImplicitStepJacobian::Data jacobian_data(jacobian);
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  Eigen::VectorXd x_model;
  Eigen::VectorXd u;
  bench_point(model, &x_model, &u);
  const int nx = step.state_size();
  Eigen::VectorXd x = Eigen::VectorXd::Zero(nx);
  x.head(x_model.size()) = x_model;
  for (int i = 0; i < step.wheel_speed_states(); ++i) x[x_model.size() + i] = u[InputIndex::wheel_speed(i)];
  const Eigen::Vector3d twist(1.05, 0.1, 0.22);
  Eigen::VectorXd next(nx);
  Eigen::MatrixXd a(nx, nx);
  Eigen::MatrixXd b(nx, 3);
  Eigen::VectorXd gradient(nx + 3);
  Eigen::VectorXd inputs(model.input_size());
  double wear = 0.0;
  const long evaluations_before = SemiImplicitStep<double>::model_evaluations(data);
  const long jacobian_evaluations_before = SemiImplicitStepJacobian::model_evaluations(jacobian_data);
  const long linearisations_before = SemiImplicitStepJacobian::linearisations(jacobian_data);
  for (auto _ : state) {
    if (with_jacobian) {
      benchmark::DoNotOptimize(jacobian.twist_step(jacobian_data, x, twist, 0.05, next, a, b, &wear, gradient));
    } else {
      step.module_inputs(x, twist, 0.05, inputs);
      benchmark::DoNotOptimize(step.step(data, x, inputs, 0.05, next, &wear));
    }
    benchmark::DoNotOptimize(next.data());
  }
  state.counters["directions"] = with_jacobian ? nx + 3 : 0;
  // The work clock's units (WorkClock, VehiclePredictionModel::charge_work_to): module evaluations
  // in double per step; per Jacobian its twist solves' evaluations, its linearisations and its Jet
  // chunks, as VehiclePredictionModel prices them. Time per unit is the rate to charge, so the two
  // rows' s_per_unit agree when the Jacobian's prices are right.
  const double per_iteration = 1.0 / std::max(static_cast<double>(state.iterations()), 1.0);
  const double iterations = static_cast<double>(state.iterations());
  double units = 0.0;
  if (with_jacobian) {
    const double evaluations =
        static_cast<double>(SemiImplicitStepJacobian::model_evaluations(jacobian_data) - jacobian_evaluations_before);
    const double linearisations =
        static_cast<double>(SemiImplicitStepJacobian::linearisations(jacobian_data) - linearisations_before);
    units = modules * (evaluations * per_iteration +
                       VehiclePredictionModel::module_evaluations_per_linearisation() * linearisations * per_iteration +
                       VehiclePredictionModel::module_evaluations_per_jet_chunk() * SemiImplicitStepJacobian::chunks(nx + 3));
  } else {
    units = modules * static_cast<double>(SemiImplicitStep<double>::model_evaluations(data) - evaluations_before) *
            per_iteration;
  }
  state.counters["work_units"] = units;
  state.counters["s_per_unit"] = benchmark::Counter(units * iterations, benchmark::Counter::kIsRate |
                                                                            benchmark::Counter::kInvert);
}
BENCHMARK(BM_Models_PredictionStep)->ArgsProduct({{4, 8, 10, 16}, {0, 1}})->ArgNames({"modules", "jacobian"});

}  // namespace
}  // namespace swerve
