// The MPC's prediction model of a swerve vehicle: the dynamic model with ideal actuators (the
// paper's hierarchical design: the drives track steering-rate and wheel-speed commands), as a
// PredictionModel. Steering end stops are respected by clipping the steering rate.
//
// Tire forces make the body velocities very stiff (cornering stiffness B C D ~ 1e4 N/rad per wheel
// against a few hundred kg: time constants of milliseconds, shorter still near standstill where
// slip is regularised), so an explicit step at the controller's dt diverges. The default step is
// therefore semi-implicit: steering angles advance explicitly, the body twist solves the backward
// Euler equation v+ = v + dt a(v+, delta+, omega) by Newton's method, the pose follows the SE(2)
// exponential of v+ over dt.
//
// Stage wear. The tire transient that the implicit step steps over (milliseconds) is where most of
// the wear of a sudden command happens, so dt times the wear rate at (v+, delta+) misses it (up to
// 25x low at a start-up against the 1 kHz RK4 plant). For the frictional-power wear model (no
// casters) the stage wear is therefore k times the energy balance of the step: the drives' work
// minus the body's kinetic-energy gain, sum_i h Fx_i(v+) r omega_i - [KE(v+) - KE(v0)], exact for
// steady motion and equal to the linear-damper limit 1/2 m dv^2 for an impulsive change (the
// implicit forces' impulse h F(v+) is the body's momentum change). Otherwise (Archard wear, or
// casters): dt times the rate.
//
// Slow motion (body and every commanded contact speed under 0.25 m/s, five slip-regularisation
// speeds) takes `slow_substeps` (5) shorter steps: with one step there the stage wear was off by
// 6-20x either way against the RK4 plant (within 2 % with five), and the controller, fearing the
// wrong things at a start, lagged and wore twice the baseline's wear on a smoothly ramped curve
// (20.5 J against 10.4 J; 11.4 J with them). Faster motion keeps one step: start-ups and large
// command changes are within ~15 %, and five steps everywhere cost too many optimiser proposals.
// Explicit RK4 with substeps is kept for comparison.
#pragma once

#include <Eigen/Core>

#include <memory>

#include "swerve/models/integrators.hpp"
#include "swerve/models/semi_implicit_step.hpp"
#include "swerve/models/semi_implicit_step_jacobian.hpp"
#include "swerve/models/vehicle_model.hpp"
#include "swerve/ocp/prediction_model.hpp"

namespace swerve {

class VehiclePredictionModel final : public PredictionModel {
 public:
  VehiclePredictionModel(const VehicleParams& params, PredictionOptions options = PredictionOptions{});
  ~VehiclePredictionModel() override;
  VehiclePredictionModel(const VehiclePredictionModel&) = delete;
  VehiclePredictionModel& operator=(const VehiclePredictionModel&) = delete;

  int state_size() const noexcept override { return state_size_; }
  int input_size() const noexcept override { return input_size_; }
  int input_group_size() const noexcept override { return 2; }  // (steering rate, wheel speed) per module
  // Charges modules x (double evaluations of the vehicle model) per step. A Jacobian is charged
  // per module its twist solves' evaluations likewise, plus module_evaluations_per_linearisation()
  // per substep linearised and module_evaluations_per_jet_chunk() per Jet chunk.
  void charge_work_to(const Clock* clock) noexcept override { work_clock_ = clock; }
  void observe_module_faults(const ModuleFaults* faults) noexcept override;
  void observe_friction_scales(const double* scales) noexcept override;
  // Semi-implicit steps only (PredictionMethod::kSemiImplicit): RK4's stage wear stays unweighted.
  void observe_wear_weights(const double* weights) noexcept override;
  // What one module's share of the model's linearisation at a substep, and of one Jet chunk of a
  // step (kModelJetSize directions chained through it), cost in double evaluations of one module,
  // as BM_Models_PredictionStep measures a step and its Jacobian on the reference machine.
  static double module_evaluations_per_linearisation() noexcept;
  static double module_evaluations_per_jet_chunk() noexcept;
  bool has_jacobians() const noexcept override { return true; }

  // The module inputs (2n: steering rate, wheel speed per module) that carry out `twist_body` over
  // the next `dt` from state `x`: inverse kinematics, the 180 deg choice nearest the current
  // steering angle, the steering-rate limit, and the wheel speed scaled by the cosine of the
  // steering error still left. noexcept, no allocation.
  void module_inputs(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Vector3d& twist_body, double dt,
                     Eigen::Ref<Eigen::VectorXd> inputs) const noexcept;

  // Scratch owned by the caller, for the steps and their Jacobians (made once, by create_data();
  // allocation-free after).
  class Data final : public PredictionData {
   public:
    Data(Data&&) noexcept;
    Data& operator=(Data&&) noexcept;
    ~Data() override;

   private:
    friend class VehiclePredictionModel;
    struct Impl;
    explicit Data(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
  };
  std::unique_ptr<PredictionData> create_data() const override;  // a Data
  bool step(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
            const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
            double* stage_wear) const noexcept override;
  bool step_jacobians(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                      const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                      Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                      Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept override;
  // The same step with the body twist (vx, vy, r) as its input, mapped to module inputs by
  // module_inputs() first (TwistPredictionModel is this as a PredictionModel), and its Jacobians
  // (b: nx x 3, wear_gradient: nx + 3).
  bool twist_step(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Vector3d& twist_body,
                  double dt, Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept;
  bool twist_step_jacobians(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                            const Eigen::Vector3d& twist_body, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                            Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                            Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept;

  const VehicleModel<double>& vehicle() const noexcept;
  // Evaluations of the vehicle model (each with the twist Jacobian, or in double for the final
  // values) by the double steps on `data` (a Data) since it was made: the rollout's cost driver
  // (BM_Prediction_Rollout reports them per stage).
  static long model_evaluations(const PredictionData& data) noexcept;
  const PredictionOptions& options() const noexcept { return options_; }
  // The state's lagged actuators (see SemiImplicitStep::state_size): n wheel speeds from index
  // 6 + n with drive_lag on a plant whose drives lag, else none; then n steering rates likewise.
  int wheel_speed_states() const noexcept;
  int steering_rate_states() const noexcept;

 private:
  PredictionOptions options_;
  int modules_, state_size_, input_size_;
  std::unique_ptr<SemiImplicitStep<double>> values_;
  std::unique_ptr<SemiImplicitStepJacobian> jacobian_;  // the step's derivatives (models/)
  const Clock* work_clock_ = nullptr;              // charged with the work of every step (not owned)
  int module_jacobian_chunks_ = 0, twist_jacobian_chunks_ = 0;  // Jet chunks per Jacobian
  bool charged_step(Data::Impl& own, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                    double dt, Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept;
  // Runs `evaluate` (a Jacobian on own's scratch, of `chunks` Jet chunks) and charges its work.
  template <typename Evaluate>
  bool charged_jacobian(Data::Impl& own, int chunks, const Evaluate& evaluate) const noexcept;
  static Data::Impl& scratch(PredictionData& data) noexcept;  // data's, which must be a Data
};

}  // namespace swerve
