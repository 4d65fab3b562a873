#include "swerve/mpc/vehicle_prediction_model.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <sstream>

#include "swerve/config/config_error.hpp"
#include "swerve/kinematics/se2.hpp"

namespace swerve {
namespace {

constexpr double kSlowSpeed = 0.25;  // m/s: 5 slip-regularisation speeds of the paper's tire

}  // namespace

const char* to_string(PredictionMethod method) noexcept {
  return method == PredictionMethod::kSemiImplicit ? "semi_implicit" : "rk4";
}

void PredictionOptions::validate() const {
  auto reject = [](const char* field, int value, const char* rule) {
    std::ostringstream message;
    message << "PredictionOptions." << field << " = " << value << ": " << rule;
    throw ConfigError(message.str());
  };
  if (substeps < 1) reject("substeps", substeps, "must be >= 1");
  if (slow_substeps < 1) reject("slow_substeps", slow_substeps, "must be >= 1");
  if (max_newton_iterations < 1) reject("max_newton_iterations", max_newton_iterations, "must be >= 1");
}

VehiclePredictionModel::VehiclePredictionModel(const VehicleParams& params, PredictionOptions options)
    : options_(options), model_(params, Fidelity::kIdeal), rk4_(model_, IntegratorMethod::kRk4),
      modules_(model_.modules()), state_size_(model_.state_size()), input_size_(model_.input_size()) {
  options_.validate();
  const ModuleLimits& limits = params.layout.limits();
  min_angle_ = Eigen::VectorXd::Constant(modules_, limits.min_steering_angle);
  max_angle_ = Eigen::VectorXd::Constant(modules_, limits.max_steering_angle);
  u_applied_ = Eigen::VectorXd::Zero(input_size_);
  trial_state_ = Eigen::VectorXd::Zero(state_size_);
  state_dot_ = Eigen::VectorXd::Zero(state_size_);
  substep_state_ = Eigen::VectorXd::Zero(state_size_);
  diagnostics_.resize(static_cast<std::size_t>(modules_));
  energy_wear_ = params.casters.empty() && params.wear.model == WearModelKind::kFrictionalPower;
  wheel_radius_ = params.layout.wheel_radius();
}

double VehiclePredictionModel::kinetic_energy(const Eigen::Vector3d& v) const noexcept {
  const VehicleParams& p = model_.params();
  const Eigen::Vector2d& c = p.center_of_mass_body;
  const double vcx = v.x() - v.z() * c.y();
  const double vcy = v.y() + v.z() * c.x();
  return 0.5 * p.mass * (vcx * vcx + vcy * vcy) + 0.5 * p.yaw_inertia * v.z() * v.z();
}

bool VehiclePredictionModel::body_acceleration(const Eigen::Vector3d& v, Eigen::Vector3d* acceleration,
                                               double* wear_rate) const noexcept {
  trial_state_.segment<3>(StateIndex::kVx) = v;
  if (model_.derivative(trial_state_, u_applied_, state_dot_, nullptr, wear_rate) != ModelStatus::kOk) return false;
  *acceleration = state_dot_.segment<3>(StateIndex::kVx);
  return acceleration->allFinite();
}

bool VehiclePredictionModel::semi_implicit_substep(const Eigen::Ref<const Eigen::VectorXd>& x, double h,
                                                   Eigen::Ref<Eigen::VectorXd> x_next, double* wear) const noexcept {
  // Steering advances explicitly under the (already end-stop-clipped) rate.
  trial_state_ = x;
  for (int i = 0; i < modules_; ++i) {
    trial_state_[StateIndex::steering(i)] = x[StateIndex::steering(i)] + h * u_applied_[InputIndex::steering_rate(i)];
  }
  // Backward Euler on the body twist: G(v) = v - v0 - h a(v) = 0, Newton with a forward-difference
  // Jacobian and step halving, from the explicit prediction.
  const Eigen::Vector3d v0 = x.segment<3>(StateIndex::kVx);
  Eigen::Vector3d v = v0, a, a_probe;
  double wear_rate = 0.0;
  if (!body_acceleration(v, &a, &wear_rate)) return false;
  Eigen::Vector3d residual = v - v0 - h * a;
  for (int iteration = 0; iteration < options_.max_newton_iterations && residual.norm() > 1e-10; ++iteration) {
    Eigen::Matrix3d jacobian;
    for (int j = 0; j < 3; ++j) {
      Eigen::Vector3d probe = v;
      const double delta = 1e-6 * (1.0 + std::abs(v[j]));
      probe[j] += delta;
      if (!body_acceleration(probe, &a_probe, nullptr)) return false;
      jacobian.col(j) = Eigen::Vector3d::Unit(j) - h * (a_probe - a) / delta;
    }
    const Eigen::Vector3d newton_step = jacobian.partialPivLu().solve(-residual);
    double scale = 1.0;
    for (int halving = 0; halving < 6; ++halving, scale *= 0.5) {
      const Eigen::Vector3d trial = v + scale * newton_step;
      Eigen::Vector3d trial_a;
      if (!body_acceleration(trial, &trial_a, nullptr)) continue;
      const Eigen::Vector3d trial_residual = trial - v0 - h * trial_a;
      if (trial_residual.norm() < residual.norm() || halving == 5) {
        v = trial;
        a = trial_a;
        residual = trial_residual;
        break;
      }
    }
  }
  if (!body_acceleration(v, &a, &wear_rate)) return false;
  double step_wear = h * wear_rate;
  if (energy_wear_) {
    // Forces at v+ (the implicit step's) for the drives' work; see the header for why.
    trial_state_.segment<3>(StateIndex::kVx) = v;
    if (model_.derivative(trial_state_, u_applied_, state_dot_, diagnostics_.data()) != ModelStatus::kOk) return false;
    const VehicleParams& p = model_.params();
    double drive_work = 0.0;
    for (int i = 0; i < modules_; ++i) {
      drive_work += h * diagnostics_[static_cast<std::size_t>(i)].fx_wheel * p.layout.wheel_radius() *
                    u_applied_[InputIndex::wheel_speed(i)];
    }
    const double dissipated = drive_work - (kinetic_energy(v) - kinetic_energy(v0));
    step_wear = p.wear.coefficient * std::max(0.0, dissipated);
  }
  // Pose: the body moves with the constant twist v over h (exact on arcs).
  const Eigen::Vector3d pose = compose_pose(x.head<3>(), h * v);
  x_next = trial_state_;
  x_next.head<3>() = pose;
  x_next.segment<3>(StateIndex::kVx) = v;
  if (wear != nullptr) *wear += step_wear;
  return x_next.allFinite();
}

bool VehiclePredictionModel::step(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                                  double dt, Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept {
  if (x.size() != state_size_ || u.size() != input_size_ || x_next.size() != state_size_ || !(dt > 0.0) ||
      !x.allFinite() || !u.allFinite()) {
    return false;
  }
  // End stops: the steering rate is clipped so the angle stays inside the module's range.
  u_applied_ = u;
  for (int i = 0; i < modules_; ++i) {
    const double angle = x[StateIndex::steering(i)];
    const int rate = InputIndex::steering_rate(i);
    u_applied_[rate] = std::min(std::max(u_applied_[rate], (min_angle_[i] - angle) / dt), (max_angle_[i] - angle) / dt);
  }
  double wear = 0.0;
  bool ok = true;
  if (options_.method == PredictionMethod::kRk4) {
    ok = rk4_.step(x, u_applied_, dt, options_.substeps, x_next, &wear) == ModelStatus::kOk;
  } else {
    // Slow motion (body and every commanded contact speed under 0.25 m/s) is where one implicit
    // step per controller step mispredicts wear most; there it takes more, shorter steps.
    double fastest = x.segment<2>(StateIndex::kVx).norm();
    for (int i = 0; i < modules_; ++i) {
      fastest = std::max(fastest, std::abs(u_applied_[InputIndex::wheel_speed(i)]) * wheel_radius_);
    }
    const int substeps = fastest < kSlowSpeed ? std::max(options_.substeps, options_.slow_substeps) : options_.substeps;
    const double h = dt / substeps;
    substep_state_ = x;
    for (int s = 0; s < substeps && ok; ++s) {
      ok = semi_implicit_substep(substep_state_, h, x_next, &wear);
      substep_state_ = x_next;
    }
  }
  if (stage_wear != nullptr) *stage_wear = wear;
  return ok && std::isfinite(wear);
}

}  // namespace swerve
