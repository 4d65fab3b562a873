// The swerve prediction step for any scalar type: double for the optimiser's rollouts, ceres::Jet
// for their exact Jacobians. Internal to the library; vehicle_prediction_model.hpp says what the
// step does and why. Branches (the 180 deg flip, clamps, the slow-motion substeps) are chosen on
// the values, so the Jet evaluation differentiates the branch the double evaluation takes.
//
// The backward-Euler body twist v+ solves G(v+, p) = v+ - v0 - h a(v+, p) = 0 (p: state and
// inputs). Newton's method finds its value in double; its derivatives follow from the implicit
// function theorem, dv+/dp = -(dG/dv)^-1 dG/dp, with both partials from Jets of the model's
// derivative at the converged v+ (exact, no finite differences and no differentiation of the
// Newton iterations).
#pragma once

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <utility>
#include <vector>

#include "swerve/kinematics/kinematics.hpp"
#include "swerve/kinematics/module_state.hpp"
#include "swerve/kinematics/se2.hpp"
#include "swerve/models/integrators.hpp"
#include "swerve/models/jet.hpp"
#include "swerve/models/vehicle_model.hpp"
#include "swerve/mpc/vehicle_prediction_model.hpp"

namespace swerve::detail {

inline constexpr double kSlowSpeed = 0.25;  // m/s: 5 slip-regularisation speeds of the paper's tire
// Below this contact speed a module's direction is noise: it keeps its angle (the singularity hold).
inline constexpr double kHoldSpeed = 1e-3;  // m/s
// Deepest halving of a semi-implicit substep whose Newton solve finds no root (h / 16).
inline constexpr int kMaxSplits = 4;

// `value` limited to [lower, upper], the bounds chosen on values (a Jet keeps the derivative of
// whichever side is active).
template <typename T>
T clamp_by_value(const T& value, const T& lower, const T& upper) {
  if (scalar_value(value) < scalar_value(lower)) return lower;
  if (scalar_value(value) > scalar_value(upper)) return upper;
  return value;
}

// Smooth saturations for the limits inside the step. A hard clamp has a kink where it becomes
// active, and a gradient method whose iterates cross it sees linearisations that are wrong on one
// side (Ipopt stalled with dynamics defects of 1e-2 at the stages where the steering-rate limit
// switched on or off). min(x, limit) is replaced by a C1 blend over [limit - width, limit + width]:
// x - (x - limit + width)^2 / (4 width) there, exactly x below it and exactly the limit above it,
// so motion away from the limits is unchanged. Every scalar type uses them, so every optimiser
// sees one map.
template <typename T>
T soft_min(const T& x, double limit, double width) {
  const double value = scalar_value(x);
  if (value <= limit - width) return x;
  if (value >= limit + width) return T(limit);
  const T excess = x - (limit - width);
  return x - excess * excess / (4.0 * width);
}
template <typename T>
T soft_max(const T& x, double limit, double width) {
  return -soft_min<T>(-x, -limit, width);
}
template <typename T>
T soft_clamp(const T& x, double lower, double upper, double width) {
  return soft_min<T>(soft_max<T>(x, lower, width), upper, width);
}

// max(0, x) made C1 without moving its zero: 0 below 0, x^2 / (2 width) up to width, x - width / 2
// above. The step's energy balance is clamped by it: steady motion dissipates ~0, so the optimum
// of a plan that cruises sits on this corner at many stages, where a kink stalled SLSQP.
template <typename T>
T positive_part(const T& x) {
  constexpr double kWidth = 1e-4;  // J: the bias above it (5e-5 J per step) is negligible
  const double value = scalar_value(x);
  if (value <= 0.0) return T(0.0);
  if (value >= kWidth) return x - 0.5 * kWidth;
  return x * x / (2.0 * kWidth);
}

// Blend widths, relative to each limit's scale.
inline constexpr double kRateLimitSmoothing = 0.1;    // x max steering rate
inline constexpr double kSpeedLimitSmoothing = 0.05;  // x max wheel speed
inline constexpr double kAlignmentSmoothing = 0.05;   // on cos(remaining steering error), at 0

// Backward-Euler body twist by Newton's method in double (the value every scalar type shares). The
// residual's Jacobian dG/dv = I - h da/dv is exact: each evaluation of the model carries Jets along
// the three twist directions (TwistJet), so one evaluation gives the residual and its Jacobian, and
// the iteration converges quadratically. (A forward-difference Jacobian cost four evaluations an
// iteration, ~19 a step.)
class BodyTwistSolver {
 public:
  BodyTwistSolver(const VehicleParams& params, int max_iterations)
      : model_(params, Fidelity::kIdeal), max_iterations_(max_iterations),
        state_(TwistJetVector::Zero(model_.state_size())), inputs_(TwistJetVector::Zero(model_.input_size())),
        state_dot_(TwistJetVector::Zero(model_.state_size())),
        diagnostics_(static_cast<std::size_t>(model_.modules())), value_model_(params, Fidelity::kIdeal),
        value_state_(Eigen::VectorXd::Zero(model_.state_size())), value_inputs_(Eigen::VectorXd::Zero(model_.input_size())),
        value_state_dot_(Eigen::VectorXd::Zero(model_.state_size())),
        value_diagnostics_(static_cast<std::size_t>(model_.modules())) {}

  // v+ for the state `trial_state` (steering already advanced; its twist entries are ignored) under
  // `inputs`, from v0 over h, started at `guess`. Step halving keeps each iterate's residual below
  // the last. True only when the residual has converged: a tyre past its force peak makes the
  // residual non-monotone, and a long step from rest then has no root near v0 or several (Newton
  // wandered, and an unconverged 6.5 m/s was once returned for a 4 cm/s command); the caller
  // splits the step.
  bool solve(const Eigen::Ref<const Eigen::VectorXd>& trial_state, const Eigen::Ref<const Eigen::VectorXd>& inputs,
             const Eigen::Vector3d& v0, const Eigen::Vector3d& guess, double h, Eigen::Vector3d* v_out) const noexcept {
    for (Eigen::Index k = 0; k < state_.size(); ++k) state_[k] = TwistJet(trial_state[k]);
    for (Eigen::Index k = 0; k < inputs_.size(); ++k) inputs_[k] = TwistJet(inputs[k]);
    Eigen::Vector3d v = guess, a;
    Eigen::Matrix3d da_dv;
    if (!acceleration(v, &a, &da_dv)) return false;
    Eigen::Vector3d residual = v - v0 - h * a;
    double residual_norm = residual.norm();
    double previous_norm = 0.0;  // the residual before the last full Newton step; 0 if there was none
    final_in_double_ = false;
    for (int iteration = 0; iteration < max_iterations_ && residual_norm > kTolerance; ++iteration) {
      const Eigen::Matrix3d jacobian = Eigen::Matrix3d::Identity() - h * da_dv;
      const Eigen::Vector3d newton_step = jacobian.partialPivLu().solve(-residual);
      // Quadratic convergence, |r+| ~ K |r|^2 with K measured over the last full step: when that
      // puts the next residual under the tolerance, the step is taken and the model evaluated
      // there in double only, for the forces and wear rate at v+ (a Jet evaluation costs ~2.2
      // double ones, and its Jacobian would go unused). Extrapolating them along their twist
      // derivatives instead was cheaper still, but left the map rough at 1e-9, and Ipopt's line
      // search then needed 258 iterations where it had needed 165.
      if (previous_norm > 0.0) {
        const double predicted = residual_norm / (previous_norm * previous_norm) * residual_norm * residual_norm;
        if (predicted <= kTolerance) {
          v += newton_step;
          if (!final_values(v)) return false;
          residual_norm = predicted;
          break;
        }
      }
      double scale = 1.0;
      bool decreased = false;
      for (int halving = 0; halving < 6; ++halving, scale *= 0.5) {
        const Eigen::Vector3d trial = v + scale * newton_step;
        Eigen::Vector3d trial_a;
        Eigen::Matrix3d trial_da_dv;
        if (!acceleration(trial, &trial_a, &trial_da_dv)) continue;
        const Eigen::Vector3d trial_residual = trial - v0 - h * trial_a;
        if (trial_residual.norm() < residual_norm) {
          previous_norm = halving == 0 ? residual_norm : 0.0;
          v = trial;
          a = trial_a;
          da_dv = trial_da_dv;
          residual = trial_residual;
          residual_norm = residual.norm();
          decreased = true;
          break;
        }
      }
      if (!decreased) break;
    }
    *v_out = v;
    return v.allFinite() && residual_norm <= kConverged;
  }

  long evaluations() const noexcept { return evaluations_; }
  // At the twist the last solve() returned (when it converged): the wear rate and each module's
  // longitudinal wheel-frame force.
  double wear_rate() const noexcept { return final_in_double_ ? value_wear_rate_ : wear_rate_.a; }
  double drive_force(int module) const noexcept {
    const auto i = static_cast<std::size_t>(module);
    return final_in_double_ ? value_diagnostics_[i].fx_wheel : diagnostics_[i].fx_wheel.a;
  }

 private:
  static constexpr double kTolerance = 1e-10;  // m/s, rad/s on the residual: the iteration's target
  static constexpr double kConverged = 1e-8;   // what counts as a root (a rollout's cost moves ~1e-6 J)

  // a(v) and da/dv, the twist seeded in the Jets' three directions; the per-module forces and the
  // wear rate come along, so the step needs no further evaluation at the converged twist.
  bool acceleration(const Eigen::Vector3d& v, Eigen::Vector3d* a, Eigen::Matrix3d* da_dv) const noexcept {
    ++evaluations_;
    for (int j = 0; j < 3; ++j) state_[StateIndex::kVx + j] = TwistJet(v[j], j);
    if (model_.derivative(state_, inputs_, state_dot_, diagnostics_.data(), &wear_rate_) != ModelStatus::kOk) {
      return false;
    }
    for (int i = 0; i < 3; ++i) {
      (*a)[i] = state_dot_[StateIndex::kVx + i].a;
      da_dv->row(i) = state_dot_[StateIndex::kVx + i].v.transpose();
    }
    return a->allFinite() && da_dv->allFinite();
  }

  // The model in double at v (the converged twist): forces and wear rate.
  bool final_values(const Eigen::Vector3d& v) const noexcept {
    ++evaluations_;
    final_in_double_ = true;
    for (Eigen::Index k = 0; k < state_.size(); ++k) value_state_[k] = state_[k].a;
    for (Eigen::Index k = 0; k < inputs_.size(); ++k) value_inputs_[k] = inputs_[k].a;
    value_state_.segment<3>(StateIndex::kVx) = v;
    return value_model_.derivative(value_state_, value_inputs_, value_state_dot_, value_diagnostics_.data(),
                                   &value_wear_rate_) == ModelStatus::kOk &&
           std::isfinite(value_wear_rate_);
  }

  using TwistJetVector = Eigen::Matrix<TwistJet, Eigen::Dynamic, 1>;
  VehicleModel<TwistJet> model_;
  int max_iterations_;
  mutable TwistJetVector state_, inputs_, state_dot_;
  mutable std::vector<ModuleDiagnostics<TwistJet>> diagnostics_;
  mutable TwistJet wear_rate_{0.0};
  VehicleModel<double> value_model_;
  mutable Eigen::VectorXd value_state_, value_inputs_, value_state_dot_;
  mutable std::vector<ModuleDiagnostics<double>> value_diagnostics_;
  mutable double value_wear_rate_ = 0.0;
  mutable bool final_in_double_ = false;  // whether the last evaluation was final_values()
  mutable long evaluations_ = 0;
};

template <typename T>
class PredictionStep {
 public:
  using Vector = Eigen::Matrix<T, Eigen::Dynamic, 1>;
  using Vector3 = Eigen::Matrix<T, 3, 1>;

  PredictionStep(const VehicleParams& params, const PredictionOptions& options)
      : options_(options), model_(params, Fidelity::kIdeal), rk4_(model_, IntegratorMethod::kRk4),
        twist_solver_(params, options.max_newton_iterations), layout_(params.layout), kinematics_(params.layout),
        modules_(model_.modules()) {
    const int nx = model_.state_size();
    const int nu = model_.input_size();
    u_applied_ = Vector::Zero(nu);
    trial_state_ = Vector::Zero(nx);
    state_dot_ = Vector::Zero(nx);
    substep_state_ = Vector::Zero(nx);
    seeded_state_ = Vector::Zero(nx);
    constant_inputs_ = Vector::Zero(nu);
    state_values_ = Eigen::VectorXd::Zero(nx);
    input_values_ = Eigen::VectorXd::Zero(nu);
    diagnostics_.resize(static_cast<std::size_t>(modules_));
    // One slot per Newton solve: every substep, each split into halves down to kMaxSplits deep.
    const auto most_solves = static_cast<std::size_t>(std::max(options.substeps, options.slow_substeps)) *
                             ((std::size_t{1} << (kMaxSplits + 1)) - 1);
    twist_values_.assign(most_solves, Eigen::Vector3d::Zero());
    twist_factorizations_.assign(most_solves, Eigen::PartialPivLU<Eigen::Matrix3d>(Eigen::Matrix3d::Identity()));
    split_.assign(most_solves, 0);
    split_states_.assign(kMaxSplits, Vector::Zero(nx));
    wheel_states_ = ModuleStates(modules_);
    energy_wear_ = params.casters.empty() && params.wear.model == WearModelKind::kFrictionalPower;
    wheel_radius_ = params.layout.wheel_radius();
    wear_coefficient_ = params.wear.coefficient;
    // The drives reach a command through their first-order lag only when the plant has one.
    drive_lag_ = params.plant.actuator_lag ? params.actuators.drive_time_constant : 0.0;
    mass_ = params.mass;
    slip_speed_epsilon_ = params.tire.slip_speed_epsilon;
    // Sum over the tyres of their slip stiffness B C D (mean of the longitudinal and lateral
    // curves at the static loads), in N per unit slip: the damping the body's velocity sees.
    const double stiffness_per_newton = 0.5 * params.tire.mu *
                                        (params.tire.longitudinal.b * params.tire.longitudinal.c +
                                         params.tire.lateral.b * params.tire.lateral.c);
    for (int i = 0; i < modules_; ++i) {
      slip_stiffness_sum_ += stiffness_per_newton * model_.static_normal_loads()[static_cast<std::size_t>(i)];
    }
  }

  const VehicleModel<T>& model() const noexcept { return model_; }
  // Evaluations of the vehicle model's derivative in double by the semi-implicit steps so far.
  long model_evaluations() const noexcept { return twist_solver_.evaluations(); }

  // Jacobians are evaluated in chunks of Jet directions, each a full step at the same values. The
  // first chunk records each substep's Newton solution and dG/dv factorisation; later chunks
  // replay them instead of solving again (Jet instances only).
  void begin_chunk(bool first) const noexcept { replay_ = !first; }

  // x_next = F(x, u) over dt with module inputs u (steering rate, wheel speed per module) and the
  // stage wear. Sizes and finiteness are the caller's to check. No allocation.
  bool step(const Eigen::Ref<const Vector>& x, const Eigen::Ref<const Vector>& u, double dt, Eigen::Ref<Vector> x_next,
            T* stage_wear) const noexcept {
    const ModuleLimits& limits = layout_.limits();
    // End stops: the steering rate is clipped so the angle stays inside the module's range. A
    // [-pi, pi] range means none: the module turns freely through +-pi (a clip there left a
    // module reversed by pi unable to steer one way, and the tracking stuck).
    u_applied_ = u;
    for (int i = 0; i < modules_ && limits.has_steering_end_stops(); ++i) {
      const T& angle = x[StateIndex::steering(i)];
      T& rate = u_applied_[InputIndex::steering_rate(i)];
      rate = clamp_by_value<T>(rate, (limits.min_steering_angle - angle) / dt, (limits.max_steering_angle - angle) / dt);
    }
    T wear(0.0);
    bool ok = true;
    if (options_.method == PredictionMethod::kRk4) {
      ok = rk4_.step(x, u_applied_, dt, options_.substeps, x_next, &wear) == ModelStatus::kOk;
    } else {
      // Slow motion (body and every commanded contact speed under 0.25 m/s) is where one implicit
      // step per controller step mispredicts wear most; there it takes more, shorter steps.
      double fastest = std::hypot(scalar_value(x[StateIndex::kVx]), scalar_value(x[StateIndex::kVy]));
      for (int i = 0; i < modules_; ++i) {
        fastest = std::max(fastest, std::abs(scalar_value(u_applied_[InputIndex::wheel_speed(i)])) * wheel_radius_);
      }
      const int substeps =
          fastest < kSlowSpeed ? std::max(options_.substeps, options_.slow_substeps) : options_.substeps;
      const double h = dt / substeps;
      substep_index_ = 0;
      substep_state_ = x;
      for (int s = 0; s < substeps && ok; ++s) {
        ok = semi_implicit_substep(substep_state_, h, x_next, &wear, 0);
        substep_state_ = x_next;
      }
    }
    if (stage_wear != nullptr) *stage_wear = wear;
    return ok && std::isfinite(scalar_value(wear));
  }

  // The module inputs that carry out `twist_body` over the next dt from state x: inverse
  // kinematics, the 180 deg choice nearest the current angle (unless past an end stop), the
  // steering-rate limit, and the wheel speed scaled by the cosine of the steering error left.
  void module_inputs(const Eigen::Ref<const Vector>& x, const Vector3& twist_body, double dt,
                     Eigen::Ref<Vector> inputs) const noexcept {
    using std::atan2;
    using std::cos;
    using std::sqrt;
    const ModuleLimits& limits = layout_.limits();
    const bool end_stops = limits.has_steering_end_stops();
    const double max_wheel_speed = limits.max_drive_speed / wheel_radius_;
    for (int i = 0; i < modules_; ++i) {
      const Eigen::Vector2d& p = layout_.position_body(i);
      const T vx = twist_body.x() - twist_body.z() * p.y();
      const T vy = twist_body.y() + twist_body.z() * p.x();
      const T& angle = x[StateIndex::steering(i)];
      T rate(0.0), wheel_speed(0.0);
      if (std::hypot(scalar_value(vx), scalar_value(vy)) > kHoldSpeed) {
        const T speed = sqrt(vx * vx + vy * vy);
        T error = wrap_angle_of<T>(atan2(vy, vx) - angle);
        double sign = 1.0;
        if (std::abs(scalar_value(error)) > kPi / 2) {
          error = wrap_angle_of<T>(error + kPi);
          sign = -1.0;
        }
        const double reached = scalar_value(angle) + scalar_value(error);
        if (end_stops && (reached < limits.min_steering_angle || reached > limits.max_steering_angle)) {
          error = scalar_value(error) > 0.0 ? error - kPi : error + kPi;
          sign = -sign;
        }
        rate = soft_clamp<T>(error / dt, -limits.max_steering_rate, limits.max_steering_rate,
                               kRateLimitSmoothing * limits.max_steering_rate);
        // Drive only as fast as the wheel points the right way at the end of this step.
        const T alignment = soft_max<T>(cos(error - rate * dt), 0.0, kAlignmentSmoothing);
        wheel_speed = soft_clamp<T>(sign * speed * alignment / wheel_radius_, -max_wheel_speed, max_wheel_speed,
                                      kSpeedLimitSmoothing * max_wheel_speed);
      }
      inputs[InputIndex::steering_rate(i)] = rate;
      inputs[InputIndex::wheel_speed(i)] = wheel_speed;
    }
  }

 private:
  // Kinetic energy of the body (CoM translation + rotation) moving with twist v of the body origin.
  T kinetic_energy(const Vector3& v) const noexcept {
    const VehicleParams& p = model_.params();
    const Eigen::Vector2d& c = p.center_of_mass_body;
    const T vcx = v.x() - v.z() * c.y();
    const T vcy = v.y() + v.z() * c.x();
    return 0.5 * p.mass * (vcx * vcx + vcy * vcy) + 0.5 * p.yaw_inertia * v.z() * v.z();
  }

  // dv+/dp by the implicit function theorem at the converged v+ (T is a Jet; see the top). A member
  // template so that the double instantiation never compiles it.
  template <typename Jet = T>
  bool implicit_twist(const Vector3& v0, const Eigen::Vector3d& v_value, double h, std::size_t slot,
                      Vector3* v) const noexcept {
    constexpr int kDirections = decltype(std::declval<Jet>().v)::RowsAtCompileTime;
    static_assert(kDirections >= 3, "the Jet must hold the three twist directions");
    Eigen::PartialPivLU<Eigen::Matrix3d>& lu = twist_factorizations_[slot];
    if (!replay_) {
      if (!twist_jacobian(v_value, h, &lu)) return false;
    }
    // dG/dp: v held at its value, the state's and inputs' own derivatives flowing.
    for (int j = 0; j < 3; ++j) trial_state_[StateIndex::kVx + j] = T(v_value[j]);
    if (model_.derivative(trial_state_, u_applied_, state_dot_) != ModelStatus::kOk) return false;
    Eigen::Matrix<double, 3, kDirections> dg_dp;
    for (int i = 0; i < 3; ++i) {
      const T g = T(v_value[i]) - v0[i] - h * state_dot_[StateIndex::kVx + i];
      dg_dp.row(i) = g.v.transpose();
    }
    const Eigen::Matrix<double, 3, kDirections> dv_dp = -lu.solve(dg_dp);
    for (int i = 0; i < 3; ++i) {
      (*v)[i] = T(v_value[i]);
      (*v)[i].v = dv_dp.row(i).transpose();
    }
    return dv_dp.allFinite();
  }

  // dG/dv = I - h da/dv at v+, exactly: the twist seeded alone, everything else constant.
  template <typename Jet = T>
  bool twist_jacobian(const Eigen::Vector3d& v_value, double h, Eigen::PartialPivLU<Eigen::Matrix3d>* lu) const noexcept {
    for (Eigen::Index k = 0; k < trial_state_.size(); ++k) seeded_state_[k] = T(scalar_value(trial_state_[k]));
    for (Eigen::Index k = 0; k < u_applied_.size(); ++k) constant_inputs_[k] = T(scalar_value(u_applied_[k]));
    for (int j = 0; j < 3; ++j) {
      seeded_state_[StateIndex::kVx + j] = T(v_value[j]);
      seeded_state_[StateIndex::kVx + j].v[j] = 1.0;
    }
    if (model_.derivative(seeded_state_, constant_inputs_, state_dot_) != ModelStatus::kOk) return false;
    Eigen::Matrix3d dg_dv;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) dg_dv(i, j) = (i == j ? 1.0 : 0.0) - h * state_dot_[StateIndex::kVx + i].v[j];
    }
    lu->compute(dg_dv);
    return dg_dv.allFinite();
  }

  // Where the stiff tyres put v+ to first order: each tyre a damper (time constant tau_t, see
  // lagged_wear) pulling the body towards the twist its wheel rolls at (least squares over the
  // modules), the body's momentum holding it at v0: v+ = (v0 + (h/tau_t) v_wheels) / (1 + h/tau_t),
  // the exact root of the linearised residual. Newton's method starts there (from v0 it took 4-5
  // iterations at cruise).
  Eigen::Vector3d quasi_steady_twist(const Eigen::Ref<const Eigen::VectorXd>& state,
                                     const Eigen::Ref<const Eigen::VectorXd>& inputs, const Eigen::Vector3d& v0,
                                     double h) const noexcept {
    if (slip_stiffness_sum_ <= 0.0) return v0;
    for (int i = 0; i < modules_; ++i) {
      wheel_states_[i] = ModuleState{wheel_radius_ * inputs[InputIndex::wheel_speed(i)], state[StateIndex::steering(i)]};
    }
    Eigen::Vector3d wheels;
    if (kinematics_.forward(wheel_states_, &wheels) != KinematicsStatus::kOk) return v0;
    const double tire_time = mass_ * std::sqrt(v0.head<2>().squaredNorm() + slip_speed_epsilon_ * slip_speed_epsilon_) /
                             slip_stiffness_sum_;
    const double ratio = h / tire_time;
    return (v0 + ratio * wheels) / (1.0 + ratio);
  }

  // One backward-Euler substep of h. Where Newton's method finds no root (a tyre past its force
  // peak: see BodyTwistSolver::solve) the substep is taken as two half steps instead, down to
  // h / 2^kMaxSplits, which keeps the root the one that continues v0. The Jet instances replay the
  // split decisions of the first chunk.
  bool semi_implicit_substep(const Eigen::Ref<const Vector>& x, double h, Eigen::Ref<Vector> x_next, T* wear,
                             int depth) const noexcept {
    const auto slot = static_cast<std::size_t>(substep_index_++);
    if (slot >= split_.size()) return false;
    // Steering advances explicitly under the (already end-stop-clipped) rate.
    trial_state_ = x;
    for (int i = 0; i < modules_; ++i) {
      trial_state_[StateIndex::steering(i)] = x[StateIndex::steering(i)] + h * u_applied_[InputIndex::steering_rate(i)];
    }
    const Vector3 v0 = x.template segment<3>(StateIndex::kVx);
    Vector3 v;
    if constexpr (std::is_same_v<T, double>) {
      split_[slot] = !twist_solver_.solve(trial_state_, u_applied_, v0, quasi_steady_twist(trial_state_, u_applied_, v0, h),
                                          h, &v);
    } else {
      for (Eigen::Index k = 0; k < trial_state_.size(); ++k) state_values_[k] = scalar_value(trial_state_[k]);
      for (Eigen::Index k = 0; k < u_applied_.size(); ++k) input_values_[k] = scalar_value(u_applied_[k]);
      const Eigen::Vector3d v0_value(scalar_value(v0.x()), scalar_value(v0.y()), scalar_value(v0.z()));
      Eigen::Vector3d& v_value = twist_values_[slot];
      if (!replay_) {
        split_[slot] = !twist_solver_.solve(state_values_, input_values_, v0_value,
                                            quasi_steady_twist(state_values_, input_values_, v0_value, h), h, &v_value);
      }
      if (!split_[slot] && !implicit_twist(v0, v_value, h, slot, &v)) return false;
    }
    if (split_[slot]) {
      if (depth >= kMaxSplits) return false;
      Vector& middle = split_states_[static_cast<std::size_t>(depth)];
      return semi_implicit_substep(x, 0.5 * h, middle, wear, depth + 1) &&
             semi_implicit_substep(middle, 0.5 * h, x_next, wear, depth + 1);
    }
    trial_state_.template segment<3>(StateIndex::kVx) = v;
    T wear_rate(0.0);
    if constexpr (std::is_same_v<T, double>) {
      // The solver's last evaluation was at v+: its forces and wear rate are the step's.
      wear_rate = twist_solver_.wear_rate();
      for (int i = 0; i < modules_; ++i) diagnostics_[static_cast<std::size_t>(i)].fx_wheel = twist_solver_.drive_force(i);
    } else {
      if (model_.derivative(trial_state_, u_applied_, state_dot_, diagnostics_.data(), &wear_rate) != ModelStatus::kOk) {
        return false;
      }
    }
    T step_wear = h * wear_rate;
    if (energy_wear_) {
      // The drives' work with the implicit step's forces at v+, less the body's kinetic-energy gain.
      T drive_work(0.0);
      for (int i = 0; i < modules_; ++i) {
        drive_work += h * diagnostics_[static_cast<std::size_t>(i)].fx_wheel * wheel_radius_ *
                      u_applied_[InputIndex::wheel_speed(i)];
      }
      const T dissipated = drive_work - (kinetic_energy(v) - kinetic_energy(v0));
      step_wear = lagged_wear(step_wear, wear_coefficient_ * positive_part(dissipated), v0);
    }
    // Pose: the body moves with the constant twist v over h (exact on arcs).
    const Vector3 delta_body = h * v;
    const Vector3 pose = compose_pose_of<T>(x.template head<3>(), delta_body);
    x_next = trial_state_;
    x_next.template head<3>() = pose;
    *wear += step_wear;
    for (Eigen::Index k = 0; k < x_next.size(); ++k) {
      if (!std::isfinite(scalar_value(x_next[k]))) return false;
    }
    return true;
  }

  // The step's wear when the drives follow a command through their first-order lag tau_a, from
  // its steady part (h times the wear rate at v+) and the energy balance (which charges the whole
  // velocity change as if it were instantaneous). The tyres act on the body as a damper
  // c = stiffness / |v| (time constant tau_t = m / c, milliseconds); a velocity source that
  // follows a step dv through a first-order lag tau_a and drives a mass m through that damper
  // dissipates 1/2 m dv^2 tau_t / (tau_t + tau_a), not the 1/2 m dv^2 of an ideal step (integrate
  // c e^2 with e = dv tau_t / (tau_t - tau_a) (e^-t/tau_t - e^-t/tau_a)). Without that share, a
  // 1 cm/s correction in cruise was predicted ~8x dearer than the plant (tau_a = 50 ms against
  // tau_t = 7 ms on the paper's AGV at 1 m/s), and the controller let the tracking go to save it.
  T lagged_wear(const T& steady, const T& balance, const Vector3& v0) const noexcept {
    using std::sqrt;
    if (drive_lag_ <= 0.0 || slip_stiffness_sum_ <= 0.0) return balance;
    const T speed = sqrt(v0.x() * v0.x() + v0.y() * v0.y() + slip_speed_epsilon_ * slip_speed_epsilon_);
    const T tire_time = mass_ * speed / slip_stiffness_sum_;
    const T share = tire_time / (tire_time + drive_lag_);
    return steady + share * (balance - steady);
  }

  PredictionOptions options_;
  VehicleModel<T> model_;
  DiscreteDynamics<T> rk4_;
  BodyTwistSolver twist_solver_;
  ModuleLayout layout_;
  Kinematics kinematics_;
  int modules_;
  bool energy_wear_ = false;
  double wheel_radius_ = 0.0, wear_coefficient_ = 0.0;
  double drive_lag_ = 0.0, mass_ = 0.0, slip_speed_epsilon_ = 0.0, slip_stiffness_sum_ = 0.0;
  mutable Vector u_applied_, trial_state_, state_dot_, substep_state_, seeded_state_, constant_inputs_;
  mutable Eigen::VectorXd state_values_, input_values_;
  mutable std::vector<ModuleDiagnostics<T>> diagnostics_;
  mutable bool replay_ = false;  // see begin_chunk
  mutable int substep_index_ = 0;
  mutable std::vector<Eigen::Vector3d> twist_values_;                             // per solve
  mutable std::vector<Eigen::PartialPivLU<Eigen::Matrix3d>> twist_factorizations_;  // per solve
  mutable std::vector<char> split_;                                                 // per solve
  mutable std::vector<Vector> split_states_;                                        // per split depth
  mutable ModuleStates wheel_states_;
};

}  // namespace swerve::detail
