#include "swerve/ocp/ocp_problem.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>

#include "swerve/core/config_error.hpp"
#include "swerve/kinematics/module_state.hpp"  // wrap_angle

namespace swerve {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The owner every rule of this file names (throw_invalid_field: "<owner>.<field> = <value>: <rule>").
constexpr const char* kOwner = "OcpProblem";

void require_non_negative(const std::string& field, double value) {
  if (!std::isfinite(value) || value < 0.0) throw_invalid_field(kOwner, field, value, "must be finite and >= 0");
}

// The pseudo-Huber factor of an error of size |e| = error_norm and width `width` (> 0; 0 or +inf:
// quadratic, factor 1): with u = sqrt(1 + (|e|/width)^2), the residual r = w e s,
// s = sqrt(2 / (1 + u)), costs 1/2 r^2 = w^2 width^2 (u - 1) (w^2 = 2 Q: Q e^2 near e = 0, slope
// 2 Q width far out). Its derivative is
// d s / d e = slope * e, slope = -s / (2 width^2 u (1 + u)): smooth through e = 0.
struct HuberFactor {
  double scale = 1.0, slope = 0.0;
};

HuberFactor huber_factor(double error_norm, double width) noexcept {
  HuberFactor f;
  if (!(width > 0.0) || !std::isfinite(width)) return f;
  const double ratio = error_norm / width;
  const double u = std::sqrt(1.0 + ratio * ratio);
  f.scale = std::sqrt(2.0 / (1.0 + u));
  f.slope = -f.scale / (2.0 * width * width * u * (1.0 + u));
  return f;
}

// An empty vector means "this default for every input"; otherwise it must have one entry per input.
Eigen::VectorXd expand(const Eigen::VectorXd& given, int size, double fallback, const std::string& field) {
  if (given.size() == 0) return Eigen::VectorXd::Constant(size, fallback);
  if (given.size() != size) throw_invalid_field(kOwner, field + ".size()", given.size(), "must equal the input size " + std::to_string(size));
  return given;
}

}  // namespace

const OptionFields<CostWeights>& CostWeights::fields() {
  static const OptionFields<CostWeights> table{
      {"pose", &CostWeights::pose, Bound::non_negative()},
      {"twist", &CostWeights::twist, Bound::non_negative()},
      {"terminal_scale", &CostWeights::terminal_scale, Bound::non_negative()},
      {"wear", &CostWeights::wear, Bound::non_negative()},
      {"tube_penalty", &CostWeights::tube_penalty, Bound::non_negative()},
      {"pose_huber_width", &CostWeights::pose_huber_width, Bound::non_negative()},
  };
  return table;
}

OcpProblem::OcpProblem(const PredictionModel& model, int horizon, double dt, CostWeights weights, InputBounds bounds)
    : model_(&model), horizon_(horizon), nx_(model.state_size()), nu_(model.input_size()), dt_(dt),
      weights_(std::move(weights)), bounds_(std::move(bounds)) {
  if (horizon_ < 1 || horizon_ > kMaxHorizon) {
    throw_invalid_field(kOwner, "horizon", horizon_, "must be in [1, " + std::to_string(kMaxHorizon) + "]");
  }
  if (!std::isfinite(dt_) || dt_ <= 0.0) throw_invalid_field(kOwner, "dt", dt_, "must be finite and > 0");
  if (nx_ < 6) throw_invalid_field(kOwner, "state_size", nx_, "must be >= 6 (pose and body twist first)");
  if (nu_ < 1) throw_invalid_field(kOwner, "input_size", nu_, "must be >= 1");
  if (nu_ % model.input_group_size() != 0) throw_invalid_field(kOwner, "input_group_size", model.input_group_size(), "must divide the input size");
  check_fields("OcpProblem.weights", weights_, CostWeights::fields());
  weights_.effort = expand(weights_.effort, nu_, 0.0, "weights.effort");
  weights_.rate = expand(weights_.rate, nu_, 0.0, "weights.rate");
  for (int i = 0; i < nu_; ++i) {
    require_non_negative("weights.effort[" + std::to_string(i) + "]", weights_.effort[i]);
    require_non_negative("weights.rate[" + std::to_string(i) + "]", weights_.rate[i]);
  }
  if (weights_.state_effort.size() != 0 && weights_.state_effort.size() != nx_) {
    throw_invalid_field(kOwner, "weights.state_effort.size()", weights_.state_effort.size(), "must equal the state size " + std::to_string(nx_));
  }
  int weighted_states = 0;
  for (Eigen::Index j = 0; j < weights_.state_effort.size(); ++j) {
    require_non_negative("weights.state_effort[" + std::to_string(j) + "]", weights_.state_effort[j]);
    if (weights_.state_effort[j] > 0.0) ++weighted_states;
  }
  state_effort_index_ = Eigen::VectorXi::Zero(weighted_states);
  state_effort_root_ = Eigen::VectorXd::Zero(weighted_states);
  for (Eigen::Index j = 0, m = 0; j < weights_.state_effort.size(); ++j) {
    if (!(weights_.state_effort[j] > 0.0)) continue;
    state_effort_index_[m] = static_cast<int>(j);
    state_effort_root_[m++] = std::sqrt(2.0 * weights_.state_effort[j]);
  }
  bounds_.lower = expand(bounds_.lower, nu_, -kInfinity, "bounds.lower");
  bounds_.upper = expand(bounds_.upper, nu_, kInfinity, "bounds.upper");
  bounds_.max_step = expand(bounds_.max_step, nu_, kInfinity, "bounds.max_step");
  for (int i = 0; i < nu_; ++i) {
    const std::string index = "[" + std::to_string(i) + "]";
    if (std::isnan(bounds_.lower[i]) || std::isnan(bounds_.upper[i]) || bounds_.lower[i] > bounds_.upper[i]) {
      throw_invalid_field(kOwner, "bounds.lower" + index, bounds_.lower[i], "must be <= bounds.upper" + index + " (" +
                                                            std::to_string(bounds_.upper[i]) + ")");
    }
    if (std::isnan(bounds_.max_step[i]) || bounds_.max_step[i] <= 0.0) {
      throw_invalid_field(kOwner, "bounds.max_step" + index, bounds_.max_step[i], "must be > 0");
    }
  }
  pose_root_ = (2.0 * weights_.pose).cwiseSqrt();
  terminal_pose_root_ = (2.0 * weights_.terminal_scale * weights_.pose).cwiseSqrt();
  twist_root_ = (2.0 * weights_.twist).cwiseSqrt();
  position_huber_width_ = weights_.pose_huber_width;
  const double position_weight = 0.5 * (weights_.pose.x() + weights_.pose.y());
  if (weights_.pose_huber_width > 0.0 && weights_.pose.z() > 0.0) {
    // Without a position weight there is nothing to compare the heading with: it stays quadratic.
    heading_huber_width_ = weights_.pose_huber_width * std::sqrt(position_weight / weights_.pose.z());
  }
  tube_root_ = std::sqrt(2.0 * weights_.tube_penalty);
  effort_root_ = (2.0 * weights_.effort).cwiseSqrt();
  rate_root_ = (2.0 * weights_.rate).cwiseSqrt();
  x0_ = Eigen::VectorXd::Zero(nx_);
  u_previous_ = Eigen::VectorXd::Zero(nu_).cwiseMax(bounds_.lower).cwiseMin(bounds_.upper);
  reference_pose_ = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, horizon_);
  reference_twist_ = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, horizon_);
  tube_ = Eigen::Matrix<double, 2, Eigen::Dynamic>::Constant(2, horizon_, kInfinity);
}

bool OcpProblem::set_tube(int k, double position_bound, double heading_bound) noexcept {
  if (k < 1 || k > horizon_ || !(position_bound > 0.0) || !(heading_bound > 0.0)) return false;
  tube_(0, k - 1) = position_bound;
  tube_(1, k - 1) = heading_bound;
  return true;
}

void OcpProblem::clear_tube() noexcept { tube_.setConstant(kInfinity); }

Eigen::Vector2d OcpProblem::tube_excess(const Eigen::Ref<const Eigen::MatrixXd>& states) const noexcept {
  Eigen::Vector2d worst = Eigen::Vector2d::Zero();
  if (states.rows() != nx_ || states.cols() != horizon_ + 1) return Eigen::Vector2d::Constant(kInfinity);
  for (int k = 1; k <= horizon_; ++k) {
    const Eigen::Vector2d error = tracking_error(k, states.col(k));
    worst = worst.cwiseMax(error - tube_.col(k - 1));
  }
  return worst;
}

Eigen::Vector2d OcpProblem::tracking_error(int k, const Eigen::Ref<const Eigen::VectorXd>& x) const noexcept {
  const auto column = static_cast<Eigen::Index>(k - 1);
  return {(x.head<2>() - reference_pose_.col(column).head<2>()).norm(),
          std::abs(wrap_angle(x[2] - reference_pose_(2, column)))};
}

bool OcpProblem::set_initial_state(const Eigen::Ref<const Eigen::VectorXd>& x0) noexcept {
  if (x0.size() != nx_ || !x0.allFinite()) return false;
  x0_ = x0;
  return true;
}

bool OcpProblem::set_previous_input(const Eigen::Ref<const Eigen::VectorXd>& u_previous) noexcept {
  if (u_previous.size() != nu_ || !u_previous.allFinite()) return false;
  u_previous_ = u_previous;
  return true;
}

bool OcpProblem::set_reference(int k, const Eigen::Vector3d& pose_world, const Eigen::Vector3d& twist_body) noexcept {
  if (k < 1 || k > horizon_ || !pose_world.allFinite() || !twist_body.allFinite()) return false;
  reference_pose_.col(k - 1) = pose_world;
  reference_twist_.col(k - 1) = twist_body;
  return true;
}

bool OcpProblem::set_wear_weight(double lambda) noexcept {
  if (!std::isfinite(lambda) || lambda < 0.0) return false;
  weights_.wear = lambda;
  return true;
}

int OcpProblem::project(Eigen::Ref<Eigen::MatrixXd> inputs) const noexcept {
  int first_changed = horizon_;
  for (int k = 0; k < horizon_; ++k) {
    for (int i = 0; i < nu_; ++i) {
      const double before = k == 0 ? u_previous_[i] : inputs(i, k - 1);
      const double lower = std::max(bounds_.lower[i], before - bounds_.max_step[i]);
      const double upper = std::min(bounds_.upper[i], before + bounds_.max_step[i]);
      double value = inputs(i, k);
      if (!std::isfinite(value)) value = before;
      // When the previous input lies outside the box (a bound changed), the box wins.
      const double projected = lower <= upper ? std::min(std::max(value, lower), upper)
                                              : std::min(std::max(value, bounds_.lower[i]), bounds_.upper[i]);
      if (projected != inputs(i, k)) {
        inputs(i, k) = projected;
        if (k < first_changed) first_changed = k;
      }
    }
  }
  return first_changed;
}

bool OcpProblem::is_feasible(const Eigen::Ref<const Eigen::MatrixXd>& inputs, double tolerance) const noexcept {
  if (inputs.rows() != nu_ || inputs.cols() != horizon_ || !inputs.allFinite()) return false;
  for (int k = 0; k < horizon_; ++k) {
    for (int i = 0; i < nu_; ++i) {
      const double before = k == 0 ? u_previous_[i] : inputs(i, k - 1);
      const double value = inputs(i, k);
      if (value < bounds_.lower[i] - tolerance || value > bounds_.upper[i] + tolerance) return false;
      if (std::abs(value - before) > bounds_.max_step[i] + tolerance) return false;
    }
  }
  return true;
}

Eigen::Ref<const Eigen::VectorXd> OcpProblem::input_before(const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                                                           int k) const noexcept {
  if (k == 0) return Eigen::Ref<const Eigen::VectorXd>(u_previous_);
  return Eigen::Ref<const Eigen::VectorXd>(inputs.col(static_cast<Eigen::Index>(k) - 1));
}

void OcpProblem::tracking_residuals(int k, const Eigen::Ref<const Eigen::VectorXd>& x_next,
                                    TrackingResiduals* residuals, TrackingJacobian* jacobian) const noexcept {
  const auto kk = static_cast<Eigen::Index>(k);
  Eigen::Vector3d pose_error = x_next.head<3>() - reference_pose_.col(kk);
  pose_error.z() = wrap_angle(pose_error.z());
  const Eigen::Vector3d& pose_root = k == horizon_ - 1 ? terminal_pose_root_ : pose_root_;
  const double position_error = pose_error.head<2>().norm();
  const double position_excess = std::max(0.0, position_error - tube_(0, kk));
  const double heading_excess = std::max(0.0, std::abs(pose_error.z()) - tube_(1, kk));
  const HuberFactor position_factor = huber_factor(position_error, position_huber_width_);
  const HuberFactor heading_factor = huber_factor(std::abs(pose_error.z()), heading_huber_width_);
  const Eigen::Vector3d huber_scale(position_factor.scale, position_factor.scale, heading_factor.scale);
  TrackingResiduals& r = *residuals;
  r.segment<3>(kPoseResidual) = pose_root.cwiseProduct(pose_error).cwiseProduct(huber_scale);
  r.segment<3>(kTwistResidual) = twist_root_.cwiseProduct(x_next.segment<3>(3) - reference_twist_.col(kk));
  r[kTubeResidual] = tube_root_ * position_excess;
  r[kTubeResidual + 1] = tube_root_ * heading_excess;
  if (jacobian == nullptr) return;
  // The wrapped heading error's derivative is 1; the tube's, d |e| / d e = e / |e| beyond the bound
  // (where |e| > b > 0) and 0 inside.
  TrackingJacobian& j = *jacobian;
  j.setZero();
  // d (w e s) / d e = w s + w e (d s / d e)^T, with d s / d e = slope e.
  j.block<3, 3>(kPoseResidual, 0) = pose_root.cwiseProduct(huber_scale).asDiagonal();
  const Eigen::Vector2d weighted_position = pose_root.head<2>().cwiseProduct(pose_error.head<2>());
  j.block<2, 2>(kPoseResidual, 0).noalias() +=
      position_factor.slope * weighted_position * pose_error.head<2>().transpose();
  j(kPoseResidual + 2, 2) += heading_factor.slope * pose_root.z() * pose_error.z() * pose_error.z();
  j.block<3, 3>(kTwistResidual, 3) = twist_root_.asDiagonal();
  if (position_excess > 0.0) j.block<1, 2>(kTubeResidual, 0) = (tube_root_ / position_error) * pose_error.head<2>();
  if (heading_excess > 0.0) j(kTubeResidual + 1, 2) = pose_error.z() > 0.0 ? tube_root_ : -tube_root_;
}

double OcpProblem::stage_cost(int k, const Eigen::Ref<const Eigen::VectorXd>& x_next,
                              const Eigen::Ref<const Eigen::VectorXd>& u,
                              const Eigen::Ref<const Eigen::VectorXd>& u_before, double wear,
                              CostBreakdown* parts) const noexcept {
  TrackingResiduals r;
  tracking_residuals(k, x_next, &r);
  const double tracking = 0.5 * r.squaredNorm();
  const double wear_cost = weights_.wear * wear;
  const double effort = 0.5 * effort_root_.cwiseProduct(u).squaredNorm() + state_effort(x_next);
  const double rate = 0.5 * rate_root_.cwiseProduct(u - u_before).squaredNorm();
  if (parts != nullptr) {
    parts->tracking += tracking;
    parts->wear += wear_cost;
    parts->effort += effort;
    parts->rate += rate;
  }
  return tracking + wear_cost + effort + rate;
}

double OcpProblem::stage_cost_without_wear(int k, const Eigen::Ref<const Eigen::VectorXd>& x_next,
                                           const Eigen::Ref<const Eigen::VectorXd>& u,
                                           const Eigen::Ref<const Eigen::VectorXd>& u_before,
                                           Eigen::Ref<Eigen::VectorXd> d_x_next, Eigen::Ref<Eigen::VectorXd> d_u,
                                           Eigen::Ref<Eigen::VectorXd> d_u_before) const noexcept {
  // The gradient of 1/2 |r|^2 is J^T r, term by term.
  TrackingResiduals r;
  TrackingJacobian jacobian;
  tracking_residuals(k, x_next, &r, &jacobian);
  d_x_next.setZero();
  d_x_next.head<kTrackedStates>().noalias() = jacobian.transpose() * r;
  for (Eigen::Index j = 0; j < state_effort_index_.size(); ++j) {
    const double root = state_effort_root_[j];
    d_x_next[state_effort_index_[j]] += root * root * x_next[state_effort_index_[j]];
  }
  const auto rate_residual = rate_root_.cwiseProduct(u - u_before);
  d_u = effort_root_.cwiseProduct(effort_root_.cwiseProduct(u)) + rate_root_.cwiseProduct(rate_residual);
  d_u_before = -rate_root_.cwiseProduct(rate_residual);
  return 0.5 * (r.squaredNorm() + effort_root_.cwiseProduct(u).squaredNorm() + rate_residual.squaredNorm()) +
         state_effort(x_next);
}

double OcpProblem::state_effort(const Eigen::Ref<const Eigen::VectorXd>& x_next) const noexcept {
  double sum = 0.0;
  for (Eigen::Index j = 0; j < state_effort_index_.size(); ++j) {
    const double r = state_effort_root_[j] * x_next[state_effort_index_[j]];
    sum += r * r;
  }
  return 0.5 * sum;
}

double OcpProblem::rollout(PredictionData& data, const Eigen::Ref<const Eigen::MatrixXd>& inputs, int first_step,
                           Eigen::Ref<Eigen::MatrixXd> states, Eigen::Ref<Eigen::VectorXd> stage_costs,
                           double* stage_wear) const noexcept {
  if (first_step <= 0) {
    first_step = 0;
    states.col(0) = x0_;
  }
  for (int k = first_step; k < horizon_; ++k) {
    double wear = 0.0;
    const auto kk = static_cast<Eigen::Index>(k);
    if (!model_->step(data, states.col(kk), inputs.col(kk), dt_, states.col(kk + 1), &wear) || !std::isfinite(wear)) {
      for (int j = k; j < horizon_; ++j) stage_costs[j] = std::numeric_limits<double>::infinity();
      return std::numeric_limits<double>::infinity();
    }
    if (stage_wear != nullptr) stage_wear[k] = wear;
    stage_costs[kk] = stage_cost(k, states.col(kk + 1), inputs.col(kk), input_before(inputs, k), wear, nullptr);
  }
  return stage_costs.sum();
}

CostBreakdown OcpProblem::evaluate(PredictionData& data, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                                   Eigen::Ref<Eigen::MatrixXd> states) const noexcept {
  std::array<double, kMaxHorizon> stage_costs, stage_wear;
  Eigen::Map<Eigen::VectorXd> costs(stage_costs.data(), horizon_);
  if (!std::isfinite(rollout(data, inputs, 0, states, costs, stage_wear.data()))) {
    CostBreakdown failed;
    failed.tracking = std::numeric_limits<double>::infinity();
    return failed;
  }
  return breakdown(inputs, states, Eigen::Map<const Eigen::VectorXd>(stage_wear.data(), horizon_));
}

CostBreakdown OcpProblem::breakdown(const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                                    const Eigen::Ref<const Eigen::MatrixXd>& states,
                                    const Eigen::Ref<const Eigen::VectorXd>& stage_wear) const noexcept {
  CostBreakdown parts;
  if (inputs.rows() != nu_ || inputs.cols() != horizon_ || states.rows() != nx_ || states.cols() != horizon_ + 1 ||
      stage_wear.size() != horizon_) {
    parts.tracking = std::numeric_limits<double>::infinity();
    return parts;
  }
  for (int k = 0; k < horizon_; ++k) {
    const auto kk = static_cast<Eigen::Index>(k);
    stage_cost(k, states.col(kk + 1), inputs.col(kk), input_before(inputs, k), stage_wear[kk], &parts);
  }
  return parts;
}

}  // namespace swerve
