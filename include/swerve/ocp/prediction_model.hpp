// The discrete map x_{k+1} = F(x_k, u_k) over one controller step, as the optimal control problem
// and every solver backend see it. The swerve vehicle implements it on top of the dynamic model;
// tests implement it with systems whose optimum is known in closed form. Gradient-based backends
// also need its exact Jacobians (step_jacobians). A model is immutable; the scratch of its step
// lives in a PredictionData its caller owns, so rollouts on separate data may run on separate threads.
#pragma once

#include <Eigen/Core>

#include <memory>

#include "swerve/ocp/deadline.hpp"

namespace swerve {

// The scratch of a model's step (Crocoddyl's createData(), acados' workspace), made by the model's
// create_data() and owned by the caller: one per thread makes rollouts re-entrant.
class PredictionData {
 public:
  virtual ~PredictionData() = default;
};

class PredictionModel {
 public:
  virtual ~PredictionModel() = default;
  virtual int state_size() const noexcept = 0;
  virtual int input_size() const noexcept = 0;
  // Inputs come in groups that belong together (a swerve module's steering rate and wheel speed);
  // the annealer perturbs a group at a time. Must divide input_size().
  virtual int input_group_size() const noexcept { return 1; }

  // Advances `x` by one step of `dt` under the constant input `u`, writing the next state and the
  // tire wear accumulated over the step (0 for models without wear). The state starts with the
  // pose (x, y, psi) in the world frame and the body twist (vx, vy, r), which the tracking cost
  // reads. noexcept and allocation-free; returns false when the result is not finite.
  virtual bool step(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                    double dt, Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept = 0;

  // Scratch for step(data, ...), sized once (no allocation after). nullptr, the default, for models
  // whose step needs none.
  virtual std::unique_ptr<PredictionData> create_data() const { return nullptr; }
  // step() on `data`, which this model's create_data() made (nullptr: the model's own scratch,
  // which makes the call not re-entrant). Steps on separate data may run on separate threads, with
  // the results of one thread bit for bit. The default suits models without scratch.
  virtual bool step(PredictionData* data, const Eigen::Ref<const Eigen::VectorXd>& x,
                    const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                    double* stage_wear) const noexcept {
    (void)data;
    return step(x, u, dt, x_next, stage_wear);
  }

  // The clock this model charges its work to (Clock::charge, in module evaluations), so a work
  // clock prices a rollout by what it evaluates; nullptr (the default) charges nothing. Wiring,
  // set by the owner before solving, not part of an evaluation: the clock must outlive the model.
  // Models whose cost does not grow with a vehicle's size may leave it unused (the default).
  virtual void charge_work_to(const Clock* clock) noexcept { (void)clock; }

  // Whether step_jacobians() gives exact derivatives (gradient-based backends need them).
  virtual bool has_jacobians() const noexcept { return false; }
  // step() with its exact Jacobians: a = dx_next/dx (nx x nx), b = dx_next/du (nx x nu), the stage
  // wear and its gradient [dW/dx; dW/du] (nx + nu). noexcept and allocation-free; false when the
  // model has none (the default), on wrong sizes, or when the result is not finite.
  virtual bool step_jacobians(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                              double dt, Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                              Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                              Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
    (void)x, (void)u, (void)dt, (void)x_next, (void)a, (void)b, (void)stage_wear, (void)wear_gradient;
    return false;
  }
  // step_jacobians() on `data` (this model's create_data(); nullptr: the model's own scratch), so
  // Jacobians on separate data may run on separate threads, as steps may. The default suits models
  // without scratch.
  virtual bool step_jacobians(PredictionData* data, const Eigen::Ref<const Eigen::VectorXd>& x,
                              const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                              Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                              Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
    (void)data;
    return step_jacobians(x, u, dt, x_next, a, b, stage_wear, wear_gradient);
  }
};

}  // namespace swerve
