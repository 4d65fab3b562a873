// The prediction's discrete dynamics, for any scalar type: double for the optimiser's rollouts,
// ceres::Jet for their exact Jacobians. SemiImplicitStep<T> advances the vehicle model with ideal
// actuators (optionally with the drives' and the steering drives' lags: PredictionOptions::drive_lag
// and steering_lag) over one controller step and returns its stage wear;
// ocp/vehicle_prediction_model.hpp wraps it as the MPC's PredictionModel and says why each part is
// there. Branches (the 180 deg flip, clamps, the slow-motion substeps) are chosen on the values, so
// the Jet evaluation differentiates the branch the double evaluation takes.
//
// The backward-Euler body twist v+ solves G(v+, p) = v+ - v0 - h a(v+, p) = 0 (p: state and
// inputs). Newton's method finds its value in double (BodyTwistSolver); its derivatives follow from
// the implicit function theorem, dv+/dp = -(dG/dv)^-1 dG/dp, with both partials from the model
// linearised once per substep at the converged v+ (model_linearisation.hpp: exact, no finite
// differences and no differentiation of the Newton iterations). The module inputs come from the
// shared twist-to-module map and its smooth limits (kinematics/module_commands.hpp,
// core/smoothing.hpp), so every optimiser sees one map.
#pragma once

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <utility>
#include <vector>

#include "swerve/core/option_fields.hpp"
#include "swerve/core/smoothing.hpp"
#include "swerve/kinematics/kinematics.hpp"
#include "swerve/kinematics/module_commands.hpp"
#include "swerve/kinematics/module_state.hpp"
#include "swerve/kinematics/se2.hpp"
#include "swerve/models/drive_response.hpp"
#include "swerve/models/integrators.hpp"
#include "swerve/models/jet.hpp"
#include "swerve/models/model_linearisation.hpp"
#include "swerve/models/vehicle_model.hpp"

namespace swerve {

enum class PredictionMethod { kSemiImplicit, kRk4 };
const char* to_string(PredictionMethod method) noexcept;  // "semi_implicit", "rk4"

struct PredictionOptions {
  PredictionMethod method = PredictionMethod::kSemiImplicit;
  int substeps = 1;              // per controller step (both methods)
  int slow_substeps = 5;         // semi-implicit, when body and commanded wheels are under 0.25 m/s
  int max_newton_iterations = 8; // semi-implicit only
  // The wheel speeds as states that follow their commands through the drives' first-order lag
  // (when the vehicle's plant has one: plant.actuator_lag), so the state is (pose, twist, steering
  // angles, wheel speeds). Off: the drives reach their commands at once.
  bool drive_lag = false;
  // The steering rates as states that follow their commands through the steering drives' lag (when
  // the plant has one), appended after the wheel speeds. Off: each module steers at its commanded
  // rate at once.
  bool steering_lag = false;
  static const OptionFields<PredictionOptions>& fields();  // the rules, read by the YAML loader too
  void validate() const;         // throws ConfigError
};


inline constexpr double kSlowSpeed = 0.25;  // m/s: 5 slip-regularisation speeds of the paper's tire
// Deepest halving of a semi-implicit substep whose Newton solve finds no root (h / 16).
inline constexpr int kMaxSplits = 4;

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

// Backward-Euler body twist by Newton's method in double (the value every scalar type shares). The
// residual's Jacobian dG/dv = I - h da/dv is exact: each evaluation of the model carries Jets along
// the three twist directions (TwistJet), so one evaluation gives the residual and its Jacobian, and
// the iteration converges quadratically. (A forward-difference Jacobian cost four evaluations an
// iteration, ~19 a step.)
class BodyTwistSolver {
 public:
  using TwistJetVector = Eigen::Matrix<TwistJet, Eigen::Dynamic, 1>;

  // The solver's scratch, owned by its caller: one per thread makes solves re-entrant.
  struct Data {
    explicit Data(const BodyTwistSolver& solver)
        : state(TwistJetVector::Zero(solver.state_size_)), inputs(TwistJetVector::Zero(solver.input_size_)),
          state_dot(TwistJetVector::Zero(solver.state_size_)), diagnostics(static_cast<std::size_t>(solver.modules_)),
          value_state(Eigen::VectorXd::Zero(solver.state_size_)), value_inputs(Eigen::VectorXd::Zero(solver.input_size_)),
          value_state_dot(Eigen::VectorXd::Zero(solver.state_size_)),
          value_diagnostics(static_cast<std::size_t>(solver.modules_)),
          steering_cos(static_cast<std::size_t>(solver.modules_)), steering_sin(static_cast<std::size_t>(solver.modules_)) {}
    TwistJetVector state, inputs, state_dot;
    std::vector<ModuleDiagnostics<TwistJet>> diagnostics;
    TwistJet wear_rate{0.0};
    Eigen::VectorXd value_state, value_inputs, value_state_dot;
    std::vector<ModuleDiagnostics<double>> value_diagnostics;
    double value_wear_rate = 0.0;
    // Each module's steering cos and sin: fixed over a solve, computed once at its start.
    std::vector<double> steering_cos, steering_sin;
    bool final_in_double = false;  // whether the last evaluation was final_values()
    long evaluations = 0;
  };

  BodyTwistSolver(const VehicleParams& params, int max_iterations)
      : model_(params, Fidelity::kIdeal), value_model_(params, Fidelity::kIdeal), max_iterations_(max_iterations),
        state_size_(model_.state_size()), input_size_(model_.input_size()), modules_(model_.modules()) {}

  // VehicleModel::observe_friction_scales, for both of its models.
  void observe_friction_scales(const double* scales) noexcept {
    model_.observe_friction_scales(scales);
    value_model_.observe_friction_scales(scales);
  }
  // VehicleModel::observe_module_faults, for both of its models.
  void observe_module_faults(const ModuleFaults* faults) noexcept {
    model_.observe_module_faults(faults);
    value_model_.observe_module_faults(faults);
  }

  // v+ for the state `trial_state` (steering already advanced; its twist entries are ignored) under
  // `inputs`, from v0 over h, started at `guess`. Step halving keeps each iterate's residual below
  // the last. True only when the residual has converged: a tyre past its force peak makes the
  // residual non-monotone, and a long step from rest then has no root near v0 or several (Newton
  // wandered, and an unconverged 6.5 m/s was once returned for a 4 cm/s command); the caller
  // splits the step.
  bool solve(Data& d, const Eigen::Ref<const Eigen::VectorXd>& trial_state, const Eigen::Ref<const Eigen::VectorXd>& inputs,
             const Eigen::Vector3d& v0, const Eigen::Vector3d& guess, double h, Eigen::Vector3d* v_out) const noexcept {
    for (Eigen::Index k = 0; k < d.state.size(); ++k) d.state[k] = TwistJet(trial_state[k]);
    for (Eigen::Index k = 0; k < d.inputs.size(); ++k) d.inputs[k] = TwistJet(inputs[k]);
    for (int i = 0; i < modules_; ++i) {
      const double delta = trial_state[StateIndex::steering(i)];
      d.steering_cos[static_cast<std::size_t>(i)] = std::cos(delta);
      d.steering_sin[static_cast<std::size_t>(i)] = std::sin(delta);
    }
    Eigen::Vector3d v = guess, a;
    Eigen::Matrix3d da_dv;
    if (!acceleration(d, v, &a, &da_dv)) return false;
    Eigen::Vector3d residual = v - v0 - h * a;
    double residual_norm = residual.norm();
    double previous_norm = 0.0;  // the residual before the last full Newton step; 0 if there was none
    d.final_in_double = false;
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
          if (!final_values(d, v)) return false;
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
        if (!acceleration(d, trial, &trial_a, &trial_da_dv)) continue;
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

  static long evaluations(const Data& d) noexcept { return d.evaluations; }
  // At the twist the last solve() returned (when it converged): the wear rate and each module's
  // longitudinal wheel-frame force.
  static double wear_rate(const Data& d) noexcept { return d.final_in_double ? d.value_wear_rate : d.wear_rate.a; }
  static double module_wear_rate(const Data& d, int module) noexcept {
    const auto i = static_cast<std::size_t>(module);
    return d.final_in_double ? d.value_diagnostics[i].wear_rate : d.diagnostics[i].wear_rate.a;
  }
  static double drive_force(const Data& d, int module) noexcept {
    const auto i = static_cast<std::size_t>(module);
    return d.final_in_double ? d.value_diagnostics[i].fx_wheel : d.diagnostics[i].fx_wheel.a;
  }

 private:
  static constexpr double kTolerance = 1e-10;  // m/s, rad/s on the residual: the iteration's target
  static constexpr double kConverged = 1e-8;   // what counts as a root (a rollout's cost moves ~1e-6 J)

  // a(v) and da/dv, the twist seeded in the Jets' three directions; the per-module forces and the
  // wear rate come along, so the step needs no further evaluation at the converged twist.
  bool acceleration(Data& d, const Eigen::Vector3d& v, Eigen::Vector3d* a, Eigen::Matrix3d* da_dv) const noexcept {
    ++d.evaluations;
    for (int j = 0; j < 3; ++j) d.state[StateIndex::kVx + j] = TwistJet(v[j], j);
    if (model_.derivative_at_steering(d.state, d.inputs, d.steering_cos.data(), d.steering_sin.data(), d.state_dot,
                                      d.diagnostics.data(), &d.wear_rate) != ModelStatus::kOk) {
      return false;
    }
    for (int i = 0; i < 3; ++i) {
      (*a)[i] = d.state_dot[StateIndex::kVx + i].a;
      da_dv->row(i) = d.state_dot[StateIndex::kVx + i].v.transpose();
    }
    return a->allFinite() && da_dv->allFinite();
  }

  // The model in double at v (the converged twist): forces and wear rate.
  bool final_values(Data& d, const Eigen::Vector3d& v) const noexcept {
    ++d.evaluations;
    d.final_in_double = true;
    for (Eigen::Index k = 0; k < d.state.size(); ++k) d.value_state[k] = d.state[k].a;
    for (Eigen::Index k = 0; k < d.inputs.size(); ++k) d.value_inputs[k] = d.inputs[k].a;
    d.value_state.segment<3>(StateIndex::kVx) = v;
    return value_model_.derivative_at_steering(d.value_state, d.value_inputs, d.steering_cos.data(),
                                               d.steering_sin.data(), d.value_state_dot, d.value_diagnostics.data(),
                                               &d.value_wear_rate) == ModelStatus::kOk &&
           std::isfinite(d.value_wear_rate);
  }

  VehicleModel<TwistJet> model_;
  VehicleModel<double> value_model_;
  int max_iterations_, state_size_, input_size_, modules_;
};

template <typename T>
class SemiImplicitStep {
 public:
  using Vector = Eigen::Matrix<T, Eigen::Dynamic, 1>;
  using Vector3 = Eigen::Matrix<T, 3, 1>;

  SemiImplicitStep(const VehicleParams& params, const PredictionOptions& options)
      : options_(options), model_(params, Fidelity::kIdeal), rk4_(model_, IntegratorMethod::kRk4),
        twist_solver_(params, options.max_newton_iterations), linearisation_(params), layout_(params.layout),
        kinematics_(params.layout), modules_(model_.modules()) {
    energy_wear_ = params.casters.empty() && params.wear.model == WearModelKind::kFrictionalPower;
    wheel_radius_ = params.layout.wheel_radius();
    wear_coefficient_ = params.wear.coefficient;
    // The drives reach a command through their first-order lag only when the plant has one.
    drive_lag_ = params.plant.actuator_lag ? params.actuators.drive_time_constant : 0.0;
    // With options.drive_lag the wheel speeds are states of the prediction (see step()).
    lag_states_ = options.drive_lag && drive_lag_ > 0.0 ? modules_ : 0;
    drive_response_.time_constant = drive_lag_;
    const double steering_lag = params.plant.actuator_lag ? params.actuators.steering_time_constant : 0.0;
    steering_lag_states_ = options.steering_lag && steering_lag > 0.0 ? modules_ : 0;
    steering_response_.time_constant = steering_lag;
    if (params.plant.actuator_saturation) {
      drive_response_.max_acceleration = params.layout.limits().max_drive_acceleration / params.layout.wheel_radius();
    }
    mass_ = params.mass;
    slip_speed_epsilon_ = params.tire.slip_speed_epsilon;
    // Sum over the tyres of their slip stiffness B C D (mean of the longitudinal and lateral
    // curves at the static loads), in N per unit slip: the damping the body's velocity sees.
    const double stiffness_per_newton =
        0.5 * (params.tire.mu_longitudinal() * params.tire.longitudinal.b * params.tire.longitudinal.c +
               params.tire.mu_lateral() * params.tire.lateral.b * params.tire.lateral.c);
    for (int i = 0; i < modules_; ++i) {
      nominal_slip_stiffness_sum_ += stiffness_per_newton * model_.static_normal_loads()[static_cast<std::size_t>(i)];
    }
    static_load_shares_ = params.static_load_shares();
  }

  // A lag's response over one step (end and mean) linearised in its start and command.
  struct LagResponse {
    double end = 0.0, mean = 0.0;
    double end_per_start = 0.0, end_per_command = 0.0, mean_per_start = 0.0, mean_per_command = 0.0;
  };

  // The step's scratch, owned by its caller (Crocoddyl's createData(), acados' workspace): the
  // step itself is immutable, so rollouts with a Data each may run on threads of their own.
  struct Data {
    explicit Data(const SemiImplicitStep& step)
        : rk4(step.rk4_), twist(step.twist_solver_), linearisation(step.linearisation_) {
      const int nx = step.model_.state_size();
      const int nu = step.model_.input_size();
      u_applied = Vector::Zero(nu);
      trial_state = Vector::Zero(nx);
      substep_state = Vector::Zero(nx);
      state_values = Eigen::VectorXd::Zero(nx);
      input_values = Eigen::VectorXd::Zero(nu);
      diagnostics.resize(static_cast<std::size_t>(step.modules_));
      // One slot per Newton solve: every substep, each split into halves down to kMaxSplits deep.
      const auto most_solves =
          static_cast<std::size_t>(std::max(step.options_.substeps, step.options_.slow_substeps)) *
          ((std::size_t{1} << (kMaxSplits + 1)) - 1);
      twist_values.assign(most_solves, Eigen::Vector3d::Zero());
      twist_factorizations.assign(most_solves, Eigen::PartialPivLU<Eigen::Matrix3d>(Eigen::Matrix3d::Identity()));
      if constexpr (!std::is_same_v<T, double>) {
        linear_points.assign(most_solves, step.linearisation_.make_point());
        // Each substep steps every drive and steering lag once, and the step the drives once more.
        lag_responses.resize(2 * static_cast<std::size_t>(step.modules_) * (most_solves + 1));
      }
      split.assign(most_solves, 0);
      split_states.assign(kMaxSplits, Vector::Zero(nx));
      wheel_states = ModuleStates(step.modules_);
      wheel_speeds_next = Vector::Zero(step.lag_states_);
      wheel_commands = Vector::Zero(step.lag_states_);
      wheel_speeds_now = Vector::Zero(step.lag_states_);
      wheel_speeds_mean = Vector::Zero(step.lag_states_);
      steering_commands = Vector::Zero(step.steering_lag_states_);
      steering_rates_now = Vector::Zero(step.steering_lag_states_);
      steering_rates_end = Vector::Zero(step.steering_lag_states_);
    }
    Vector u_applied, trial_state, substep_state;
    Vector wheel_speeds_next;  // drive lag: the wheel speeds at the end of the whole step
    // Drive lag: each wheel's command, its speed at the current substep's start, and its mean over
    // the substep.
    Vector wheel_commands, wheel_speeds_now, wheel_speeds_mean;
    // Steering lag: each module's commanded rate, its rate at the current substep's (or with RK4
    // the step's) start and end.
    Vector steering_commands, steering_rates_now, steering_rates_end;
    Eigen::VectorXd state_values, input_values;
    std::vector<ModuleDiagnostics<T>> diagnostics;
    bool replay = false;  // see begin_chunk
    int substep_index = 0;
    std::vector<Eigen::Vector3d> twist_values;                             // per solve
    std::vector<Eigen::PartialPivLU<Eigen::Matrix3d>> twist_factorizations;  // per solve: dG/dv
    std::vector<ModelLinearisation::Point> linear_points;                    // per solve (Jets only)
    std::vector<LagResponse> lag_responses;                                  // per lag stepped (Jets only)
    std::size_t lag_response_index = 0;
    long linearisations = 0;
    std::vector<char> split;                                                 // per solve
    std::vector<Vector> split_states;                                        // per split depth
    ModuleStates wheel_states;
    typename DiscreteDynamics<T>::Data rk4;  // PredictionMethod::kRk4's stages
    long rk4_evaluations = 0;                 // its derivative evaluations (4 per substep)
    BodyTwistSolver::Data twist;
    ModelLinearisation::Data linearisation;
  };

  const VehicleModel<T>& model() const noexcept { return model_; }
  // The prediction's state: the model's (pose, twist, steering angles), then with drive_lag the n
  // wheel speeds (rad/s), then with steering_lag the n steering rates (rad/s).
  int state_size() const noexcept { return model_.state_size() + lag_states_ + steering_lag_states_; }
  int wheel_speed_states() const noexcept { return lag_states_; }
  int steering_rate_states() const noexcept { return steering_lag_states_; }
  // Evaluations of the vehicle model's derivative in double by the steps so far.
  static long model_evaluations(const Data& d) noexcept {
    return BodyTwistSolver::evaluations(d.twist) + d.rk4_evaluations;
  }
  // The model's linearisations (one per converged substep) by a Jet instance's steps so far.
  static long linearisations(const Data& d) noexcept { return d.linearisations; }

  // Jacobians are evaluated in chunks of Jet directions, each a full step at the same values. The
  // first chunk records each substep's Newton solution and the model's linearisation there; later
  // chunks replay them instead of solving and linearising again (Jet instances only).
  static void begin_chunk(Data& d, bool first) noexcept { d.replay = !first; }

  // The modules' faults from now on (null: none): a module whose steering is stuck gets no
  // steering rate, and the twist map rolls its wheel along its angle (ModuleCommandRule::faults).
  // Wiring like charge_work_to, not part of an evaluation: `faults` must outlive the step.
  // A dead drive reaches every model the step evaluates (VehicleModel::observe_module_faults).
  void observe_module_faults(const ModuleFaults* faults) noexcept {
    faults_ = faults;
    model_.observe_module_faults(faults);
    twist_solver_.observe_module_faults(faults);
    linearisation_.observe_module_faults(faults);
  }
  // The floor's grip under each module from now on (VehicleModel::observe_friction_scales; null:
  // the tire's own mu everywhere), for every model the step evaluates. Wiring as above.
  void observe_friction_scales(const double* scales) noexcept {
    model_.observe_friction_scales(scales);
    twist_solver_.observe_friction_scales(scales);
    linearisation_.observe_friction_scales(scales);
  }

  // Each module's weight on its own wear from now on (n entries, all finite and >= 0; null: 1
  // each), so that a worn tyre's wear may cost more than a new one's (wear balancing). Wiring as
  // above. The semi-implicit step only: RK4's stage wear stays unweighted (PredictionOptions are
  // checked against this by the controller).
  void observe_wear_weights(const double* weights) noexcept { wear_weights_ = weights; }

  // x_next = F(x, u) over dt with module inputs u (steering rate, wheel speed per module) and the
  // stage wear. Sizes and finiteness are the caller's to check. No allocation.
  //
  // Drive lag (PredictionOptions::drive_lag): wheel i starts the step at its state x[6 + n + i]
  // and follows its command through the drive's first-order lag and acceleration clamp, as the
  // plant's drive does (drive_response). Each implicit substep runs on the wheel's speed at its end
  // and charges the drive's work at its mean speed (see semi_implicit_substep); the state moves on
  // to the speed at the step's end. Steering lag (PredictionOptions::steering_lag) likewise: the
  // steering rates are states after the wheel speeds, and each substep's angle advances by the
  // rate's mean over it. Without drive lag the wheels
  // reach their commands at once, and the prediction missed the wear of modules whose lagging
  // wheels fight one another while the body turns: on the 8-module carrier's hard start the
  // plant wore 172 and 235 J in two half-second windows where the prediction, from the same states
  // and commands, said 27 and 8.5 J; with the logged wheel speeds and the lag, 165 and 226 J.
  bool step(Data& d, const Eigen::Ref<const Vector>& x_full, const Eigen::Ref<const Vector>& u, double dt,
            Eigen::Ref<Vector> x_next_full, T* stage_wear) const noexcept {
    const int model_size = model_.state_size();
    const auto x = x_full.head(model_size);
    Eigen::Ref<Vector> x_next = x_next_full.head(model_size);
    const ModuleLimits& limits = layout_.limits();
    // End stops: the steering rate is clipped so the angle stays inside the module's range. A
    // [-pi, pi] range means none: the module turns freely through +-pi (a clip there left a
    // module reversed by pi unable to steer one way, and the tracking stuck).
    d.u_applied = u;
    // A stuck steering holds its angle whatever it is commanded (observe_module_faults).
    for (int i = 0; i < modules_ && faults_ != nullptr; ++i) {
      if (steering_stuck(faults_, i)) d.u_applied[InputIndex::steering_rate(i)] = T(0.0);
    }
    for (int i = 0; i < modules_ && limits.has_steering_end_stops(); ++i) {
      const T& angle = x[StateIndex::steering(i)];
      T& rate = d.u_applied[InputIndex::steering_rate(i)];
      rate = clamp_by_value<T>(rate, (limits.min_steering_angle - angle) / dt, (limits.max_steering_angle - angle) / dt);
    }
    // Lagged actuators start at their states (*_now). The wheels' mean speeds over the whole step
    // decide the slow-motion substeps below; RK4 runs on the means over the step, and the
    // semi-implicit substeps follow each lag substep by substep instead.
    d.lag_response_index = 0;
    if (lag_states_ > 0) {
      const DriveLagStep drive_over_dt(drive_response_, dt);
      for (int i = 0; i < lag_states_; ++i) {
        T& wheel = d.u_applied[InputIndex::wheel_speed(i)];
        d.wheel_commands[i] = wheel;
        d.wheel_speeds_now[i] = x_full[model_size + i];
        lag_response(d, d.wheel_speeds_now[i], d.wheel_commands[i], drive_over_dt, &d.wheel_speeds_next[i], &wheel);
      }
    }
    for (int i = 0; i < steering_lag_states_; ++i) {
      d.steering_commands[i] = d.u_applied[InputIndex::steering_rate(i)];
      // A stuck steering does not turn at the rate it turned before it stuck, either.
      d.steering_rates_now[i] = steering_stuck(faults_, i) ? T(0.0) : T(x_full[model_size + lag_states_ + i]);
    }
    T wear(0.0);
    bool ok = true;
    if (options_.method == PredictionMethod::kRk4) {
      for (int i = 0; i < steering_lag_states_; ++i) {
        drive_response<T>(d.steering_rates_now[i], d.steering_commands[i], steering_response_, dt,
                          &d.steering_rates_end[i], &d.u_applied[InputIndex::steering_rate(i)]);
      }
      ok = rk4_.step(d.rk4, x, d.u_applied, dt, options_.substeps, x_next, &wear) == ModelStatus::kOk;
      d.rk4_evaluations += 4L * options_.substeps;
      d.wheel_speeds_now = d.wheel_speeds_next;
      d.steering_rates_now = d.steering_rates_end;
    } else {
      // Slow motion (body and every commanded contact speed under 0.25 m/s) is where one implicit
      // step per controller step mispredicts wear most; there it takes more, shorter steps.
      double fastest = std::hypot(scalar_value(x[StateIndex::kVx]), scalar_value(x[StateIndex::kVy]));
      for (int i = 0; i < modules_; ++i) {
        fastest = std::max(fastest, std::abs(scalar_value(d.u_applied[InputIndex::wheel_speed(i)])) * wheel_radius_);
      }
      const int substeps =
          fastest < kSlowSpeed ? std::max(options_.substeps, options_.slow_substeps) : options_.substeps;
      const double h = dt / substeps;
      d.substep_index = 0;
      d.substep_state = x;
      for (int s = 0; s < substeps && ok; ++s) {
        ok = semi_implicit_substep(d, d.substep_state, h, x_next, &wear, 0);
        d.substep_state = x_next;
      }
    }
    x_next_full.segment(model_size, lag_states_) = d.wheel_speeds_now;
    x_next_full.segment(model_size + lag_states_, steering_lag_states_) = d.steering_rates_now;
    if (stage_wear != nullptr) *stage_wear = wear;
    return ok && std::isfinite(scalar_value(wear));
  }

  // The module inputs that carry out `twist_body` over the next dt from state x: the shared
  // twist-to-module map (kinematics/module_commands.hpp) with the nearest way round (never past an
  // end stop) and smooth limits, so the optimisers' derivatives see no kink.
  void module_inputs(const Eigen::Ref<const Vector>& x, const Vector3& twist_body, double dt,
                     Eigen::Ref<Vector> inputs) const noexcept {
    module_inputs_at<T>(twist_body, x.segment(StateIndex::kFirstSteering, modules_), dt, inputs.head(2 * modules_));
  }
  // The same map in any scalar S, from the steering angles alone (n): module i's inputs depend on
  // the twist and its own angle only (the Jacobian colours them; semi_implicit_step_jacobian.cpp).
  template <typename S>
  void module_inputs_at(const Eigen::Matrix<S, 3, 1>& twist_body,
                        const Eigen::Ref<const Eigen::Matrix<S, Eigen::Dynamic, 1>>& angles, double dt,
                        Eigen::Ref<Eigen::Matrix<S, Eigen::Dynamic, 1>> inputs) const noexcept {
    static_assert(InputIndex::steering_rate(1) == 2 && InputIndex::wheel_speed(1) == 3,
                  "module_commands interleaves (steering rate, wheel speed) per module");
    ModuleCommandRule rule;
    rule.flip = FlipPolicy::kNearest;
    rule.tie_band = kDirectionTieBand;
    rule.shape = LimitShape::kSmooth;
    rule.faults = faults_;
    module_commands<S>(layout_, twist_body, angles, dt, rule, inputs);
  }

 private:
  // Kinetic energy of the body (CoM translation + rotation) moving with twist v of the body origin.
  T kinetic_energy(const Vector3& v) const noexcept {
    const VehicleParams& p = model_.params();
    const Eigen::Vector2d& c = p.center_of_mass_body;
    const Eigen::Matrix<T, 2, 1> v_com = point_velocity<T>(v, c);
    return 0.5 * p.mass * (v_com.x() * v_com.x() + v_com.y() * v_com.y()) + 0.5 * p.yaw_inertia * v.z() * v.z();
  }

  // A lag's response (drive_response) from `start` towards `command`. A Jet instance linearises it
  // in the two once, in a Jacobian's first chunk, and later chunks chain those partials: the wide
  // Jets' own arithmetic here was a fifth of a Jacobian.
  void lag_response(Data& d, const T& start, const T& command, const DriveLagStep& step, T* end, T* mean) const noexcept {
    if constexpr (std::is_same_v<T, double>) {
      drive_response<double>(start, command, step, end, mean);
    } else {
      if (d.lag_response_index >= d.lag_responses.size()) {  // not foreseen by Data's sizing
        drive_response<T>(start, command, step, end, mean);
        return;
      }
      LagResponse& response = d.lag_responses[d.lag_response_index++];
      if (!d.replay) {
        using ResponseJet = ceres::Jet<double, 2>;  // directions: start, command
        ResponseJet end_jet, mean_jet;
        drive_response<ResponseJet>(ResponseJet(scalar_value(start), 0), ResponseJet(scalar_value(command), 1), step,
                                    &end_jet, &mean_jet);
        response = {end_jet.a, mean_jet.a, end_jet.v[0], end_jet.v[1], mean_jet.v[0], mean_jet.v[1]};
      }
      T end_out(response.end), mean_out(response.mean);
      end_out.v = response.end_per_start * start.v + response.end_per_command * command.v;
      mean_out.v = response.mean_per_start * start.v + response.mean_per_command * command.v;
      *end = end_out;
      *mean = mean_out;
    }
  }

  // The model linearised at the converged v+ of solve `slot` (state_values and input_values hold
  // the substep's point), and dG/dv = I - h da/dv factorised. Jet instances only.
  bool linearise_substep(Data& d, const Eigen::Vector3d& v_value, double h, std::size_t slot) const noexcept {
    d.state_values.template segment<3>(StateIndex::kVx) = v_value;
    ModelLinearisation::Point& point = d.linear_points[slot];
    ++d.linearisations;
    if (!linearisation_.linearise(d.linearisation, d.state_values, d.input_values, &point)) return false;
    const Eigen::Matrix3d dg_dv = Eigen::Matrix3d::Identity() - h * point.acceleration_per_twist;
    d.twist_factorizations[slot].compute(dg_dv);
    return dg_dv.allFinite();
  }

  // The derivative part of a model input's Jet: module i's steering angle after the substep's
  // advance, or its wheel speed.
  static const auto& steering_derivatives(const Data& d, int module) noexcept {
    return d.trial_state[StateIndex::steering(module)].v;
  }
  static const auto& wheel_speed_derivatives(const Data& d, int module) noexcept {
    return d.u_applied[InputIndex::wheel_speed(module)].v;
  }

  // dv+/dp by the implicit function theorem at the converged v+ (T is a Jet; see the top): dG/dp
  // holds v at its value, so it is the start's own derivatives and the model's through the
  // steering angles and wheel speeds, chained from the substep's linearisation. A member template
  // so that the double instantiation never compiles it.
  template <typename Jet = T>
  bool implicit_twist(const Data& d, const Vector3& v0, const Eigen::Vector3d& v_value, double h, std::size_t slot,
                      Vector3* v) const noexcept {
    constexpr int kDirections = decltype(std::declval<Jet>().v)::RowsAtCompileTime;
    const ModelLinearisation::Point& point = d.linear_points[slot];
    Eigen::Matrix<double, 3, kDirections> dg_dp;
    for (int i = 0; i < 3; ++i) dg_dp.row(i) = -v0[i].v.transpose();
    for (int i = 0; i < modules_; ++i) {
      dg_dp.noalias() -= (h * point.acceleration_per_steering.col(i)) * steering_derivatives(d, i).transpose();
      dg_dp.noalias() -= (h * point.acceleration_per_wheel_speed.col(i)) * wheel_speed_derivatives(d, i).transpose();
    }
    const Eigen::Matrix<double, 3, kDirections> dv_dp = -d.twist_factorizations[slot].solve(dg_dp);
    for (int i = 0; i < 3; ++i) {
      (*v)[i] = T(v_value[i]);
      (*v)[i].v = dv_dp.row(i).transpose();
    }
    return dv_dp.allFinite();
  }

  // The wear rate and each module's drive force at v+, their derivatives chained from the
  // substep's linearisation through v+ (*v), the steering angles and the wheel speeds.
  template <typename Jet = T>
  void outputs_at_twist(Data& d, const Vector3& v, std::size_t slot, T* wear_rate) const noexcept {
    const ModelLinearisation::Point& point = d.linear_points[slot];
    *wear_rate = T(point.wear_rate);
    for (int j = 0; j < 3; ++j) wear_rate->v += point.wear_rate_per_twist[j] * v[j].v;
    for (int i = 0; i < modules_; ++i) {
      wear_rate->v += point.wear_rate_per_steering[i] * steering_derivatives(d, i) +
                      point.wear_rate_per_wheel_speed[i] * wheel_speed_derivatives(d, i);
      T& force = d.diagnostics[static_cast<std::size_t>(i)].fx_wheel;
      const auto partials = point.drive_force_partials.row(i);
      force = T(point.drive_force[i]);
      for (int j = 0; j < 3; ++j) force.v += partials[ModelLinearisation::kTwist + j] * v[j].v;
      force.v += partials[ModelLinearisation::kSteering] * steering_derivatives(d, i) +
                 partials[ModelLinearisation::kWheelSpeed] * wheel_speed_derivatives(d, i);
    }
  }

  // Where the stiff tyres put v+ to first order: each tyre a damper (time constant tau_t, see
  // lagged_wear) pulling the body towards the twist its wheel rolls at (least squares over the
  // modules), the body's momentum holding it at v0: v+ = (v0 + (h/tau_t) v_wheels) / (1 + h/tau_t),
  // the exact root of the linearised residual. Newton's method starts there (from v0 it took 4-5
  // iterations at cruise).
  Eigen::Vector3d quasi_steady_twist(Data& d, const Eigen::Ref<const Eigen::VectorXd>& state,
                                     const Eigen::Ref<const Eigen::VectorXd>& inputs, const Eigen::Vector3d& v0,
                                     double h) const noexcept {
    if (nominal_slip_stiffness_sum_ <= 0.0) return v0;
    for (int i = 0; i < modules_; ++i) {
      d.wheel_states[i] = ModuleState{wheel_radius_ * inputs[InputIndex::wheel_speed(i)], state[StateIndex::steering(i)]};
    }
    Eigen::Vector3d wheels;
    if (kinematics_.forward(d.wheel_states, &wheels) != KinematicsStatus::kOk) return v0;
    const double ratio = h / tire_time_constant<double>(v0.x(), v0.y());
    return (v0 + ratio * wheels) / (1.0 + ratio);
  }

  // One backward-Euler substep of h. Where Newton's method finds no root (a tyre past its force
  // peak: see BodyTwistSolver::solve) the substep is taken as two half steps instead, down to
  // h / 2^kMaxSplits, which keeps the root the one that continues v0. The Jet instances replay the
  // split decisions of the first chunk.
  bool semi_implicit_substep(Data& d, const Eigen::Ref<const Vector>& x, double h, Eigen::Ref<Vector> x_next, T* wear,
                             int depth) const noexcept {
    const auto slot = static_cast<std::size_t>(d.substep_index++);
    if (slot >= d.split.size()) return false;
    // Lagged drives: the implicit step runs on each wheel's speed at the substep's end (a velocity
    // source ramping at a leads the body by a tau_t there, as in the plant; the mean speed left the
    // body a h / 2 further behind and priced a ramp's rollout 1.4-3x the plant's), and the drives'
    // work below on its mean (the integral of force times speed).
    if (lag_states_ > 0) {
      const DriveLagStep drive_over_h(drive_response_, h);
      for (int i = 0; i < lag_states_; ++i) {
        lag_response(d, d.wheel_speeds_now[i], d.wheel_commands[i], drive_over_h,
                     &d.u_applied[InputIndex::wheel_speed(i)], &d.wheel_speeds_mean[i]);
      }
    }
    // Lagged steering: the angle advances by the rate's mean over the substep.
    if (steering_lag_states_ > 0) {
      const DriveLagStep steering_over_h(steering_response_, h);
      for (int i = 0; i < steering_lag_states_; ++i) {
        lag_response(d, d.steering_rates_now[i], d.steering_commands[i], steering_over_h, &d.steering_rates_end[i],
                     &d.u_applied[InputIndex::steering_rate(i)]);
      }
    }
    // Steering advances explicitly under the (already end-stop-clipped) rate.
    const ModuleLimits& limits = layout_.limits();
    d.trial_state = x;
    for (int i = 0; i < modules_; ++i) {
      T& rate = d.u_applied[InputIndex::steering_rate(i)];
      const T& angle = x[StateIndex::steering(i)];
      if (steering_lag_states_ > 0 && limits.has_steering_end_stops()) {
        rate = clamp_by_value<T>(rate, (limits.min_steering_angle - angle) / h,
                                 (limits.max_steering_angle - angle) / h);
      }
      d.trial_state[StateIndex::steering(i)] = angle + h * rate;
    }
    const Vector3 v0 = x.template segment<3>(StateIndex::kVx);
    Vector3 v;
    if constexpr (std::is_same_v<T, double>) {
      d.split[slot] = !twist_solver_.solve(d.twist, d.trial_state, d.u_applied, v0, quasi_steady_twist(d, d.trial_state, d.u_applied, v0, h),
                                          h, &v);
    } else {
      for (Eigen::Index k = 0; k < d.trial_state.size(); ++k) d.state_values[k] = scalar_value(d.trial_state[k]);
      for (Eigen::Index k = 0; k < d.u_applied.size(); ++k) d.input_values[k] = scalar_value(d.u_applied[k]);
      const Eigen::Vector3d v0_value(scalar_value(v0.x()), scalar_value(v0.y()), scalar_value(v0.z()));
      Eigen::Vector3d& v_value = d.twist_values[slot];
      if (!d.replay) {
        d.split[slot] = !twist_solver_.solve(d.twist, d.state_values, d.input_values, v0_value,
                                            quasi_steady_twist(d, d.state_values, d.input_values, v0_value, h), h, &v_value);
        if (!d.split[slot] && !linearise_substep(d, v_value, h, slot)) return false;
      }
      if (!d.split[slot] && !implicit_twist(d, v0, v_value, h, slot, &v)) return false;
    }
    if (d.split[slot]) {
      if (depth >= kMaxSplits) return false;
      Vector& middle = d.split_states[static_cast<std::size_t>(depth)];
      return semi_implicit_substep(d, x, 0.5 * h, middle, wear, depth + 1) &&
             semi_implicit_substep(d, middle, 0.5 * h, x_next, wear, depth + 1);
    }
    d.trial_state.template segment<3>(StateIndex::kVx) = v;
    for (int i = 0; i < lag_states_; ++i) d.wheel_speeds_now[i] = d.u_applied[InputIndex::wheel_speed(i)];
    for (int i = 0; i < steering_lag_states_; ++i) d.steering_rates_now[i] = d.steering_rates_end[i];
    T wear_rate(0.0);
    if constexpr (std::is_same_v<T, double>) {
      // The solver's last evaluation was at v+: its forces and wear rate are the step's.
      wear_rate = BodyTwistSolver::wear_rate(d.twist);
      for (int i = 0; i < modules_; ++i) d.diagnostics[static_cast<std::size_t>(i)].fx_wheel = BodyTwistSolver::drive_force(d.twist, i);
    } else {
      outputs_at_twist(d, v, slot, &wear_rate);
    }
    T step_wear = h * wear_rate;
    if (energy_wear_) {
      // The drives' work with the implicit step's forces at v+, less the body's kinetic-energy gain.
      T drive_work(0.0);
      for (int i = 0; i < modules_; ++i) {
        drive_work += h * d.diagnostics[static_cast<std::size_t>(i)].fx_wheel * wheel_radius_ *
                      (lag_states_ > 0 ? d.wheel_speeds_mean[i] : d.u_applied[InputIndex::wheel_speed(i)]);
      }
      const T dissipated = drive_work - (kinetic_energy(v) - kinetic_energy(v0));
      step_wear = lagged_wear(step_wear, wear_coefficient_ * positive_part(dissipated), v0);
    }
    if (wear_weights_ != nullptr) step_wear = weighted_wear(d, step_wear, v, slot, h);
    // Pose: the body moves with the constant twist v over h (exact on arcs).
    const Vector3 delta_body = h * v;
    const Vector3 pose = compose_pose_of<T>(x.template head<3>(), delta_body);
    x_next = d.trial_state;
    x_next.template head<3>() = pose;
    *wear += step_wear;
    for (Eigen::Index k = 0; k < x_next.size(); ++k) {
      if (!std::isfinite(scalar_value(x_next[k]))) return false;
    }
    return true;
  }

  // The step's wear `unweighted` with module i's own wear weighed by w_i. Its steady part is
  // h sum_i rate_i at v+, module by module, so that part becomes h sum_i w_i rate_i. The rest (what
  // the energy balance charges beyond it: the transient the implicit step steps over) the tyres
  // dissipate as dampers in proportion to their stiffness, i.e. their static loads times the
  // floor's grip under them (slip_stiffness_sum), so it takes their stiffness-weighted mean weight
  // w_bar: w_bar W + h sum_i (w_i - w_bar) rate_i, which is W itself when every weight is 1.
  T weighted_wear(Data& d, const T& unweighted, const Vector3& v, std::size_t slot, double h) const noexcept {
    const double* grip = model_.friction_scales();
    double mean_weight = 0.0, stiffness = 0.0;
    for (int i = 0; i < modules_; ++i) {
      const double share = static_load_shares_[static_cast<std::size_t>(i)] * (grip != nullptr ? grip[i] : 1.0);
      mean_weight += share * wear_weights_[i];
      stiffness += share;
    }
    mean_weight /= stiffness;
    T excess(0.0);
    for (int i = 0; i < modules_; ++i) {
      const double excess_weight = wear_weights_[i] - mean_weight;
      if (excess_weight == 0.0) continue;
      if constexpr (std::is_same_v<T, double>) {
        excess += excess_weight * BodyTwistSolver::module_wear_rate(d.twist, i);
      } else {
        const ModelLinearisation::Point& point = d.linear_points[slot];
        T rate(point.module_wear_rate[i]);
        for (int j = 0; j < 3; ++j) rate.v += point.module_wear_rate_per_twist(j, i) * v[j].v;
        rate.v += point.wear_rate_per_steering[i] * steering_derivatives(d, i) +
                  point.wear_rate_per_wheel_speed[i] * wheel_speed_derivatives(d, i);
        excess += excess_weight * rate;
      }
    }
    return mean_weight * unweighted + h * excess;
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
  // With the wheel speeds as lagged states (drive_lag) each step sees the wheels' mean change, and
  // the same share still applies: the wheels still reach it through the lag inside the step. (A
  // share for a change spread over the step, tau_t / (tau_t + h / 2), was measured against the
  // plant over 0.3 s of small corrections at cruise: 1.2-4.3x its wear, against 0.9-3.4x.)
  T lagged_wear(const T& steady, const T& balance, const Vector3& v0) const noexcept {
    if (drive_lag_ <= 0.0 || nominal_slip_stiffness_sum_ <= 0.0) return balance;
    const T tire_time = tire_time_constant<T>(v0.x(), v0.y());
    const T share = tire_time / (tire_time + drive_lag_);
    return steady + share * (balance - steady);
  }

  // tau_t = m / c of the tyres acting on the body as one damper c = stiffness / |v| (|v| regularised
  // by the slip-speed epsilon), for a body moving at (vx, vy). Needs nominal_slip_stiffness_sum_ > 0.
  template <typename S>
  S tire_time_constant(const S& vx, const S& vy) const noexcept {
    using std::sqrt;
    return mass_ * sqrt(vx * vx + vy * vy + slip_speed_epsilon_ * slip_speed_epsilon_) / slip_stiffness_sum();
  }

  // The tyres' summed slip stiffness on the floor under them: each tyre's share of the nominal sum
  // (its static load's) times its friction scale, since the stiffness B C D grows with D = mu Fz.
  double slip_stiffness_sum() const noexcept {
    return nominal_slip_stiffness_sum_ * model_.load_weighted_friction_scale();
  }

  PredictionOptions options_;
  VehicleModel<T> model_;
  DiscreteDynamics<T> rk4_;
  BodyTwistSolver twist_solver_;
  ModelLinearisation linearisation_;  // the Jet instances' partials per substep
  ModuleLayout layout_;
  Kinematics kinematics_;
  int modules_;
  const ModuleFaults* faults_ = nullptr;  // observe_module_faults (not owned)
  const double* wear_weights_ = nullptr;  // observe_wear_weights (not owned)
  std::vector<double> static_load_shares_;  // VehicleParams::static_load_shares
  bool energy_wear_ = false;
  double wheel_radius_ = 0.0, wear_coefficient_ = 0.0;
  double drive_lag_ = 0.0, mass_ = 0.0, slip_speed_epsilon_ = 0.0;
  double nominal_slip_stiffness_sum_ = 0.0;  // at the tire's own mu (slip_stiffness_sum())
  int lag_states_ = 0;  // n with PredictionOptions::drive_lag on a plant with drive lag, else 0
  int steering_lag_states_ = 0;  // n with PredictionOptions::steering_lag on a plant with steering lag
  DriveLag drive_response_;
  DriveLag steering_response_;  // no acceleration clamp: the plant's steering rate has none
};

}  // namespace swerve
