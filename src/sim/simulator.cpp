#include "swerve/sim/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "swerve/core/config_error.hpp"
#include "swerve/core/random.hpp"

namespace swerve {
namespace {

// The owner every rule of this file names (throw_invalid_field: "<owner>.<field> = <value>: <rule>").
constexpr const char* kOwner = "SimulatorOptions";

std::string corner_text(const Eigen::Vector2d& corner) {
  std::ostringstream text;
  text << '[' << corner.x() << ", " << corner.y() << ']';
  return text.str();
}

}  // namespace

const OptionFields<MeasurementNoise>& MeasurementNoise::fields() {
  static const OptionFields<MeasurementNoise> table = {
      {"position", &MeasurementNoise::position, Bound::non_negative(), {}, nullptr, "(m)"},
      {"heading", &MeasurementNoise::heading, Bound::non_negative(), {}, nullptr, "(rad)"},
      {"velocity", &MeasurementNoise::velocity, Bound::non_negative(), {}, nullptr, "(m/s)"},
      {"yaw_rate", &MeasurementNoise::yaw_rate, Bound::non_negative(), {}, nullptr, "(rad/s)"},
      {"steering_angle", &MeasurementNoise::steering_angle, Bound::non_negative(), {}, nullptr, "(rad)"},
  };
  return table;
}

const OptionFields<SimulatorOptions>& SimulatorOptions::fields() {
  static const OptionFields<SimulatorOptions> table = {
      // 0: automatic (VehicleModel::recommended_substeps).
      {"substeps", &SimulatorOptions::substeps, Bound::closed(0, 100000)},
      // Periods of delay; the delay line holds this many measurements, so it is kept to a size a
      // scenario means (100 periods: seconds at any control rate).
      {"measurement_delay_steps", &SimulatorOptions::measurement_delay_steps, Bound::closed(0, 100)},
  };
  return table;
}

void SimulatorOptions::validate() const {
  if (!std::isfinite(control_period) || control_period <= 0.0) throw_invalid_field(kOwner, "control_period", control_period, "must be > 0");
  for (std::size_t f = 0; f < faults.size(); ++f) {
    const std::string field = "faults[" + std::to_string(f) + "]";
    if (faults[f].module < 0 || faults[f].module >= kMaxModules) {
      throw_invalid_field(kOwner, field + ".module", faults[f].module, "must name a module of the vehicle");
    }
    if (!std::isfinite(faults[f].at) || faults[f].at < 0.0) throw_invalid_field(kOwner, field + ".at", faults[f].at, "must be >= 0 (s)");
    if (faults[f].kind == ModuleFault::kNone) {
      throw_invalid_field(kOwner, field + ".kind", to_string(faults[f].kind),
                          "must be stuck_steering, dead_drive or steering_sensor_lost");
    }
  }
  for (std::size_t p = 0; p < friction_patches.size(); ++p) {
    const std::string field = "friction_patches[" + std::to_string(p) + "]";
    const FrictionPatch& patch = friction_patches[p];
    if (!std::isfinite(patch.mu) || patch.mu <= 0.0) throw_invalid_field(kOwner, field + ".mu", patch.mu, "must be finite and > 0");
    if (!patch.min_world.allFinite() || !patch.max_world.allFinite() || !patch.corners_in_order()) {
      throw_invalid_field(kOwner, field + ".max", corner_text(patch.max_world),
                          "must be finite and greater than min = " + corner_text(patch.min_world) + " in x and y (m)");
    }
    for (std::size_t q = 0; q < p; ++q) {
      if (patch.overlaps(friction_patches[q])) {
        throw_invalid_field(kOwner, field, corner_text(patch.min_world) + " to " + corner_text(patch.max_world),
                            "overlaps friction_patches[" + std::to_string(q) + "] (patches may touch, not overlap)");
      }
    }
  }
  for (std::size_t i = 0; i < initial_module_wear.size(); ++i) {
    if (!std::isfinite(initial_module_wear[i]) || initial_module_wear[i] < 0.0) {
      throw_invalid_field(kOwner, "initial_module_wear[" + std::to_string(i) + "]", initial_module_wear[i],
                          "must be finite and >= 0 (wear units)");
    }
  }
  check_fields("SimulatorOptions", *this, fields());
  check_fields("SimulatorOptions.noise", noise, MeasurementNoise::fields());
}

Simulator::Simulator(const VehicleParams& vehicle, SimulatorOptions options)
    : options_(options), model_(vehicle, Fidelity::kPlant), dynamics_(model_, IntegratorMethod::kRk4),
      dynamics_data_(dynamics_) {
  options_.validate();
  substeps_ = options_.substeps > 0 ? options_.substeps : model_.recommended_substeps(options_.control_period, 0.0);
  // A patch that grips more than the tire's mu stiffens the slip dynamics in proportion (the slip
  // stiffness B C D grows with D = mu Fz): the automatic substeps grow with it.
  double grip = 1.0;
  for (std::size_t p = 0; p < options_.friction_patches.size(); ++p) {
    const double scale = options_.friction_patches[p].mu / vehicle.tire.mu;
    if (scale > 10.0) {
      throw_invalid_field(kOwner, "friction_patches[" + std::to_string(p) + "].mu", options_.friction_patches[p].mu,
                          "must be at most 10x the tire's mu (" + std::to_string(vehicle.tire.mu) + ")");
    }
    grip = std::max(grip, scale);
  }
  if (options_.substeps == 0) substeps_ = static_cast<int>(std::ceil(substeps_ * grip));
  const int n = model_.modules();
  if (!options_.initial_module_wear.empty() && static_cast<int>(options_.initial_module_wear.size()) != n) {
    throw_invalid_field(kOwner, "initial_module_wear.size", static_cast<int>(options_.initial_module_wear.size()),
                        "must be the vehicle's module count, " + std::to_string(n));
  }
  state_ = next_state_ = state_dot_ = Eigen::VectorXd::Zero(model_.state_size());
  input_ = Eigen::VectorXd::Zero(model_.input_size());
  measurement_ = Eigen::VectorXd::Zero(StateIndex::prefix_size(n));
  diagnostics_.resize(static_cast<std::size_t>(n));
  module_wear_.assign(static_cast<std::size_t>(n), 0.0);
  step_module_wear_.assign(static_cast<std::size_t>(n), 0.0);
  period_module_wear_.assign(static_cast<std::size_t>(n), 0.0);
  samples_.resize(static_cast<std::size_t>(n));
  active_faults_ = ModuleFaults(n, ModuleFault::kNone);
  friction_scales_.assign(static_cast<std::size_t>(n), 1.0);
  model_.observe_module_faults(&active_faults_);  // a dead drive's wheel rolls free
  if (!options_.friction_patches.empty()) model_.observe_friction_scales(friction_scales_.data());
  for (std::size_t f = 0; f < options_.faults.size(); ++f) {
    if (options_.faults[f].module >= n) {
      throw_invalid_field(kOwner, "faults[" + std::to_string(f) + "].module", options_.faults[f].module,
                          "must name a module of the vehicle, 0 to " + std::to_string(n - 1));
    }
  }
}

void Simulator::apply_faults() noexcept {
  for (const PlantFault& fault : options_.faults) {
    if (!fault.due_by(time_) || active_faults_[fault.module] == fault.kind) continue;
    active_faults_[fault.module] = fault.kind;
    // The steering stops where it is: its rate state too, not only the commands from now on.
    const int rate = model_.steering_rate_index(fault.module);
    if (rate >= 0) state_[rate] = 0.0;
  }
  for (int i = 0; i < model_.modules(); ++i) {
    if (steering_stuck(&active_faults_, i)) input_[InputIndex::steering_rate(i)] = 0.0;
  }
}

void Simulator::update_friction(const Eigen::VectorXd& state) noexcept {
  if (options_.friction_patches.empty()) return;
  const double c = std::cos(state[StateIndex::kPsi]), s = std::sin(state[StateIndex::kPsi]);
  const Eigen::Vector2d origin_world(state[StateIndex::kX], state[StateIndex::kY]);
  const double tire_mu = model_.params().tire.mu;
  for (int i = 0; i < model_.modules(); ++i) {
    const Eigen::Vector2d& p = model_.params().layout.position_body(i);
    const Eigen::Vector2d contact_world = origin_world + Eigen::Vector2d(c * p.x() - s * p.y(), s * p.x() + c * p.y());
    double scale = 1.0;
    for (const FrictionPatch& patch : options_.friction_patches) {
      if (patch.contains(contact_world)) scale = patch.mu / tire_mu;
    }
    friction_scales_[static_cast<std::size_t>(i)] = scale;
  }
}

void Simulator::reset(const Eigen::VectorXd& initial_prefix) {
  const int n = model_.modules();
  if (initial_prefix.size() != StateIndex::prefix_size(n) || !initial_prefix.allFinite()) {
    std::ostringstream message;
    message << "Simulator.initial_state: expected " << StateIndex::prefix_size(n)
            << " finite values (pose, twist, steering angles), got " << initial_prefix.size()
            << (initial_prefix.allFinite() ? "" : " with NaN/inf");
    throw ConfigError(message.str());
  }
  state_ = model_.complete_state(initial_prefix);
  time_ = 0.0;
  frictional_energy_ = 0.0;
  std::fill(module_wear_.begin(), module_wear_.end(), 0.0);
  for (int i = 0; i < n; ++i) active_faults_[i] = ModuleFault::kNone;
  input_.setZero();
  for (int i = 0; i < n; ++i) {  // hold the initial wheel speeds until the first command
    const int index = model_.wheel_speed_index(i);
    if (index >= 0) input_[InputIndex::wheel_speed(i)] = state_[index];
  }
  rng_state_ = options_.seed;
  update_friction(state_);
  delayed_.clear();
  update_measurement();
  refresh_samples();
}

double Simulator::gaussian() noexcept {
  // Box-Muller on our own generator: the same numbers on every platform and standard library.
  const double u1 = (static_cast<double>(splitmix64(&rng_state_) >> 11) + 0.5) * 0x1.0p-53;  // (0, 1)
  const double u2 = unit_interval(splitmix64(&rng_state_));
  return box_muller(u1, u2).first;
}

void Simulator::update_measurement() noexcept {
  const int n = model_.modules();
  const Eigen::VectorXd truth = state_.head(StateIndex::prefix_size(n));
  // A fixed-length queue after the first call: the real-time loop allocates only while filling it.
  delayed_.push_back(truth);
  while (static_cast<int>(delayed_.size()) > options_.measurement_delay_steps + 1) delayed_.pop_front();
  measurement_ = delayed_.front();
  const MeasurementNoise& noise = options_.noise;
  const double sigma[6] = {noise.position, noise.position, noise.heading, noise.velocity, noise.velocity, noise.yaw_rate};
  for (int i = 0; i < 6; ++i) {
    if (sigma[i] > 0.0) measurement_[i] += sigma[i] * gaussian();
  }
  if (noise.steering_angle > 0.0) {
    for (int i = 0; i < n; ++i) measurement_[StateIndex::steering(i)] += noise.steering_angle * gaussian();
  }
  for (int i = 0; i < n; ++i) {  // a lost encoder reports nothing a number could mean
    if (active_faults_[i] == ModuleFault::kSteeringSensorLost) {
      measurement_[StateIndex::steering(i)] = std::numeric_limits<double>::quiet_NaN();
    }
  }
}

void Simulator::refresh_samples() noexcept {
  model_.derivative(state_, input_, state_dot_, diagnostics_.data());
  for (int i = 0; i < model_.modules(); ++i) {
    const auto m = static_cast<std::size_t>(i);
    const ModuleDiagnostics<double>& d = diagnostics_[m];
    PlantModuleSample& s = samples_[m];
    s.steering_angle = state_[StateIndex::steering(i)];
    const int wheel = model_.wheel_speed_index(i);
    s.wheel_speed = wheel >= 0 ? state_[wheel] : input_[InputIndex::wheel_speed(i)];
    s.slip_angle = d.slip_angle;
    s.slip_ratio = d.slip_ratio;
    s.fx_wheel = d.fx_wheel;
    s.fy_wheel = d.fy_wheel;
    s.wear_rate = d.wear_rate;
    s.wear = module_wear_[m];
  }
}

bool Simulator::advance(const ModuleArray<ModuleCommand>& commands) noexcept {
  const int n = model_.modules();
  if (commands.size() != n) return false;
  for (int i = 0; i < n; ++i) {
    input_[InputIndex::steering_rate(i)] = commands[i].steering_rate;
    input_[InputIndex::wheel_speed(i)] = commands[i].wheel_speed;
  }
  if (!input_.allFinite()) return false;
  apply_faults();
  const double h = options_.control_period / substeps_;
  double energy = 0.0;
  std::fill(period_module_wear_.begin(), period_module_wear_.end(), 0.0);
  next_state_ = state_;
  for (int s = 0; s < substeps_; ++s) {
    update_friction(next_state_);  // the grip under each contact at the substep's start
    // Frictional energy by the rectangle rule on the substep grid (it is a report, not a state).
    model_.derivative(next_state_, input_, state_dot_, diagnostics_.data());
    for (int i = 0; i < n; ++i) energy += h * diagnostics_[static_cast<std::size_t>(i)].frictional_power;
    state_dot_ = next_state_;  // reuse as the substep's start state (x_next may not alias x)
    if (dynamics_.step(dynamics_data_, state_dot_, input_, h, 1, next_state_, nullptr, step_module_wear_.data()) !=
            ModelStatus::kOk ||
        !next_state_.allFinite()) {
      return false;
    }
    for (int i = 0; i < n; ++i) {
      const auto m = static_cast<std::size_t>(i);
      period_module_wear_[m] += step_module_wear_[m];
    }
  }
  for (int i = 0; i < n; ++i) module_wear_[static_cast<std::size_t>(i)] += period_module_wear_[static_cast<std::size_t>(i)];
  state_ = next_state_;
  update_friction(state_);
  frictional_energy_ += energy;
  time_ += options_.control_period;
  update_measurement();
  refresh_samples();
  return true;
}

}  // namespace swerve
