// The tracking-first tube of the wear-aware controller (TrackingTolerance): per stage, the position
// and heading error within which the optimiser may trade tracking for wear. Each stage's bound is
// the tolerance, widened to the kinematic baseline's own predicted error where that is larger (a
// tube the baseline itself cannot keep would only force the optimiser out of it). A plan that
// leaves the tube by more than a quarter of the tolerance is not sent. Allocation-free after
// construction.
#pragma once

#include <Eigen/Core>

#include "swerve/core/option_fields.hpp"
#include "swerve/ocp/ocp_problem.hpp"

namespace swerve {

struct TrackingTolerance {
  double position = 0.0;  // m
  double heading = 0.0;   // rad
  double penalty = 1e5;   // per m^2 and rad^2 of excess
  bool enabled() const noexcept { return position > 0.0 || heading > 0.0; }
  static const OptionFields<TrackingTolerance>& fields();  // the rules, read by the YAML loader too
  void validate() const;  // throws ConfigError naming the field and value
};

class TrackingTube {
 public:
  // Buffers for the baseline's rollout over problems shaped as `shape`.
  TrackingTube(const TrackingTolerance& tolerance, const OcpProblem& shape);

  // Sets every stage's tube on `problem`: the tolerance, widened to where `baseline_plan` (the
  // baseline's plan in the problem's inputs, nu x N; nullptr when the baseline could not plan),
  // rolled out on `data`, is predicted further off.
  void set(OcpProblem& problem, PredictionData& data, const Eigen::MatrixXd* baseline_plan) noexcept;

  // Whether a rolled-out plan (states nx x N+1) leaves `problem`'s tube by more than a quarter of
  // the tolerance. The penalty is exterior, so a kept tube is kept to within the small excess its
  // stiffness allows; beyond that slack the plan gave up tracking.
  bool left(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& states) const noexcept;

 private:
  TrackingTolerance tolerance_;
  Eigen::MatrixXd states_;       // nx x N+1: the baseline plan rolled out
  Eigen::VectorXd stage_costs_;  // N
};

}  // namespace swerve
