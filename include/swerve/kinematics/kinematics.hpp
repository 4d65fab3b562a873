// Swerve kinematics for any layout of >= 2 steered-and-driven modules: chassis twist <-> module
// states (first order), chassis acceleration <-> module drive acceleration and steering rate
// (second order), and the module-command chain (desaturate, singularity hold, flip optimisation).
// Stateless after construction; the remembered headings live in ModuleHeadingMemory.
//
// Twists are (vx, vy, omega) of the reference point, the origin of the layout's body frame: the
// point forward kinematics always reports. A centre of rotation passed to inverse kinematics only
// says which body point moves with (vx, vy); it never changes what forward kinematics returns.
#pragma once

#include <Eigen/Core>

#include <optional>

#include "swerve/core/option_fields.hpp"
#include "swerve/kinematics/module_commands.hpp"
#include "swerve/kinematics/module_heading_memory.hpp"
#include "swerve/kinematics/module_layout.hpp"
#include "swerve/kinematics/module_state.hpp"

namespace swerve {

struct KinematicsOptions {
  // m/s. A module slower than this keeps its remembered heading (its direction would be noise).
  double hold_speed_threshold = kHoldSpeed;
  // rad, half-width of the band around 90 deg of steering error inside which a module keeps its
  // previous forward/reversed decision. 0.1 rad is ~10x typical steering-encoder noise and costs
  // at most 6 deg of extra steering.
  double flip_hysteresis = 0.1;
  // Flip all modules together (decided on their mean steering error) so every wheel drives the
  // same way round, instead of deciding per module.
  bool whole_robot_flip = false;
  // Scale each commanded speed by cos(commanded - measured angle) when measured angles are given,
  // so a module still steering does not push sideways (clamped at 0 beyond 90 deg).
  bool cosine_scaling = true;

  static const OptionFields<KinematicsOptions>& fields();  // the rules, read by the YAML loader too
  // Throws ConfigError naming the field and value.
  void validate() const;
};

// What desaturate_twist keeps when the twist asks more than the drive limit allows.
enum class DesaturationPriority {
  kProportional,     // scale translation and rotation together (direction of the twist kept)
  kKeepRotation,     // shrink translation first; rotation only if rotation alone is too fast
  kKeepTranslation,  // shrink rotation first; translation only if translation alone is too fast
};

class Kinematics {
 public:
  // Throws ConfigError when the layout has more than kMaxModules modules or options are invalid.
  explicit Kinematics(ModuleLayout layout, KinematicsOptions options = KinematicsOptions{});

  int size() const { return size_; }
  const ModuleLayout& layout() const { return layout_; }
  const KinematicsOptions& options() const { return options_; }
  // True when forward kinematics uses the closed form of a layout centred on its reference point
  // (identical to the least-squares solution there; see forward()).
  bool uses_closed_form() const { return centred_; }

  // ---- first order -----------------------------------------------------------------------------
  // Raw inverse kinematics: each module's velocity v + omega x (r_i - c), with c the centre of
  // rotation and (vx, vy) the velocity of c; reported as speed >= 0 and its direction (angle 0 for
  // a zero velocity). On error: all modules {0, 0}.
  KinematicsStatus inverse(const Eigen::Vector3d& twist_body, ModuleStates* states,
                           const Eigen::Vector2d& center_of_rotation_body = Eigen::Vector2d::Zero()) const noexcept;

  // By value, for code off the real-time path (no allocation either): nullopt on error.
  std::optional<ModuleStates> inverse(const Eigen::Vector3d& twist_body,
                                      const Eigen::Vector2d& center_of_rotation_body = Eigen::Vector2d::Zero()) const;

  // The command chain for hardware: inverse -> desaturate to limits().max_drive_speed (the
  // layout's limit: ModuleLayout's default is 2 m/s, so give yours; inverse() never desaturates) ->
  // singularity hold -> optimize (which records the result in *memory). `measured` (optional,
  // may be null) supplies current module angles for the flip decision and cosine scaling; without
  // it the remembered headings stand in. On error: zero speeds at the remembered headings.
  KinematicsStatus command(const Eigen::Vector3d& twist_body, ModuleHeadingMemory* memory, ModuleStates* states,
                           const Eigen::Vector2d& center_of_rotation_body = Eigen::Vector2d::Zero(),
                           const ModuleStates* measured = nullptr) const noexcept;

  // Singularity hold: every module with |speed| < hold_speed_threshold takes its remembered
  // heading and the projection of its velocity on it (so it never jumps and never carries NaN).
  KinematicsStatus hold_singular(const ModuleHeadingMemory& memory, ModuleStates* states) const noexcept;

  // Chooses per module (or for the whole robot) between (theta, v) and (theta + pi, -v) to
  // minimise steering from the current angle, keeping the previous choice while the steering
  // error stays within 90 deg +- flip_hysteresis and never turning past an end stop
  // (choose_drive_direction); then cosine scaling; records into *memory. Modules below the hold
  // threshold are left as they are.
  KinematicsStatus optimize(ModuleHeadingMemory* memory, ModuleStates* states,
                            const ModuleStates* measured = nullptr) const noexcept;

  // Ratio-preserving desaturation: if any |speed| exceeds max_speed, every speed is scaled by the
  // same factor (signs kept). kInvalidLimit for max_speed <= 0 (states untouched).
  static KinematicsStatus desaturate(double max_speed, ModuleStates* states) noexcept;

  // Translation/rotation-aware desaturation on the twist itself: the largest twist within the
  // drive limit that keeps what `priority` names (exactly, where possible). On error: zero twist.
  KinematicsStatus desaturate_twist(const Eigen::Vector3d& twist_body, double max_module_speed,
                                    DesaturationPriority priority, Eigen::Vector3d* twist_out,
                                    const Eigen::Vector2d& center_of_rotation_body = Eigen::Vector2d::Zero()) const
      noexcept;

  // Forward kinematics: the least-squares twist of the reference point from module velocities,
  // min sum_i w_i |A_i xi - u_i|^2 with A_i = [1 0 -y_i; 0 1 x_i]. The unweighted form uses the
  // pseudo-inverse factored at construction (or its closed form on centred layouts); the weighted
  // form solves the 3x3 normal equations per call. On error: zero twist.
  KinematicsStatus forward(const ModuleStates& states, Eigen::Vector3d* twist_body) const noexcept;
  std::optional<Eigen::Vector3d> forward(const ModuleStates& states) const;  // by value; nullopt on error
  KinematicsStatus forward(const ModuleStates& states, const ModuleWeights& weights,
                           Eigen::Vector3d* twist_body) const noexcept;
  // The same on wheel-distance increments: returns the body displacement (dx, dy, dpsi) to feed
  // to se2_exp. `deltas[i].distance` is the distance rolled since the last call.
  KinematicsStatus forward_delta(const ModulePositions& deltas, Eigen::Vector3d* delta_body) const noexcept;
  KinematicsStatus forward_delta(const ModulePositions& deltas, const ModuleWeights& weights,
                                 Eigen::Vector3d* delta_body) const noexcept;

  // ---- second order ----------------------------------------------------------------------------
  // `acceleration_body` = (ax, ay, alpha): the inertial acceleration of the reference point
  // expressed in the body frame, and the angular acceleration. Each module point then accelerates
  // by a_i = a + alpha x r_i - omega^2 r_i (rigid-body kinematics), and its body-frame velocity
  // u_i changes by u_i' = a_i - omega x u_i. With h_i the unit vector of states[i].angle (only the
  // angles of `states` are used, so flipped and held modules are handled):
  //   drive_acceleration = h_i . u_i'
  //   steering_rate      = (u_i x u_i') / |u_i|^2     (exact d/dt atan2(u_i), body-relative)
  // For |u_i| below hold_speed_threshold (eps) the steering rate is (u_i x u_i') / eps^2: it ramps
  // linearly to 0 at standstill and is continuous at eps, so v -> 0 gives no NaN and no division
  // by zero. A pure spin at constant rate gives centripetal a_i != 0 but zero drive acceleration
  // and steering rate. On error: all zeros.
  // With a centre of rotation c, twist and acceleration are those of the body point c (as in
  // inverse()), and r_i is measured from c.
  KinematicsStatus second_order(const Eigen::Vector3d& twist_body, const Eigen::Vector3d& acceleration_body,
                                const ModuleStates& states, ModuleAccelerations* accelerations,
                                const Eigen::Vector2d& center_of_rotation_body = Eigen::Vector2d::Zero()) const
      noexcept;

  // Inverse of second_order: the least-squares (ax, ay, alpha) from module drive accelerations and
  // steering rates at module states `states` (signed speeds and angles; omega comes from forward
  // kinematics of `states`). On error: zero.
  KinematicsStatus chassis_acceleration(const ModuleStates& states, const ModuleAccelerations& accelerations,
                                        Eigen::Vector3d* acceleration_body) const noexcept;

  // (ax, ay, alpha) as second_order wants it from the body-frame rates of the twist
  // (d/dt of vx, vy, omega as a dynamic model integrates them): a = v' + omega x v.
  static Eigen::Vector3d inertial_acceleration(const Eigen::Vector3d& twist_body,
                                               const Eigen::Vector3d& twist_rate_body) noexcept;

 private:
  struct Directions {  // unit direction of each moving module's raw velocity
    std::array<double, kMaxModules> cos;
    std::array<double, kMaxModules> sin;
  };
  // The flip decision, cosine scaling and memory update shared by command() and optimize();
  // moving modules of *states hold speed >= threshold along `directions`, the rest are held.
  void choose_flips(ModuleHeadingMemory* memory, ModuleStates* states, const Directions& directions,
                    const ModuleStates* measured) const noexcept;
  // Module velocity in the body frame for a twist about centre c.
  Eigen::Vector2d module_velocity(int module, const Eigen::Vector3d& twist_body, const Eigen::Vector2d& c) const {
    return point_velocity<double>(twist_body, positions_[static_cast<std::size_t>(module)] - c);
  }
  // Least squares with the precomputed factorisation; `u` holds 2N stacked module vectors.
  Eigen::Vector3d solve_unweighted(const double* u) const noexcept;
  KinematicsStatus solve_weighted(const double* u, const ModuleWeights& weights, Eigen::Vector3d* xi) const noexcept;

  ModuleLayout layout_;
  KinematicsOptions options_;
  int size_;
  std::array<Eigen::Vector2d, kMaxModules> positions_{};
  // (A^T A)^-1 A^T, 3 x 2N, stored with fixed capacity so no call allocates.
  Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor, 3, 2 * kMaxModules> pseudo_inverse_;
  bool centred_ = false;
  double inv_sum_r2_ = 0.0;  // 1 / sum |r_i|^2, the closed form's rotation gain
  double inv_count_ = 0.0;
  double length_scale_ = 1.0;  // RMS module radius, for scale-free rank tests
};

// One module on its own (WPILib's SwerveModuleState::optimize): `desired`, or the same motion as
// (angle + pi, -speed) when that needs less steering from `current_angle` (more than 90 deg away;
// exactly 90 deg keeps `desired`). Angles wrapped. No memory and no hysteresis: a module near 90
// deg may flip back and forth, which Kinematics::optimize with a ModuleHeadingMemory prevents.
ModuleState optimize_module(const ModuleState& desired, double current_angle) noexcept;

}  // namespace swerve
