// Rolls a delayed measurement forward to the time it is acted on (a Smith predictor on the
// kinematic model): the steering angles advance by the steering rates commanded since the
// measurement was taken, the pose by the body twist those commands make (forward kinematics).
// Both controllers use it, so a measurement latency the timestamp reveals never meets a deadbeat
// steering law that reacts to its own delayed effect (issue 14, item 7).
#pragma once

#include <Eigen/Core>

#include "swerve/kinematics/kinematics.hpp"
#include "swerve/mpc/tracking_controller.hpp"

namespace swerve {

class LatencyCompensator {
 public:
  // Longest latency rolled forward, in control periods; an older measurement is rolled forward by
  // this many (the wear-aware controller rejects one older than its staleness bound first).
  static constexpr int kMaxSteps = 8;

  LatencyCompensator(const ModuleLayout& layout, double dt);

  // Remembers the commands sent this cycle (call once per step, after deciding them).
  void record(const ModuleArray<ModuleCommand>& commands) noexcept;
  // Forgets every recorded command (after a reset or a safe stop whose effect is unknown).
  void reset() noexcept { recorded_ = 0; }

  // Writes into `now` the measured state (pose, twist, steering angles: 6 + n) rolled forward by
  // `latency` seconds, rounded to whole periods and at most kMaxSteps or the commands recorded.
  // With no latency `now` is the measurement, bit for bit. Returns the periods rolled forward.
  int compensate(const Eigen::Ref<const Eigen::VectorXd>& measured, double latency,
                 Eigen::Ref<Eigen::VectorXd> now) noexcept;

 private:
  Kinematics kinematics_;
  double dt_;
  int modules_;
  Eigen::MatrixXd history_;  // 2n x kMaxSteps ring: steering rate, wheel surface speed per module
  int newest_ = -1, recorded_ = 0;
  ModuleStates states_;
};

}  // namespace swerve
