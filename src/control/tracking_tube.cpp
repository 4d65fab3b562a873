#include "swerve/control/tracking_tube.hpp"

#include <cmath>

namespace swerve {

const OptionFields<TrackingTolerance>& TrackingTolerance::fields() {
  static const OptionFields<TrackingTolerance> table{
      {"position", &TrackingTolerance::position, Bound::positive(), {}, nullptr, "(m)"},
      {"heading", &TrackingTolerance::heading, Bound::positive(), {}, nullptr, "(rad)"},
      {"penalty", &TrackingTolerance::penalty, Bound::positive()},
  };
  return table;
}

void TrackingTolerance::validate() const {
  if (enabled()) check_fields("TrackingTolerance", *this, fields());
}

TrackingTube::TrackingTube(const TrackingTolerance& tolerance, const OcpProblem& shape)
    : tolerance_(tolerance),
      states_(Eigen::MatrixXd::Zero(shape.state_size(), shape.horizon() + 1)),
      stage_costs_(Eigen::VectorXd::Zero(shape.horizon())) {}

void TrackingTube::set(OcpProblem& problem, PredictionData& data, const Eigen::MatrixXd* baseline_plan) noexcept {
  const bool rolled_out =
      baseline_plan != nullptr && std::isfinite(problem.rollout(data, *baseline_plan, 0, states_, stage_costs_));
  for (int k = 1; k <= problem.horizon(); ++k) {
    Eigen::Vector2d bound(tolerance_.position, tolerance_.heading);
    if (rolled_out) bound = bound.cwiseMax(problem.tracking_error(k, states_.col(k)));
    problem.set_tube(k, bound[0], bound[1]);
  }
}

bool TrackingTube::left(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& states) const noexcept {
  const Eigen::Vector2d excess = problem.tube_excess(states);
  return excess[0] > 0.25 * tolerance_.position || excess[1] > 0.25 * tolerance_.heading;
}

}  // namespace swerve
