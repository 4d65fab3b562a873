// The clock a controller follows its reference on while it may hold it: a controller that waits
// (pre-alignment at rest: the wheels wait for the steering) holds the reference, and from then on
// tracks it behind t by the time held, in all. Shared by the kinematic baseline and the wear-aware
// controller, so both report the same delay (ControlOutput::reference_delay_s).
#pragma once

namespace swerve {

class ReferenceHold {
 public:
  // The reference's time for a step at t: t less the time held so far. The time since the last
  // step counts as held when that step held the reference. noexcept, no allocation.
  double reference_time(double t) noexcept {
    if (held_ && t > last_t_) delay_s_ += t - last_t_;
    last_t_ = t;
    return t - delay_s_;
  }
  // The same for a step at t still to come, changing nothing (a preparation's look ahead).
  double reference_time_ahead(double t) const noexcept {
    return t - delay_s_ - (held_ && t > last_t_ ? t - last_t_ : 0.0);
  }
  // Whether this step holds the reference (the time to the next step then does not count on it).
  void set_held(bool held) noexcept { held_ = held; }
  bool held() const noexcept { return held_; }
  double delay_s() const noexcept { return delay_s_; }  // s: the time held, in all
  void reset() noexcept { *this = ReferenceHold(); }

 private:
  bool held_ = false;     // the last step held it
  double last_t_ = 0.0;   // s: the last step's t
  double delay_s_ = 0.0;  // s
};

}  // namespace swerve
