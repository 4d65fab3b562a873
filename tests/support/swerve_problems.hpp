// The swerve optimal control problems the MPC and solver tests and the solver benchmarks share: a
// 4-module robot (0.6 x 0.5 m, the model fixtures' 40 kg per module; 2n modules on n axles 0.6 m
// apart for more) with body-twist inputs, cruising at 0.5 m/s, in two scenes.
//   kSidestep: the reference runs 0.2 m to the left (wear 1, rate 1, default pose weights); the
//              conformance suite's problem. set_cycle(c) moves the reference c steps on;
//              next_cycle(c, &plan) moves the whole problem one receding-horizon cycle on.
//   kTurn:     turning at 0.1 rad/s towards a reference ahead, every cost term active.
#pragma once

#include <Eigen/Core>

#include <random>

#include "support/model_fixtures.hpp"
#include "swerve/ocp/ocp_problem.hpp"
#include "swerve/ocp/solver.hpp"
#include "swerve/ocp/twist_prediction_model.hpp"

namespace swerve::testing {

enum class SwerveScene { kSidestep, kTurn };

struct SwerveTestProblem {
  VehicleParams params;
  TwistPredictionModel model{params};
  SwerveScene scene;
  OcpProblem problem;

  explicit SwerveTestProblem(SwerveScene which, int horizon = 20, double max_step = -1.0, int modules = 4)
      : params(make_params(modules == 4 ? ModuleLayout::rectangle(0.6, 0.5, 0.1)
                                        : ModuleLayout::multi_axle(modules / 2, 0.6, 0.5, 0.1))),
        scene(which), problem(model, horizon, 0.05, weights(which), bounds(which, max_step)) {
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(model.state_size());
    const Eigen::Vector3d twist = which == SwerveScene::kSidestep ? Eigen::Vector3d(0.5, 0.0, 0.0)
                                                                  : Eigen::Vector3d(0.5, 0.0, 0.1);
    x0.segment<3>(3) = twist;
    problem.set_initial_state(x0);
    problem.set_previous_input(twist);
    set_cycle(0);
  }

  // Keep going straight at 0.5 m/s over the whole horizon: in the sidestep scene a feasible start
  // that is not the optimum (the reference is aside), the start the solver tests give.
  Eigen::MatrixXd straight_on() const {
    Eigen::MatrixXd inputs = Eigen::MatrixXd::Zero(3, problem.horizon());
    inputs.row(0).setConstant(0.5);
    return inputs;
  }
  SwerveTestProblem(const SwerveTestProblem&) = delete;  // the problem points at the model

  void set_cycle(int cycle) {
    for (int k = 1; k <= problem.horizon(); ++k) {
      const int j = k + cycle;
      if (scene == SwerveScene::kSidestep) {
        problem.set_reference(k, {0.025 * j, 0.2, 0.0}, {0.5, 0.0, 0.0});
      } else {
        problem.set_reference(k, {0.03 * j, 0.004 * j, 0.01 * j}, {0.6, 0.0, 0.2});
      }
    }
  }

  // One receding-horizon cycle on along `plan`, a solution of this problem: the state it predicted,
  // its first input as the last one sent, the reference at `cycle`; `plan` is shifted one step, so
  // its inputs are the next cycle's warm start.
  void next_cycle(int cycle, Solution* plan) {
    problem.set_initial_state(plan->states.col(1));
    problem.set_previous_input(plan->inputs.col(0));
    set_cycle(cycle);
    plan->shift();
  }

  // Inputs near the turning reference's twist, jittered by up to +-`spread` per entry.
  Eigen::MatrixXd jittered_inputs(double spread, unsigned seed) const {
    std::mt19937 random(seed);
    std::uniform_real_distribution<double> jitter(-spread, spread);
    Eigen::MatrixXd inputs(3, problem.horizon());
    for (int k = 0; k < problem.horizon(); ++k) {
      inputs.col(k) = Eigen::Vector3d(0.55 + jitter(random), jitter(random), 0.15 + jitter(random));
    }
    return inputs;
  }

  static CostWeights weights(SwerveScene which) {
    CostWeights w;
    if (which == SwerveScene::kSidestep) {
      w.wear = 1.0;
      w.rate = Eigen::Vector3d::Constant(1.0);
    } else {
      w.pose = {10.0, 10.0, 200.0};
      w.twist = {1.0, 1.0, 0.5};
      w.wear = 3.0;
      w.effort = Eigen::Vector3d(0.01, 0.02, 0.03);
      w.rate = Eigen::Vector3d(1.0, 1.0, 0.5);
    }
    return w;
  }
  // max_step < 0: the scene's default (sidestep 0.1 / 0.1 / 0.25, turn 0.25).
  static InputBounds bounds(SwerveScene which, double max_step) {
    InputBounds b;
    b.upper = Eigen::Vector3d(2.0, 2.0, 4.0);
    b.lower = -b.upper;
    if (max_step > 0.0) {
      b.max_step = Eigen::Vector3d::Constant(max_step);
    } else {
      b.max_step = which == SwerveScene::kSidestep ? Eigen::Vector3d(0.1, 0.1, 0.25) : Eigen::Vector3d::Constant(0.25);
    }
    return b;
  }
};

}  // namespace swerve::testing
