#include "swerve/ocp/twist_prediction_model.hpp"

namespace swerve {

TwistPredictionModel::TwistPredictionModel(const VehicleParams& params, PredictionOptions options)
    : modules_(params, options) {}

bool TwistPredictionModel::step(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                const Eigen::Ref<const Eigen::VectorXd>& twist_body, double dt,
                                Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept {
  if (twist_body.size() != 3) return false;
  return modules_.twist_step(data, x, twist_body.head<3>(), dt, x_next, stage_wear);
}

bool TwistPredictionModel::step_jacobians(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                          const Eigen::Ref<const Eigen::VectorXd>& twist_body, double dt,
                                          Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                                          Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                                          Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
  if (twist_body.size() != 3) return false;
  return modules_.twist_step_jacobians(data, x, twist_body.head<3>(), dt, x_next, a, b, stage_wear, wear_gradient);
}

}  // namespace swerve
