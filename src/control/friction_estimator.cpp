#include "swerve/control/friction_estimator.hpp"

#include <algorithm>
#include <cmath>

#include "swerve/control/actuator_estimator.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

constexpr const char* kOwner = "FrictionEstimator";
// The relative step of the grip at which the sensitivity is taken by a forward difference: the
// twist is smooth in the grip, and 5 % keeps the difference far above the Newton solve's tolerance.
constexpr double kSensitivityStep = 0.05;
// s: the longest substep of the estimator's own prediction. One implicit step per 50 ms period
// read the grip 9-13 % high on a slalom (its twist lags the plant's within the step); 10 ms
// substeps read it within 3 % (tests/control/friction_estimator_test.cpp), at 2 x 5 substeps per
// period, a small share of a solve's hundreds.
constexpr double kMaxSubstep = 0.01;
// Share of a period within which a command's time counts as a measurement's (rounding only).
constexpr double kAlignment = 0.01;

PredictionOptions with_fine_substeps(PredictionOptions prediction, double period) {
  if (std::isfinite(period) && period > 0.0) {
    prediction.substeps = std::max(prediction.substeps, static_cast<int>(std::ceil(period / kMaxSubstep - 1e-9)));
  }
  return prediction;
}

}  // namespace

const OptionFields<FrictionEstimationOptions>& FrictionEstimationOptions::fields() {
  // Direct-list-initialised: with `= {` and a bool field GCC 12 stops with an internal error.
  static const OptionFields<FrictionEstimationOptions> table{
      {"enabled", &FrictionEstimationOptions::enabled},
      {"min_scale", &FrictionEstimationOptions::min_scale, Bound::half_open(0.0, 1.0)},
      {"max_scale", &FrictionEstimationOptions::max_scale, Bound::closed(1.0, 10.0)},
      {"memory", &FrictionEstimationOptions::memory, Bound::positive(), {}, nullptr, "(s)"},
      {"velocity_noise", &FrictionEstimationOptions::velocity_noise, Bound::positive(), {}, nullptr, "(m/s)"},
      {"yaw_rate_noise", &FrictionEstimationOptions::yaw_rate_noise, Bound::positive(), {}, nullptr, "(rad/s)"},
      {"prior_deviation", &FrictionEstimationOptions::prior_deviation, Bound::positive()},
      {"min_speed", &FrictionEstimationOptions::min_speed, Bound::non_negative(), {}, nullptr, "(m/s)"},
  };
  return table;
}

void FrictionEstimationOptions::validate() const { check_fields("FrictionEstimationOptions", *this, fields()); }

FrictionEstimator::FrictionEstimator(const VehicleParams& vehicle, const PredictionOptions& prediction,
                                     double control_period, FrictionEstimationOptions options)
    : options_(options), layout_(vehicle.layout), period_(control_period) {
  options_.validate();
  if (!std::isfinite(control_period) || control_period <= 0.0) {
    throw_invalid_field(kOwner, "control_period", control_period, "must be > 0 (s)");
  }
  forgetting_ = std::exp(-control_period / options_.memory);
  min_information_ = 1.0 / (options_.prior_deviation * options_.prior_deviation);
  model_ = std::make_unique<VehiclePredictionModel>(vehicle, with_fine_substeps(prediction, control_period));
  modules_ = vehicle.layout.size();
  data_ = model_->create_data();
  trial_scales_ = std::make_unique<std::array<double, kMaxModules>>();
  trial_scales_->fill(1.0);
  model_->observe_friction_scales(trial_scales_->data());
  state_ = Eigen::VectorXd::Zero(model_->state_size());
  next_ = next_above_ = state_;
  inputs_ = Eigen::VectorXd::Zero(model_->input_size());
  last_measured_ = Eigen::VectorXd::Zero(StateIndex::prefix_size(modules_));
  reset();
}

FrictionEstimator::~FrictionEstimator() = default;
FrictionEstimator::FrictionEstimator(FrictionEstimator&&) noexcept = default;
FrictionEstimator& FrictionEstimator::operator=(FrictionEstimator&&) noexcept = default;

void FrictionEstimator::reset() noexcept {
  information_ = min_information_;
  have_last_ = chained_ = have_updated_ = false;
  sent_.clear();
}

void FrictionEstimator::set_scale(double scale) {
  if (!std::isfinite(scale) || scale < options_.min_scale || scale > options_.max_scale) {
    throw_invalid_field(kOwner, "scale", scale,
                        "must be within [min_scale, max_scale] = [" + std::to_string(options_.min_scale) + ", " +
                            std::to_string(options_.max_scale) + "]");
  }
  scale_ = scale;
}

void FrictionEstimator::commanded(const ModuleArray<ModuleCommand>& commands, double t) noexcept {
  if (commands.size() != modules_ || !std::isfinite(t)) return;
  SentCommand& sent = sent_.push(t);
  for (int i = 0; i < modules_; ++i) {
    sent.inputs[static_cast<std::size_t>(InputIndex::steering_rate(i))] = commands[i].steering_rate;
    sent.inputs[static_cast<std::size_t>(InputIndex::wheel_speed(i))] = commands[i].wheel_speed;
  }
}

void FrictionEstimator::start_chain(const Eigen::Ref<const Eigen::VectorXd>& measured) noexcept {
  const int first = StateIndex::prefix_size(modules_);
  for (int i = 0; i < model_->wheel_speed_states(); ++i) {
    state_[first + i] = rolling_wheel_speed(layout_, measured, i);
  }
  state_.tail(model_->steering_rate_states()).setZero();
}

bool FrictionEstimator::predict(double scale, Eigen::VectorXd* next) noexcept {
  std::fill(trial_scales_->begin(), trial_scales_->begin() + modules_, scale);
  return model_->step(*data_, state_, inputs_, period_, *next, nullptr) && next->allFinite();
}

void FrictionEstimator::update(const Eigen::Vector3d& residual, const Eigen::Vector3d& sensitivity,
                               double measured_at) noexcept {
  // Recursive least squares on one parameter with exponential forgetting and a floor under the
  // information (a bounded covariance, so an unexcited stretch cannot wind the gain up): with the
  // residuals weighted by their noise, I_k = max(lambda I_k-1, I_min) + j'j and
  // scale += j'r / I_k, one Gauss-Newton step per period on the nonlinear model.
  const Eigen::Vector3d sigma(options_.velocity_noise, options_.velocity_noise, options_.yaw_rate_noise);
  const Eigen::Vector3d weighted_residual = residual.cwiseQuotient(sigma);
  const Eigen::Vector3d weighted_sensitivity = sensitivity.cwiseQuotient(sigma);
  // Forgotten by the time since the last update, not per update: evidence a stretch of skipped
  // periods (slow, unaligned) left behind is as old as the stretch.
  const double periods = have_updated_ ? std::max(1.0, (measured_at - last_update_at_) / period_) : 1.0;
  information_ = std::max(std::pow(forgetting_, periods) * information_, min_information_) +
                 weighted_sensitivity.squaredNorm();
  have_updated_ = true;
  last_update_at_ = measured_at;
  const double step = weighted_sensitivity.dot(weighted_residual) / information_;
  scale_ = std::clamp(scale_ + step, options_.min_scale, options_.max_scale);
}

bool FrictionEstimator::observe(const Eigen::Ref<const Eigen::VectorXd>& measured, double measured_at) noexcept {
  const int prefix = StateIndex::prefix_size(modules_);
  if (measured.size() != prefix || !measured.allFinite() || !std::isfinite(measured_at)) return false;
  bool updated = false;
  const bool one_period_on = have_last_ && std::abs(measured_at - last_measured_at_ - period_) < 0.25 * period_;
  // The command sent with the last measurement: sent at the period's start, but for rounding. One
  // sent mid-period (a delay that is not a whole number of periods) ran only over part of it, and
  // the rest would be blamed on the grip.
  const int command = one_period_on ? sent_.find(last_measured_at_, kAlignment * period_) : -1;
  if (command >= 0) {
    state_.head(prefix) = last_measured_;
    if (!chained_) start_chain(last_measured_);
    const SentCommand& sent = sent_.back(command);
    for (int k = 0; k < inputs_.size(); ++k) inputs_[k] = sent.inputs[static_cast<std::size_t>(k)];
    const double above = scale_ * (1.0 + kSensitivityStep);
    if (predict(scale_, &next_) && predict(above, &next_above_)) {
      // The first period of a chain started from guessed actuator states: it only sets them.
      const double speed = last_measured_.segment<2>(StateIndex::kVx).norm();
      if (chained_ && speed >= options_.min_speed) {
        const Eigen::Vector3d twist = next_.segment<3>(StateIndex::kVx);
        update(measured.segment<3>(StateIndex::kVx) - twist,
               (next_above_.segment<3>(StateIndex::kVx) - twist) / (above - scale_), measured_at);
        updated = true;
      }
      state_.tail(state_.size() - prefix) = next_.tail(next_.size() - prefix);
      chained_ = true;
    } else {
      chained_ = false;
    }
  } else {
    chained_ = false;
  }
  last_measured_ = measured;
  last_measured_at_ = measured_at;
  have_last_ = true;
  return updated;
}

}  // namespace swerve
