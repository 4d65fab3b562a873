// Estimates the floor's grip under the vehicle online, as a scale on the tire's peak friction mu.
// Each control period it runs the prediction model from the last measurement under the commands
// sent, at the estimate and a little above it; the measured body twist at the period's end against
// the two gives the residual and its sensitivity to the grip, and recursive least squares with
// exponential forgetting moves the estimate. Fixed capacity: no allocation after construction.
#pragma once

#include <Eigen/Core>

#include <array>
#include <memory>

#include "swerve/core/option_fields.hpp"
#include "swerve/core/stamped_history.hpp"
#include "swerve/kinematics/module_faults.hpp"
#include "swerve/kinematics/module_state.hpp"
#include "swerve/models/vehicle_params.hpp"
#include "swerve/ocp/vehicle_prediction_model.hpp"

namespace swerve {

struct FrictionEstimationOptions {
  bool enabled = false;
  // Bounds of the estimate, as multiples of the vehicle's tire mu.
  double min_scale = 0.2;
  double max_scale = 1.5;
  // s: the forgetting time constant. Evidence older than this weighs 1/e as much (counted in time,
  // updates or not), so a change of floor is followed within a few of it.
  double memory = 0.5;
  // The sensor's noise on the measured body velocity (m/s) and yaw rate (rad/s): the residuals'
  // weights. Smaller trusts each period more.
  double velocity_noise = 0.01;
  double yaw_rate_noise = 0.01;
  // The scale's standard deviation when nothing is known: the information never falls below
  // 1 / prior_deviation^2, so a period of little excitation cannot swing the estimate.
  double prior_deviation = 0.5;
  // m/s: below this body speed the slips are the model's regularisation more than the floor's, and
  // the estimate holds.
  double min_speed = 0.2;
  static const OptionFields<FrictionEstimationOptions>& fields();
  void validate() const;  // throws ConfigError naming the field and value
};

class FrictionEstimator {
 public:
  // The vehicle and the prediction the controller runs (its options); `control_period` > 0 s.
  // Throws ConfigError for invalid options or parameters.
  FrictionEstimator(const VehicleParams& vehicle, const PredictionOptions& prediction, double control_period,
                    FrictionEstimationOptions options);
  ~FrictionEstimator();
  FrictionEstimator(FrictionEstimator&&) noexcept;
  FrictionEstimator& operator=(FrictionEstimator&&) noexcept;

  // The commands sent at `t` (s), acting over the next period.
  void commanded(const ModuleArray<ModuleCommand>& commands, double t) noexcept;
  // A measurement (pose, twist, steering angles: 6 + n) taken at `measured_at` (s). When the last
  // one was a period before it and commands were sent at its time (so one command acted over the
  // whole period: a delay of whole periods), the estimate is updated; returns true when it was.
  // Non-finite input is ignored. noexcept, no allocation.
  bool observe(const Eigen::Ref<const Eigen::VectorXd>& measured, double measured_at) noexcept;

  // The estimate: the floor's peak friction as a multiple of the tire's mu.
  double scale() const noexcept { return scale_; }
  // Its information (1 / variance, in the residuals' weights) after the last update.
  double information() const noexcept { return information_; }
  // A known grip (a map of the floor): the estimate continues from it. Throws ConfigError unless
  // finite and within [min_scale, max_scale].
  void set_scale(double scale);
  // Forget the history (a new run): the estimate stays (the floor did not change), its
  // information falls back to the prior's.
  void reset() noexcept;
  // The modules' faults the prediction takes (SemiImplicitStep::observe_module_faults).
  void observe_module_faults(const ModuleFaults* faults) noexcept { model_->observe_module_faults(faults); }
  const FrictionEstimationOptions& options() const noexcept { return options_; }

 private:
  static constexpr int kHistory = 128;  // commands kept: a measurement up to 127 periods old
  struct SentCommand {
    double t = 0.0;
    std::array<double, 2 * kMaxModules> inputs{};  // steering rate, wheel speed per module
  };
  // The prediction from state_ under inputs_ at grip `scale` into `next`; false when it failed.
  bool predict(double scale, Eigen::VectorXd* next) noexcept;
  // The lagged actuator states of state_ for a chain that starts at `measured`: wheels rolling
  // with the body, steering at rest.
  void start_chain(const Eigen::Ref<const Eigen::VectorXd>& measured) noexcept;
  // One least-squares step on the residual z - h(scale_) with sensitivity dh/dscale (both 3), of
  // the measurement taken at `measured_at`.
  void update(const Eigen::Vector3d& residual, const Eigen::Vector3d& sensitivity, double measured_at) noexcept;

  FrictionEstimationOptions options_;
  ModuleLayout layout_;
  double period_;
  double forgetting_;       // per period: exp(-period / memory)
  double min_information_;  // 1 / prior_deviation^2
  int modules_;
  std::unique_ptr<VehiclePredictionModel> model_;
  std::unique_ptr<PredictionData> data_;
  std::unique_ptr<std::array<double, kMaxModules>> trial_scales_;  // what model_ observes
  Eigen::VectorXd state_, inputs_, next_, next_above_;
  Eigen::VectorXd last_measured_;
  double last_measured_at_ = 0.0;
  bool have_last_ = false;
  bool chained_ = false;  // state_'s actuator states continue a prediction (else: just started)
  bool have_updated_ = false;
  double last_update_at_ = 0.0;  // s: the measurement of the last update
  StampedHistory<SentCommand, kHistory> sent_;
  double scale_ = 1.0;
  double information_ = 0.0;
};

}  // namespace swerve
