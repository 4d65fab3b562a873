// Per-module values of the kinematics layer (commanded speed and angle, travelled distance, drive
// acceleration and steering rate) in fixed-capacity arrays, so the per-cycle path never touches the
// heap; plus the status codes every per-cycle kinematics function returns and the angle wrap.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <string>

#include "swerve/core/dcheck.hpp"
#include "swerve/kinematics/module_layout.hpp"

namespace swerve {

// Largest module count the real-time kinematics supports (a 2 x 8 multi-axle carrier). Layouts
// with more modules are rejected when the ModuleLayout is built, so a vehicle config that loads
// can always be driven.
inline constexpr int kMaxModules = 16;

// Status of a per-cycle kinematics call. On anything but kOk the outputs hold a documented safe
// value (never NaN), so a caller that ignores the status still sends something harmless.
enum class KinematicsStatus {
  kOk,
  kNonFiniteInput,     // NaN or inf in a twist, acceleration, module state or limit
  kWrongModuleCount,   // an input array's size differs from the layout's module count
  kInvalidDt,          // dt <= 0 or not finite
  kInvalidLimit,       // a limit that must be > 0 is not
  kInvalidWeight,      // a forward-kinematics weight is negative or not finite
  kRankDeficient,      // the weighted modules cannot determine a 3-dof twist (e.g. all weights 0)
};
// Snake-case word for logs and summaries ("non_finite_input").
const char* to_string(KinematicsStatus status);

// Wraps an angle to (-pi, pi], the interval every interface of SwerveMPC uses. Non-finite input
// gives 0 so a wrap never manufactures NaN downstream (callers check finiteness first).
inline double wrap_angle(double angle) {
  if (!std::isfinite(angle)) return 0.0;
  double wrapped = std::remainder(angle, 2.0 * kPi);  // [-pi, pi]
  if (wrapped <= -kPi) wrapped += 2.0 * kPi;
  return wrapped;
}

// A fixed-capacity array with one entry per module, sized at construction (<= kMaxModules).
template <typename T>
class ModuleArray {
 public:
  ModuleArray() = default;
  explicit ModuleArray(int size, const T& value = T{}) : size_(size) {
    if (size < 0 || size > kMaxModules) {
      throw ConfigError("ModuleArray size = " + std::to_string(size) + ": must be in [0, " +
                        std::to_string(kMaxModules) + "]");
    }
    data_.fill(value);
  }
  // One entry per module, e.g. ModuleStates{{1.0, 0.0}, {1.0, 0.5}}. As with std::vector, braces
  // around a single number list that number: ModuleArray<double>{4} is one module; size with (4).
  ModuleArray(std::initializer_list<T> values) : ModuleArray(static_cast<int>(values.size())) {
    std::copy(values.begin(), values.end(), data_.begin());
  }

  int size() const { return size_; }
  // Sizes the array for `size` modules without allocating; sizes beyond the capacity are a bug.
  void resize(int size) noexcept {
    SWERVE_DCHECK(size >= 0 && size <= kMaxModules);
    size_ = size < 0 ? 0 : (size > kMaxModules ? kMaxModules : size);
  }
  T& operator[](int module) {
    SWERVE_DCHECK(module >= 0 && module < size_);
    return data_[static_cast<std::size_t>(module)];
  }
  const T& operator[](int module) const {
    SWERVE_DCHECK(module >= 0 && module < size_);
    return data_[static_cast<std::size_t>(module)];
  }
  T* begin() { return data_.data(); }
  T* end() { return data_.data() + size_; }
  const T* begin() const { return data_.data(); }
  const T* end() const { return data_.data() + size_; }

 private:
  std::array<T, kMaxModules> data_{};
  int size_ = 0;
};

// A module command or measurement: signed drive speed at the contact patch (m/s) along the wheel
// heading `angle` (rad, body frame, wrapped). A negative speed drives the wheel backwards.
struct ModuleState {
  double speed = 0.0;
  double angle = 0.0;
};

// A module's odometry reading: cumulative signed distance rolled by the wheel (m) and its angle.
struct ModulePosition {
  double distance = 0.0;
  double angle = 0.0;
};

// Second-order module command: rate of change of the signed drive speed (m/s^2) and steering rate
// relative to the body (rad/s), plus the module point's inertial acceleration in the body frame.
struct ModuleAcceleration {
  double drive_acceleration = 0.0;
  double steering_rate = 0.0;
  Eigen::Vector2d acceleration_body = Eigen::Vector2d::Zero();
};

using ModuleStates = ModuleArray<ModuleState>;
using ModulePositions = ModuleArray<ModulePosition>;
using ModuleAccelerations = ModuleArray<ModuleAcceleration>;
using ModuleWeights = ModuleArray<double>;

// One module's command for its low-level drives (the paper's hierarchical design).
struct ModuleCommand {
  double steering_angle = 0.0;  // rad, body frame: the angle the steering should reach this cycle
  double steering_rate = 0.0;   // rad/s
  double wheel_speed = 0.0;     // rad/s of the wheel (signed)
};

}  // namespace swerve
