// Exact first derivatives of an OcpProblem for the gradient-based backends (Ipopt, NLopt LD_*,
// Ceres): per-stage Jacobians of the prediction model, A_k = dx_{k+1}/dx_k and B_k = dx_{k+1}/du_k,
// and of the stage wear (from PredictionModel::step_jacobians, i.e. ceres::Jet), the analytic
// gradients of the quadratic stage costs, and from both the single-shooting gradient of the total
// cost by the adjoint (reverse) recursion. Sized once for a problem's shape; no allocation after.
// It linearises on scratch of its own (a PredictionWorkspace), so two OcpDerivatives may work on
// separate threads.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <vector>

#include "swerve/ocp/ocp_problem.hpp"
#include "swerve/ocp/deadline.hpp"

namespace swerve {

class OcpDerivatives {
 public:
  // Throws ConfigError when the problem's prediction model has no Jacobians.
  explicit OcpDerivatives(const OcpProblem& shape);

  int horizon() const noexcept { return horizon_; }
  int state_size() const noexcept { return nx_; }
  int input_size() const noexcept { return nu_; }

  // Stage k at (x_k, u_k): x_{k+1} = F(x_k, u_k), with A_k, B_k, the stage wear W_k and its gradient
  // stored for a(k), b(k), wear(k), wear_gradient(k). false when the model fails.
  bool linearize_stage(const OcpProblem& problem, int k, const Eigen::Ref<const Eigen::VectorXd>& x_k,
                       const Eigen::Ref<const Eigen::VectorXd>& u_k, Eigen::Ref<Eigen::VectorXd> x_next) noexcept;

  // Single shooting: rolls `inputs` (nu x N) out from the problem's initial state, linearising every
  // stage; writes the states (nx x N+1) and dJ/du (nu x N). Returns the total cost (the same number
  // OcpProblem::rollout gives), +inf when the model fails (gradient then zero). With `stop`, it
  // gives up between stages, returning NaN, before one that would end past stop if it cost what
  // the last one did (a gradient's cost varies with the state, so a caller on a deadline cannot
  // always foresee it).
  double cost_and_gradient(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                           Eigen::Ref<Eigen::MatrixXd> states, Eigen::Ref<Eigen::MatrixXd> gradient,
                           const Deadline* stop = nullptr) noexcept;
  // Stages the last cost_and_gradient linearised (N unless it gave up or the model failed).
  int completed_stages() const noexcept { return completed_stages_; }

  // The same gradient in two parts, for a plan whose rollout is known, so that its stages may be
  // linearised on several threads. linearize_stages linearises stages [first, last) at `states`
  // (the rollout of `inputs`, nx x N+1) on `data` (the problem's model's create_data()), writing
  // each next state to `x_next` (nx) only; it returns the stages
  // done, fewer than asked when the model fails (then -1) or when, with `stop`, a stage costing
  // what the last did would end past it. Calls on disjoint stage ranges, each on its own data and
  // x_next, may run on separate threads. gradient_of_stages then runs the adjoint recursion over
  // all N linearised stages and returns the total cost.
  int linearize_stages(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                       const Eigen::Ref<const Eigen::MatrixXd>& states, int first, int last, PredictionData& data,
                       Eigen::Ref<Eigen::VectorXd> x_next, const Deadline* stop = nullptr) noexcept;
  double gradient_of_stages(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                            const Eigen::Ref<const Eigen::MatrixXd>& states, Eigen::Ref<Eigen::MatrixXd> gradient) noexcept;

  // Forward sensitivities of single shooting, after cost_and_gradient or linearize_stage on every
  // stage of one rollout: dx_{k}/du_j (nx x nu) for j < k, by S_{k+1,j} = A_k S_{k,j}, S_{j+1,j} = B_j.
  // `sensitivity` is nx x (nu * N) and receives [dx_k/du_0 ... dx_k/du_{N-1}] (zero for j >= k).
  void propagate_sensitivity(int k, const Eigen::Ref<const Eigen::MatrixXd>& previous,
                             Eigen::Ref<Eigen::MatrixXd> sensitivity) const noexcept;

  const Eigen::MatrixXd& a(int k) const noexcept { return a_[static_cast<std::size_t>(k)]; }
  const Eigen::MatrixXd& b(int k) const noexcept { return b_[static_cast<std::size_t>(k)]; }
  double wear(int k) const noexcept { return wear_[k]; }
  // [dW_k/dx_k; dW_k/du_k] (nx + nu).
  const Eigen::VectorXd& wear_gradient(int k) const noexcept { return wear_gradient_[static_cast<std::size_t>(k)]; }
  // After a gradient (cost_and_gradient or gradient_of_stages), column k: the costate of stage k's
  // dynamics, dJ/dx_{k+1} of the whole cost, i.e. the multiplier of x_{k+1} = F(x_k, u_k) (nx x N).
  const Eigen::MatrixXd& costates() const noexcept { return costates_; }

 private:
  int horizon_, nx_, nu_;
  int completed_stages_ = 0;
  PredictionWorkspace workspace_;  // the step scratch of linearize_stage and cost_and_gradient
  bool linearize_stage_on(PredictionData& data, const OcpProblem& problem, int k,
                          const Eigen::Ref<const Eigen::VectorXd>& x_k, const Eigen::Ref<const Eigen::VectorXd>& u_k,
                          Eigen::Ref<Eigen::VectorXd> x_next) noexcept;

  std::vector<Eigen::MatrixXd> a_, b_;
  std::vector<Eigen::VectorXd> wear_gradient_;
  Eigen::VectorXd wear_;
  Eigen::VectorXd costate_, d_x_next_, d_u_, d_u_before_, scratch_;
  Eigen::MatrixXd costates_;  // nx x N: the last gradient's costates
};

}  // namespace swerve
