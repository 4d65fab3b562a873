// Sizing the wear-aware controller for an embedded target: for each candidate horizon, run the
// controller in closed loop on the simulated plant with the target's budget translated to this
// machine (budget / cpu_slowdown) and count how many optimiser proposals fit in a solve. SA always
// spends its whole budget, so solve time alone says nothing; proposals per solve say how much
// search the target's budget buys at that horizon.
#pragma once

#include <string>
#include <vector>

#include "swerve/app/controller_config.hpp"
#include "swerve/app/target_config.hpp"
#include "swerve/models/vehicle_params.hpp"
#include "swerve/ocp/deadline.hpp"

namespace swerve {

struct TuningOptions {
  std::vector<int> horizons{5, 10, 20, 30, 40};
  int cycles = 20;          // closed-loop periods measured per horizon
  int min_proposals = 50;   // median optimiser proposals per solve a horizon needs to qualify
  const Clock* clock = nullptr;  // the controllers' clock (nullptr: the steady clock; tests inject one)
  void validate() const;    // ConfigError naming the field and value
};

struct HorizonMeasurement {
  int horizon = 0;
  double lookahead_s = 0.0;            // horizon x control period
  double budget_here_ms = 0.0;         // target budget / cpu_slowdown
  double proposals_median = 0.0;       // per solve
  double solve_p99_ms = 0.0;           // on this machine
  double target_p99_ms = 0.0;          // solve_p99_ms x cpu_slowdown
  int fallbacks = 0;
  bool qualifies = false;              // enough proposals and no fallback (a late solve is one)
};

struct TuningResult {
  std::vector<HorizonMeasurement> rows;
  int recommended_horizon = 0;  // the largest qualifying horizon; 0 when none qualifies
};

// `controller` must be a wear_mpc config; its dt and solve budget are replaced by the target's.
// The closed loop follows a straight line at half the drive speed limit, starting on it at that speed.
TuningResult tune_horizon(const VehicleParams& vehicle, const ControllerConfig& controller, const TargetConfig& target,
                          const TuningOptions& options);

}  // namespace swerve
