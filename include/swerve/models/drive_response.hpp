// A drive's wheel speed over one step: the plant's first-order lag towards the command with its
// acceleration clamp (VehicleModel with actuator lag and saturation: omega_dot = clamp((c - omega)
// / tau, +-alpha)), solved in closed form. The MPC's prediction (PredictionOptions::drive_lag) and
// the controller's estimate of the wheel speeds its commands have reached use it;
// tests/models/drive_response_test.cpp holds it to the vehicle model's own law.
#pragma once

#include <cmath>
#include <limits>

#include "swerve/core/scalar.hpp"

namespace swerve {

struct DriveLag {
  double time_constant = 0.0;                                         // tau, s (> 0)
  double max_acceleration = std::numeric_limits<double>::infinity();  // alpha, rad/s^2 (> 0); inf: no clamp
};

// A lag over one step of h, with its decay exp(-h / tau) computed once: the prediction steps every
// module's drive and steering over the same h, and the exponential was most of a response's cost.
struct DriveLagStep {
  DriveLagStep(const DriveLag& lag_in, double h_in) noexcept
      : lag(lag_in), h(h_in), decay(std::exp(-h_in / lag_in.time_constant)) {}
  DriveLag lag;
  double h;
  double decay;
};

// From `start`, commanded `command` over `step.h`: the wheel speed at the end (*end) and its mean
// over the step (*mean). With the error e = command - omega: while |e| > alpha tau the clamp holds
// and |e| falls linearly at alpha; below it, e decays as e^-t/tau. Branches are chosen on values,
// so a Jet differentiates the piece the double evaluation takes.
template <typename T>
void drive_response(const T& start, const T& command, const DriveLagStep& step, T* end, T* mean) noexcept {
  using std::exp;
  const double tau = step.lag.time_constant;
  const double alpha = step.lag.max_acceleration;
  const double h = step.h;
  const T error = command - start;
  const double size = std::abs(scalar_value(error));
  const double sign = scalar_value(error) < 0.0 ? -1.0 : 1.0;
  T end_error, mean_error;
  if (size <= alpha * tau) {  // unclamped throughout
    end_error = error * step.decay;
    mean_error = error * (tau / h * (1.0 - step.decay));
  } else {
    const T magnitude = sign * error;                        // |e0|, differentiable
    const T clamped_time = (magnitude - alpha * tau) / alpha;  // until |e| = alpha tau
    if (scalar_value(clamped_time) >= h) {                   // clamped throughout
      end_error = sign * (magnitude - alpha * h);
      mean_error = sign * (magnitude - 0.5 * alpha * h);
    } else {
      const T rest = h - clamped_time;
      const T decay = exp(-rest / tau);
      end_error = sign * alpha * tau * decay;
      const T area = magnitude * clamped_time - 0.5 * alpha * clamped_time * clamped_time +
                     alpha * tau * tau * (1.0 - decay);
      mean_error = sign * area / h;
    }
  }
  *end = command - end_error;
  *mean = command - mean_error;
}

// The same for one drive over h.
template <typename T>
void drive_response(const T& start, const T& command, const DriveLag& lag, double h, T* end, T* mean) noexcept {
  drive_response<T>(start, command, DriveLagStep(lag, h), end, mean);
}

}  // namespace swerve
