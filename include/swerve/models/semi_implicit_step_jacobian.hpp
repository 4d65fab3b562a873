// Exact Jacobians of the prediction's discrete map (semi_implicit_step.hpp), the one derivative path
// every gradient backend, the tests and the benchmarks use: x_next = F(x, u, dt) and its stage wear
// W, with a = dF/dx, b = dF/du and [dW/dx, dW/du], from the same step evaluated in ceres::Jet
// chunks of 8 directions (jet_chunks.hpp). The body twist's derivatives are the implicit function
// theorem's (SemiImplicitStep's header), not differentiated Newton iterations. The Jets stay here;
// the API is double.
#pragma once

#include <Eigen/Core>

#include <memory>

#include "swerve/models/semi_implicit_step.hpp"
#include "swerve/models/vehicle_params.hpp"

namespace swerve {

class SemiImplicitStepJacobian {
 public:
  // Builds the step's Jet twin from `params` and `options` (both validated; throws ConfigError).
  SemiImplicitStepJacobian(const VehicleParams& params, const PredictionOptions& options);
  ~SemiImplicitStepJacobian();
  SemiImplicitStepJacobian(const SemiImplicitStepJacobian&) = delete;
  SemiImplicitStepJacobian& operator=(const SemiImplicitStepJacobian&) = delete;

  int state_size() const noexcept { return state_size_; }
  int input_size() const noexcept { return input_size_; }  // module inputs: 2 per module
  // The Jet evaluations of the step one Jacobian takes: the nx + (input size) directions in chunks
  // of the Jet's width (module_step: input_size(); twist_step: 3).
  static int chunks(int directions) noexcept;

  // The caller's scratch: the step's Jet data and the seeded inputs, for the Jacobian it was made
  // from only. The Jacobian object itself is immutable, so evaluations that each pass a Data of
  // their own may run on threads of their own.
  class Data {
   public:
    explicit Data(const SemiImplicitStepJacobian& jacobian);  // allocates; nothing after
    ~Data();
    Data(Data&&) noexcept;
    Data& operator=(Data&&) noexcept;

   private:
    friend class SemiImplicitStepJacobian;
    struct Impl;
    std::unique_ptr<Impl> impl_;
  };

  // The modules' faults from now on (SemiImplicitStep::observe_module_faults; null: none).
  void observe_module_faults(const ModuleFaults* faults) noexcept;
  // The floor's grip under each module (SemiImplicitStep::observe_friction_scales; null: none).
  void observe_friction_scales(const double* scales) noexcept;
  // Each module's weight on its wear (SemiImplicitStep::observe_wear_weights; null: 1 each).
  void observe_wear_weights(const double* weights) noexcept;

  // The work the Jacobians on `data` did so far: the vehicle model's evaluations in their twist
  // solves (as SemiImplicitStep::model_evaluations counts a double step's) and its linearisations.
  static long model_evaluations(const Data& data) noexcept;
  static long linearisations(const Data& data) noexcept;

  // With module inputs u (steering rate, wheel speed per module): a is nx x nx, b nx x nu,
  // wear_gradient nx + nu entries. False (outputs unspecified) for a Data made for another
  // Jacobian (or moved from), wrong sizes, a non-finite or non-positive dt, non-finite x or u, a
  // failed step, or a non-finite derivative. No allocation.
  bool module_step(Data& data, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                   double dt, Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                   Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                   Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept;

  // With the body twist (vx, vy, r) as the input, mapped to module inputs by
  // SemiImplicitStep::module_inputs inside the differentiated step: b is nx x 3, wear_gradient
  // nx + 3 entries. Otherwise as module_step.
  bool twist_step(Data& data, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Vector3d& twist_body, double dt,
                  Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b,
                  double* stage_wear, Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept;

 private:
  struct Twin;                        // SemiImplicitStep<ModelJet>, defined where Jets are known
  std::unique_ptr<Twin> twin_;  // shared by every Data; immutable but for the faults observed
  int state_size_ = 0;
  int input_size_ = 0;
};

}  // namespace swerve
