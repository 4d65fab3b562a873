// The planar dynamic model of an n-module swerve vehicle (n >= 2, set at run time): rigid body in
// the body frame driven by Magic Formula tire forces, per-module steering angles, and optionally
// the plant's actuator lag, saturation, transient slip and load transfer. Templated on the scalar
// (double, swerve::ModelJet); allocation-free and noexcept after construction.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "swerve/kinematics/module_faults.hpp"
#include "swerve/models/magic_formula_tire.hpp"
#include "swerve/models/tire_wear.hpp"
#include "swerve/models/vehicle_params.hpp"

namespace swerve {

// kIdeal: the MPC's model (as in the paper): wheel speed and steering rate follow their commands
// exactly; state = the shared prefix only. kPlant: the simulator's model: adds what
// VehicleParams::plant switches on (lag, saturation, relaxation, load transfer).
enum class Fidelity { kIdeal, kPlant };

enum class ModelStatus {
  kOk,
  kNonFiniteState,    // a NaN or inf in x
  kNonFiniteInput,    // a NaN or inf in u
  kNonFiniteResult,   // the result was not finite (should not happen for finite inputs)
  kInvalidArgument,   // dt <= 0, substeps < 1, or wrong vector sizes
};
const char* to_string(ModelStatus status);  // "ok", "non_finite_state", ...

// The state prefix shared by every fidelity (size 6 + n):
//   [x, y, psi]      pose of the body origin in the world frame (m, m, rad; psi not wrapped)
//   [vx, vy, r]      velocity of the body origin in the body frame (m/s) and yaw rate (rad/s)
//   [delta_1..n]     steering angles (rad, body frame, not wrapped)
struct StateIndex {
  static constexpr int kX = 0;
  static constexpr int kY = 1;
  static constexpr int kPsi = 2;
  static constexpr int kVx = 3;
  static constexpr int kVy = 4;
  static constexpr int kYawRate = 5;
  static constexpr int kFirstSteering = 6;
  static constexpr int steering(int module) { return kFirstSteering + module; }
  static constexpr int prefix_size(int modules) { return kFirstSteering + modules; }
};

// Input u (size 2n), the paper's hierarchical design (docs/paper.md, "MPC inputs"):
//   u[2i] = steering-rate command of module i (rad/s), u[2i+1] = wheel angular speed command (rad/s).
struct InputIndex {
  static constexpr int steering_rate(int module) { return 2 * module; }
  static constexpr int wheel_speed(int module) { return 2 * module + 1; }
  static constexpr int size(int modules) { return 2 * modules; }
};

// Per-module diagnostics of one derivative evaluation.
template <typename T>
struct ModuleDiagnostics {
  T slip_ratio{0.0};             // kappa used for the force (transient value if relaxation is on)
  T slip_angle{0.0};             // alpha, rad
  T normal_load{0.0};            // Fz, N
  T fx_wheel{0.0}, fy_wheel{0.0};  // N, wheel frame
  T fx_body{0.0}, fy_body{0.0};    // N, body frame
  T slip_velocity_x_wheel{0.0}, slip_velocity_y_wheel{0.0};  // m/s, see WheelSlip
  T frictional_power{0.0};       // W
  T wear_rate{0.0};              // wear units per second
};

template <typename T>
class VehicleModel {
 public:
  using Vector = Eigen::Matrix<T, Eigen::Dynamic, 1>;

  // Validates params (throws ConfigError). Sizes are fixed here.
  VehicleModel(const VehicleParams& params, Fidelity fidelity);

  int modules() const { return modules_; }
  int state_size() const { return state_size_; }
  int input_size() const { return 2 * modules_; }
  Fidelity fidelity() const { return fidelity_; }
  const VehicleParams& params() const { return params_; }

  // Indices of the fidelity-dependent states after the prefix, or -1 when absent:
  // [wheel speeds omega_1..n (rad/s) | steering rates delta_dot_1..n (rad/s)]  with actuator lag,
  // then [kappa'_1, alpha'_1, ..., kappa'_n, alpha'_n] (transient slips) with relaxation.
  int wheel_speed_index(int module) const;
  int steering_rate_index(int module) const;
  int transient_slip_ratio_index(int module) const;
  int transient_slip_angle_index(int module) const;

  // The floor's grip under each module from now on: `scales` holds modules() entries, module i's
  // peak friction as a multiple of params().tire's (a wet patch of mu 0.4 on a tire of mu 0.8:
  // 0.5); null: 1 everywhere. Each tire's forces scale with it (D = mu Fz, Pacejka 2012, eq. 4.49:
  // the same curve at a scaled peak), its normal load and the Archard wear's load do not. Wiring
  // like SemiImplicitStep::observe_module_faults: `scales` must outlive the model, and may change
  // between evaluations, never during one.
  void observe_friction_scales(const double* scales) noexcept { friction_scales_ = scales; }
  const double* friction_scales() const noexcept { return friction_scales_; }
  // The modules' friction scales averaged with their static loads as weights: the one scale of the
  // vehicle as a whole (1 without scales).
  double load_weighted_friction_scale() const noexcept {
    if (friction_scales_ == nullptr) return 1.0;
    double total = 0.0, scaled = 0.0;
    for (int i = 0; i < modules_; ++i) {
      total += static_loads_[static_cast<std::size_t>(i)];
      scaled += static_loads_[static_cast<std::size_t>(i)] * friction_scales_[i];
    }
    return total > 0.0 ? scaled / total : 1.0;
  }
  // The modules' faults from now on (null: none). A dead drive's wheel rolls free: its tire takes
  // no longitudinal slip (the wheel spins at its contact's speed), so it gives no Fx and wears
  // only by its lateral slip. A stuck steering is its caller's to hold (the steering-rate input
  // and state), as the plant and the prediction step do. Wiring as observe_friction_scales.
  void observe_module_faults(const ModuleFaults* faults) noexcept { faults_ = faults; }

  // Static normal loads (N), modules then casters (see VehicleParams::static_normal_loads).
  const std::vector<double>& static_normal_loads() const { return static_loads_; }

  // Stiffness of the tire-slip dynamics (the reason the discrete map needs substeps): estimated
  // fastest time constant (s) when the slowest wheel contact moves at `contact_speed` (m/s):
  // tau = max(v, eps) / lambda, lambda the largest eigenvalue of M^-1/2 (sum_i K_i J_i^T J_i) M^-1/2
  // with K_i = mu Fz_i max(Bx Cx, By Cy) (each tire linearised as a damper K_i / v on its contact
  // velocity), J_i = [1 0 -(y_i - c_y); 0 1 x_i - c_x], M = diag(m, m, Iz). Pass 0 for the worst
  // case (a wheel at rest: v -> eps; ~0.33 ms for the paper vehicle).
  double slip_time_constant(double contact_speed) const;
  // Substeps for a step of dt so that h = dt / substeps <= 2 tau (explicit Euler's and RK4's
  // stability limits on the real axis are 2 tau and 2.79 tau).
  int recommended_substeps(double dt, double contact_speed) const;

  // x_dot = f(x, u). Optionally per-module diagnostics (array of modules() entries) and the total
  // wear rate of all modules. Returns kNonFiniteState/kNonFiniteInput (x_dot filled with NaN) for
  // non-finite inputs, kInvalidArgument for wrong sizes. No allocation.
  //   psi_dot = r, [x_dot, y_dot] = R(psi) [vx, vy]
  //   m (vx_dot - r vy_c) = Fx,  m (vy_dot + r vx_c) = Fy   (CoM velocity v_c = v + r x c)
  //   Iz r_dot = sum_i (p_i - c) x F_i
  ModelStatus derivative(const Eigen::Ref<const Vector>& x, const Eigen::Ref<const Vector>& u,
                         Eigen::Ref<Vector> x_dot, ModuleDiagnostics<T>* diagnostics = nullptr,
                         T* total_wear_rate = nullptr) const noexcept;
  // derivative() for a caller that holds the steering angles fixed over many evaluations (the
  // semi-implicit step's Newton solve over the body twist): each module's cos and sin of its
  // steering angle (modules() entries each) are given instead of computed, a sixth of an
  // evaluation's transcendental calls. The angles in x must carry no derivative part.
  ModelStatus derivative_at_steering(const Eigen::Ref<const Vector>& x, const Eigen::Ref<const Vector>& u,
                                     const double* steering_cos, const double* steering_sin, Eigen::Ref<Vector> x_dot,
                                     ModuleDiagnostics<T>* diagnostics, T* total_wear_rate) const noexcept;

  // d[vx_dot, vy_dot, r_dot] / d[fx_body_i, fy_body_i]: how module i's body-frame contact force moves
  // the body's acceleration (the rigid-body equations above are linear in the forces).
  Eigen::Matrix<double, 3, 2> acceleration_per_module_force(int module) const noexcept;

  // A full state from its prefix (size 6 + n): fidelity extras set to pure rolling (wheel speeds
  // matching the contact speed, steering rates and transient slips zero). Allocates (setup only).
  Eigen::VectorXd complete_state(const Eigen::VectorXd& prefix) const;

 private:
  struct ForceSums;
  // steering_cos/sin: as derivative_at_steering, or null (computed from x).
  void module_forces(const T* x, const T* u, int module, const T& fz, const double* steering_cos,
                     const double* steering_sin, ForceSums* sums, ModuleDiagnostics<T>* diag, T* x_dot) const noexcept;
  // The steering rate and wheel speed (rad/s) module `module` applies: its commands (clamped to the
  // limits when saturating) or its lagged actuator states, whose derivatives it writes to x_dot;
  // a steering at an end stop does not move further into it.
  void module_actuators(const T* x, const T* u, int module, T* x_dot, T* steer_rate, T* omega) const noexcept;
  // The casters' rolling resistance added to `sums`, at their static loads or, with `ax_ay` (the
  // body-frame acceleration; null: none), with the load transfer.
  void add_caster_forces(const T* x, const T* ax_ay, ForceSums* sums) const noexcept;
  // kOk when x and u are finite; otherwise x_dot is NaN and the status says which was not.
  ModelStatus check_finite(const T* x, const T* u, Eigen::Ref<Vector> x_dot) const noexcept;

  VehicleParams params_;
  Fidelity fidelity_;
  MagicFormulaTire<T> tire_;
  int modules_;
  int state_size_;
  bool lag_ = false;
  bool saturate_ = false;
  bool relaxation_ = false;
  bool load_transfer_ = false;
  std::vector<double> static_loads_;        // N, modules then casters
  std::vector<double> transfer_per_ax_;     // dFz/d(a_x) (N per m/s^2), modules then casters
  std::vector<double> transfer_per_ay_;     // dFz/d(a_y)
  double slip_rate_per_speed_ = 1.0;        // lambda (1/m), see slip_time_constant
  const double* friction_scales_ = nullptr;  // observe_friction_scales (not owned)
  const ModuleFaults* faults_ = nullptr;     // observe_module_faults (not owned)
};

}  // namespace swerve
