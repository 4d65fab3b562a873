// The discrete map x_{k+1} = F(x_k, u_k) over one controller step, as the optimal control problem
// and every solver backend see it. The swerve vehicle implements it on top of the dynamic model;
// tests implement it with systems whose optimum is known in closed form. Gradient-based backends
// also need its exact Jacobians (step_jacobians). A model is immutable; the scratch of its step
// lives in a PredictionData its caller owns (PredictionWorkspace: one per thread), so rollouts on
// separate data may run on separate threads.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <vector>

#include "swerve/kinematics/module_faults.hpp"
#include "swerve/ocp/deadline.hpp"

namespace swerve {

// The scratch of a model's step (Crocoddyl's createData(), acados' workspace), made by the model's
// create_data() and owned by the caller: one per thread makes rollouts re-entrant. A data serves
// only the model that made it.
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

  // Scratch for step() and step_jacobians(), sized once (no allocation after). Never null; models
  // whose step needs no scratch keep the default, an empty PredictionData.
  virtual std::unique_ptr<PredictionData> create_data() const { return std::make_unique<PredictionData>(); }

  // Advances `x` by one step of `dt` under the constant input `u` on `data` (this model's
  // create_data()), writing the next state and the tire wear accumulated over the step (0 for
  // models without wear). The state starts with the pose (x, y, psi) in the world frame and the
  // body twist (vx, vy, r), which the tracking cost reads. noexcept and allocation-free; returns
  // false when the result is not finite. The model itself is immutable: steps on separate data may
  // run on separate threads, with the results of one thread bit for bit.
  virtual bool step(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                    const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                    double* stage_wear) const noexcept = 0;

  // The clock this model charges its work to (Clock::charge, in module evaluations), so a work
  // clock prices a rollout by what it evaluates; nullptr (the default) charges nothing. Wiring,
  // set by the owner before solving, not part of an evaluation: the clock must outlive the model.
  // Models whose cost does not grow with a vehicle's size may leave it unused (the default).
  virtual void charge_work_to(const Clock* clock) noexcept { (void)clock; }

  // The modules' faults the prediction takes from now on (a stuck steering holds its angle);
  // null: none. Wiring like charge_work_to: `faults` must outlive the model, and may change
  // between solves, never during one. Models without module steering ignore it (the default).
  virtual void observe_module_faults(const ModuleFaults* faults) noexcept { (void)faults; }
  // The floor's grip under each module from now on: one entry per module, its peak friction as a
  // multiple of the vehicle's tire mu (VehicleModel::observe_friction_scales); null: the tire's
  // own. Wiring as observe_module_faults. Models without tires ignore it (the default).
  virtual void observe_friction_scales(const double* scales) noexcept { (void)scales; }
  // Each module's weight on its own tire wear in the stage wear from now on (one entry per module,
  // finite and >= 0, e.g. from the tread each has left: wear balancing); null: 1 each. Wiring as
  // observe_module_faults. Models without modules' wear ignore it (the default).
  virtual void observe_wear_weights(const double* weights) noexcept { (void)weights; }

  // Whether step_jacobians() gives exact derivatives (gradient-based backends need them).
  virtual bool has_jacobians() const noexcept { return false; }
  // step() with its exact Jacobians: a = dx_next/dx (nx x nx), b = dx_next/du (nx x nu), the stage
  // wear and its gradient [dW/dx; dW/du] (nx + nu). noexcept and allocation-free; false when the
  // model has none (the default), on wrong sizes, or when the result is not finite.
  virtual bool step_jacobians(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                              const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                              Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                              Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
    (void)data, (void)x, (void)u, (void)dt, (void)x_next, (void)a, (void)b, (void)stage_wear, (void)wear_gradient;
    return false;
  }
};

// The PredictionData a solver (or any other caller of a model) works on: one per thread, made at
// construction for the model of the problem shape it serves. Handed a problem on another model
// object (tests wrap a model in a clock), bind() makes data for that one: the only allocation
// after construction, which a controller, whose problem keeps its model, never triggers.
class PredictionWorkspace {
 public:
  // Throws ConfigError when `threads` < 1.
  PredictionWorkspace(const PredictionModel& model, int threads);

  // Makes every thread's data for `model` unless they were made for it; false when that fails (out
  // of memory), leaving the workspace bound to no model. Called by the owning thread before the
  // others use their data.
  bool bind(const PredictionModel& model) noexcept;
  // Thread `thread`'s data (0 <= thread < threads()), for the model last bound.
  PredictionData& data(int thread = 0) noexcept { return *data_[static_cast<std::size_t>(thread)]; }
  int threads() const noexcept { return static_cast<int>(data_.size()); }

 private:
  const PredictionModel* model_;
  std::vector<std::unique_ptr<PredictionData>> data_;
};

}  // namespace swerve
