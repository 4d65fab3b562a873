// The one translation unit that instantiates the prediction step for ceres::Jet: its compile time is
// the cost of the prediction's derivatives.
#include "swerve/models/semi_implicit_step_jacobian.hpp"

#include <cmath>
#include <utility>

#include "swerve/models/jet_chunks.hpp"

namespace swerve {

struct SemiImplicitStepJacobian::Twin {
  Twin(const VehicleParams& params, const PredictionOptions& options) : step(params, (options.validate(), options)) {}
  SemiImplicitStep<ModelJet> step;
};

namespace {

// The twist-to-module map differentiated once per Jacobian: directions 0-2 the twist, direction 3
// every module's steering angle (module i's inputs depend on the twist and its own angle alone).
using CommandJet = ceres::Jet<double, 4>;
using CommandJetVector = Eigen::Matrix<CommandJet, Eigen::Dynamic, 1>;
constexpr int kAngleDirection = 3;

}  // namespace

struct SemiImplicitStepJacobian::Data::Impl {
  Impl(const SemiImplicitStepJacobian& jacobian, const SemiImplicitStep<ModelJet>& step)
      : owner(&jacobian),
        data(step),
        x(ModelJetVector::Zero(step.state_size())),
        u(ModelJetVector::Zero(step.model().input_size())),
        twist(ModelJetVector::Zero(3)),
        out(ModelJetVector::Zero(step.state_size())),
        command_angles(CommandJetVector::Zero(step.model().modules())),
        commands(CommandJetVector::Zero(step.model().input_size())) {}
  const SemiImplicitStepJacobian* owner;  // its scratch is shaped for this one only
  SemiImplicitStep<ModelJet>::Data data;
  ModelJetVector x, u, twist, out;  // u: module inputs (given, or mapped from the twist)
  CommandJetVector command_angles, commands;  // twist_step's map, differentiated once
};

SemiImplicitStepJacobian::SemiImplicitStepJacobian(const VehicleParams& params, const PredictionOptions& options)
    : twin_(std::make_unique<Twin>(params, options)) {
  state_size_ = twin_->step.state_size();
  input_size_ = twin_->step.model().input_size();
}

SemiImplicitStepJacobian::~SemiImplicitStepJacobian() = default;

void SemiImplicitStepJacobian::observe_friction_scales(const double* scales) noexcept {
  twin_->step.observe_friction_scales(scales);
}

void SemiImplicitStepJacobian::observe_wear_weights(const double* weights) noexcept {
  twin_->step.observe_wear_weights(weights);
}

void SemiImplicitStepJacobian::observe_module_faults(const ModuleFaults* faults) noexcept {
  twin_->step.observe_module_faults(faults);
}

int SemiImplicitStepJacobian::chunks(int directions) noexcept {
  return (directions + kModelJetSize - 1) / kModelJetSize;
}

long SemiImplicitStepJacobian::model_evaluations(const Data& data) noexcept {
  return data.impl_ == nullptr ? 0 : SemiImplicitStep<ModelJet>::model_evaluations(data.impl_->data);
}

long SemiImplicitStepJacobian::linearisations(const Data& data) noexcept {
  return data.impl_ == nullptr ? 0 : SemiImplicitStep<ModelJet>::linearisations(data.impl_->data);
}

SemiImplicitStepJacobian::Data::Data(const SemiImplicitStepJacobian& jacobian)
    : impl_(std::make_unique<Impl>(jacobian, jacobian.twin_->step)) {}
SemiImplicitStepJacobian::Data::~Data() = default;
SemiImplicitStepJacobian::Data::Data(Data&&) noexcept = default;
SemiImplicitStepJacobian::Data& SemiImplicitStepJacobian::Data::operator=(Data&&) noexcept = default;

namespace {

// Every entry finite, as one sum: a NaN or an infinity in any entry makes it non-finite, at a
// fraction of Eigen's allFinite() over ~nx^2 entries. Finite entries could only sum to infinity
// near 1e308, which no step's derivative comes close to.
bool derivatives_finite(const Eigen::Ref<Eigen::MatrixXd>& a, const Eigen::Ref<Eigen::MatrixXd>& b,
                        const Eigen::Ref<Eigen::VectorXd>& wear_gradient) {
  return std::isfinite(a.sum() + b.sum() + wear_gradient.sum());
}

bool arguments_ok(int nx, int nu, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                  double dt, const Eigen::Ref<Eigen::VectorXd>& x_next, const Eigen::Ref<Eigen::MatrixXd>& a,
                  const Eigen::Ref<Eigen::MatrixXd>& b, const Eigen::Ref<Eigen::VectorXd>& wear_gradient) {
  return x.size() == nx && u.size() == nu && x_next.size() == nx && a.rows() == nx && a.cols() == nx &&
         b.rows() == nx && b.cols() == nu && wear_gradient.size() == nx + nu && dt > 0.0 && std::isfinite(dt) &&
         x.allFinite() && u.allFinite();
}

}  // namespace

bool SemiImplicitStepJacobian::module_step(Data& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                           const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                                           Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                                           Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                                           Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
  if (data.impl_ == nullptr || data.impl_->owner != this ||
      !arguments_ok(state_size_, input_size_, x, u, dt, x_next, a, b, wear_gradient)) {
    return false;
  }
  const SemiImplicitStep<ModelJet>& step = twin_->step;
  Data::Impl& j = *data.impl_;
  bool first = true;
  const bool ok = jet_jacobian(x, u, j.x, j.u, j.out, x_next, a, b, stage_wear, wear_gradient.data(),
                               [&](ModelJet* wear) {
                                 SemiImplicitStep<ModelJet>::begin_chunk(j.data, std::exchange(first, false));
                                 return step.step(j.data, j.x, j.u, dt, j.out, wear);
                               });
  return ok && derivatives_finite(a, b, wear_gradient);
}

bool SemiImplicitStepJacobian::twist_step(Data& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                          const Eigen::Vector3d& twist_body, double dt,
                                          Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                                          Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                                          Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
  if (data.impl_ == nullptr || data.impl_->owner != this ||
      !arguments_ok(state_size_, 3, x, twist_body, dt, x_next, a, b, wear_gradient)) {
    return false;
  }
  const SemiImplicitStep<ModelJet>& step = twin_->step;
  Data::Impl& j = *data.impl_;
  const int modules = step.model().modules();
  Eigen::Matrix<CommandJet, 3, 1> command_twist;
  for (int k = 0; k < 3; ++k) command_twist[k] = CommandJet(twist_body[k], k);
  for (int i = 0; i < modules; ++i) j.command_angles[i] = CommandJet(x[StateIndex::steering(i)], kAngleDirection);
  step.module_inputs_at<CommandJet>(command_twist, j.command_angles, dt, j.commands);
  bool first = true;
  const bool ok = jet_jacobian(x, twist_body, j.x, j.twist, j.out, x_next, a, b, stage_wear, wear_gradient.data(),
                               [&](ModelJet* wear) {
                                 SemiImplicitStep<ModelJet>::begin_chunk(j.data, std::exchange(first, false));
                                 // The chunk's directions through the map's partials (chain rule).
                                 for (int i = 0; i < modules; ++i) {
                                   for (const int k : {InputIndex::steering_rate(i), InputIndex::wheel_speed(i)}) {
                                     const CommandJet& command = j.commands[k];
                                     ModelJet& input = j.u[k];
                                     input = ModelJet(command.a);
                                     for (int t = 0; t < 3; ++t) input.v += command.v[t] * j.twist[t].v;
                                     input.v += command.v[kAngleDirection] * j.x[StateIndex::steering(i)].v;
                                   }
                                 }
                                 return step.step(j.data, j.x, j.u, dt, j.out, wear);
                               });
  return ok && derivatives_finite(a, b, wear_gradient);
}

}  // namespace swerve
