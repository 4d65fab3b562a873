// The discrete map x_{k+1} = F(x_k, u_k) over one controller step, as the optimal control problem
// and every solver backend see it. The swerve vehicle implements it on top of the dynamic model;
// tests implement it with systems whose optimum is known in closed form.
#pragma once

#include <Eigen/Core>

namespace swerve {

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
};

}  // namespace swerve
