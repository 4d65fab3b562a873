// The prediction models' exact Jacobians: the one translation unit that instantiates the
// prediction step for ceres::Jet (its compile time is the cost of the derivatives), plus the
// constructor and destructor of VehiclePredictionModel, which own the Jet twin.
#include <cmath>
#include <utility>

#include "swerve/models/jet_chunks.hpp"
#include "swerve/models/semi_implicit_step.hpp"
#include "swerve/ocp/vehicle_prediction_model.hpp"
#include "vehicle_prediction_data.hpp"

namespace swerve {
namespace detail {

// The Jet twin of the double step: immutable, shared by every Data.
struct PredictionJets {
  PredictionJets(const VehicleParams& params, const PredictionOptions& options) : step(params, options) {}
  SemiImplicitStep<ModelJet> step;
};

// A Data's scratch for the twin.
struct JetScratch {
  explicit JetScratch(const SemiImplicitStep<ModelJet>& step) : data(step) {
    const int nx = step.state_size();
    const int nu = step.model().input_size();
    x = ModelJetVector::Zero(nx);
    u = ModelJetVector::Zero(nu);
    twist = ModelJetVector::Zero(3);
    out = ModelJetVector::Zero(nx);
  }
  SemiImplicitStep<ModelJet>::Data data;
  ModelJetVector x, u, twist, out;  // u: module inputs (given, or mapped from the twist)
};

void JetScratchDeleter::operator()(JetScratch* scratch) const noexcept { delete scratch; }

}  // namespace detail

VehiclePredictionModel::VehiclePredictionModel(const VehicleParams& params, PredictionOptions options)
    : options_(options) {
  options_.validate();
  values_ = std::make_unique<SemiImplicitStep<double>>(params, options_);
  jets_ = std::make_unique<detail::PredictionJets>(params, options_);
  modules_ = values_->model().modules();
  state_size_ = values_->state_size();
  input_size_ = values_->model().input_size();
  data_.reset(static_cast<Data*>(create_data().release()));
}

VehiclePredictionModel::~VehiclePredictionModel() = default;

std::unique_ptr<detail::JetScratch, detail::JetScratchDeleter> VehiclePredictionModel::make_jet_scratch() const {
  return std::unique_ptr<detail::JetScratch, detail::JetScratchDeleter>(new detail::JetScratch(jets_->step));
}

namespace {

bool jacobian_sizes_ok(int nx, int nu, const Eigen::Ref<const Eigen::VectorXd>& x,
                       const Eigen::Ref<const Eigen::VectorXd>& u, double dt, const Eigen::Ref<Eigen::VectorXd>& x_next,
                       const Eigen::Ref<Eigen::MatrixXd>& a, const Eigen::Ref<Eigen::MatrixXd>& b,
                       const Eigen::Ref<Eigen::VectorXd>& wear_gradient) {
  return x.size() == nx && u.size() == nu && x_next.size() == nx && a.rows() == nx && a.cols() == nx &&
         b.rows() == nx && b.cols() == nu && wear_gradient.size() == nx + nu && dt > 0.0 && std::isfinite(dt) &&
         x.allFinite() && u.allFinite();
}

}  // namespace

bool VehiclePredictionModel::step_jacobians(const Eigen::Ref<const Eigen::VectorXd>& x,
                                            const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                                            Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                                            Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                                            Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
  return step_jacobians(nullptr, x, u, dt, x_next, a, b, stage_wear, wear_gradient);
}

bool VehiclePredictionModel::step_jacobians(PredictionData* data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                            const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                                            Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                                            Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                                            Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
  if (!jacobian_sizes_ok(state_size_, input_size_, x, u, dt, x_next, a, b, wear_gradient)) return false;
  const SemiImplicitStep<ModelJet>& step = jets_->step;
  detail::JetScratch& j = *scratch(data).jets;
  bool first = true;
  const bool ok = jet_jacobian(x, u, j.x, j.u, j.out, x_next, a, b, stage_wear, wear_gradient.data(),
                               [&](ModelJet* wear) {
                                 SemiImplicitStep<ModelJet>::begin_chunk(j.data, std::exchange(first, false));
                                 return step.step(j.data, j.x, j.u, dt, j.out, wear);
                               });
  return ok && a.allFinite() && b.allFinite() && wear_gradient.allFinite();
}

bool VehiclePredictionModel::twist_step_jacobians(const Eigen::Ref<const Eigen::VectorXd>& x,
                                                  const Eigen::Vector3d& twist_body, double dt,
                                                  Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                                                  Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                                                  Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
  return twist_step_jacobians(nullptr, x, twist_body, dt, x_next, a, b, stage_wear, wear_gradient);
}

bool VehiclePredictionModel::twist_step_jacobians(PredictionData* data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                                  const Eigen::Vector3d& twist_body, double dt,
                                                  Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                                                  Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                                                  Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
  if (!jacobian_sizes_ok(state_size_, 3, x, twist_body, dt, x_next, a, b, wear_gradient)) return false;
  const SemiImplicitStep<ModelJet>& step = jets_->step;
  detail::JetScratch& j = *scratch(data).jets;
  bool first = true;
  const bool ok = jet_jacobian(x, twist_body, j.x, j.twist, j.out, x_next, a, b, stage_wear, wear_gradient.data(),
                               [&](ModelJet* wear) {
                                 SemiImplicitStep<ModelJet>::begin_chunk(j.data, std::exchange(first, false));
                                 const Eigen::Matrix<ModelJet, 3, 1> twist = j.twist;
                                 step.module_inputs(j.x, twist, dt, j.u);
                                 return step.step(j.data, j.x, j.u, dt, j.out, wear);
                               });
  return ok && a.allFinite() && b.allFinite() && wear_gradient.allFinite();
}

}  // namespace swerve
