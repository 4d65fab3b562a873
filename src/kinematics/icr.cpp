#include "swerve/kinematics/icr.hpp"

#include <Eigen/Eigenvalues>

#include <cmath>

#include "swerve/kinematics/module_commands.hpp"

namespace swerve {
namespace {

// A rotation component below this (with the twist scaled to unit length) puts the ICR beyond
// 1e9 layout radii: a translation for every practical purpose.
constexpr double kTranslationTolerance = 1e-9;

void fill_centre(const Eigen::Vector3d& twist_scaled, double length, IcrEstimate* icr) {
  const double omega_scaled = twist_scaled.z();
  const Eigen::Vector2d v = twist_scaled.head<2>();
  if (std::abs(omega_scaled) <= kTranslationTolerance * std::max(1.0, v.norm())) {
    icr->at_infinity = true;
    icr->direction_body = v.norm() > 0.0 ? Eigen::Vector2d(v / v.norm()) : Eigen::Vector2d::UnitX();
    icr->center_body.setZero();
  } else {
    const double omega = omega_scaled / length;
    icr->at_infinity = false;
    icr->center_body = Eigen::Vector2d(-v.y() / omega, v.x() / omega);
  }
}

// Fits the twist to the headings of the listed modules and fills errors for them.
KinematicsStatus fit(const Kinematics& kinematics, const ModuleStates& states, const int* modules, int count,
                     IcrEstimate* icr) {
  const ModuleLayout& layout = kinematics.layout();
  double sum_r2 = 0.0;
  for (int k = 0; k < count; ++k) sum_r2 += layout.position_body(modules[k]).squaredNorm();
  const double length = sum_r2 > 0.0 ? std::sqrt(sum_r2 / count) : 1.0;
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  for (int k = 0; k < count; ++k) {
    const double angle = states[modules[k]].angle;
    const Eigen::Vector2d n(-std::sin(angle), std::cos(angle));
    const Eigen::Vector2d& r = layout.position_body(modules[k]);
    // n^T A_i with the rotation column scaled by 1/length.
    const Eigen::Vector3d row(n.x(), n.y(), (n.y() * r.x() - n.x() * r.y()) / length);
    normal += row * row.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(normal);
  const Eigen::Vector3d xi = eigen.eigenvectors().col(0);  // eigenvalues ascend
  fill_centre(xi, length, icr);
  double sum_error2 = 0.0;
  for (int k = 0; k < count; ++k) {
    const int m = modules[k];
    const Eigen::Vector2d& r = layout.position_body(m);
    const Eigen::Vector2d u = point_velocity<double>(xi.x(), xi.y(), xi.z() / length, r);
    double error = 0.0;
    if (u.norm() > 1e-9) {
      const double angle = states[m].angle;
      // Angle from the heading line to u, modulo pi, into (-pi/2, pi/2].
      error = std::atan2(std::cos(angle) * u.y() - std::sin(angle) * u.x(),
                         std::cos(angle) * u.x() + std::sin(angle) * u.y());
      if (error > kPi / 2.0) error -= kPi;
      if (error <= -kPi / 2.0) error += kPi;
    }
    icr->module_error[m] = error;
    sum_error2 += error * error;
  }
  icr->residual = std::sqrt(sum_error2 / count);
  return KinematicsStatus::kOk;
}

bool valid_states(const Kinematics& kinematics, const ModuleStates& states, KinematicsStatus* status) {
  if (states.size() != kinematics.size()) {
    *status = KinematicsStatus::kWrongModuleCount;
    return false;
  }
  for (const ModuleState& s : states) {
    if (!std::isfinite(s.angle)) {
      *status = KinematicsStatus::kNonFiniteInput;
      return false;
    }
  }
  return true;
}

}  // namespace

KinematicsStatus estimate_icr(const Kinematics& kinematics, const ModuleStates& states, IcrEstimate* icr) noexcept {
  *icr = IcrEstimate{};
  KinematicsStatus status = KinematicsStatus::kOk;
  if (!valid_states(kinematics, states, &status)) return status;
  icr->module_error.resize(kinematics.size());
  std::array<int, kMaxModules> modules{};
  for (int i = 0; i < kinematics.size(); ++i) modules[static_cast<std::size_t>(i)] = i;
  return fit(kinematics, states, modules.data(), kinematics.size(), icr);
}

KinematicsStatus pair_icr(const Kinematics& kinematics, const ModuleStates& states, int module_a, int module_b,
                          IcrEstimate* icr) noexcept {
  *icr = IcrEstimate{};
  KinematicsStatus status = KinematicsStatus::kOk;
  if (!valid_states(kinematics, states, &status)) return status;
  const int n = kinematics.size();
  if (module_a < 0 || module_a >= n || module_b < 0 || module_b >= n || module_a == module_b) {
    return KinematicsStatus::kWrongModuleCount;
  }
  icr->module_error.resize(n);
  const int modules[2] = {module_a, module_b};
  return fit(kinematics, states, modules, 2, icr);
}

IcrEstimate icr_of_twist(const Eigen::Vector3d& twist_body) noexcept {
  IcrEstimate icr;
  fill_centre(twist_body, 1.0, &icr);
  return icr;
}

}  // namespace swerve
