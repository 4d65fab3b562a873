// Time-parameterised reference trajectories: desired pose_world (x, y, psi) and body twist
// (vx, vy, r) at any time, sampled into the controller's window. Geometric paths are followed at a
// trapezoidal speed profile by arc length, and twists come from the path's analytic derivatives,
// so integrating the twist reproduces the pose (no finite differences anywhere).
#pragma once

#include <Eigen/Core>

#include <array>
#include <atomic>
#include <cstddef>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "swerve/kinematics/module_state.hpp"  // wrap_angle

namespace swerve {

struct ReferenceSample {
  Eigen::Vector3d pose_world = Eigen::Vector3d::Zero();  // x, y, psi (psi wrapped to (-pi, pi])
  Eigen::Vector3d twist_body = Eigen::Vector3d::Zero();  // vx, vy (desired body frame), r
};

class Reference {
 public:
  virtual ~Reference() = default;
  // On [0, duration()] the reference moves; after it, it holds its final pose with zero twist (a
  // window that runs off the end asks the vehicle to stop there), except a PathReference that ends at
  // speed, which goes on at its final twist; before 0 it holds the start pose. noexcept, no
  // allocation.
  virtual ReferenceSample sample(double t) const noexcept = 0;
  virtual double duration() const noexcept = 0;
  // Called by a controller at the start of each cycle, before it samples its window: a reference
  // that a planner replaces while the controller runs (TrajectoryReference) takes up the newest
  // version here, so one cycle's window never mixes two trajectories. noexcept, no allocation.
  virtual void begin_cycle() const noexcept {}
  // Whether the reference can be followed at cycle time t; a reason (static text) when it cannot,
  // and the controller then stops safely. nullptr: usable.
  virtual const char* unusable(double /*t*/) const noexcept { return nullptr; }
};

// A planar curve p(u), u in [0, u_end], with its first two derivatives (for tangent and curvature).
class PlanarCurve {
 public:
  virtual ~PlanarCurve() = default;
  virtual double parameter_end() const = 0;
  virtual Eigen::Vector2d point(double u) const = 0;
  virtual Eigen::Vector2d first_derivative(double u) const = 0;
  virtual Eigen::Vector2d second_derivative(double u) const = 0;
};

// The speed along the path: rises from 0 at `acceleration`, cruises at `speed`, and (if
// `stop_at_end`) falls back to 0 exactly at the path's end. acceleration <= 0 means "start at speed".
// Without `stop_at_end` the path ends at speed and the reference past its end continues at its final
// twist (an experiment that ends while the vehicle moves, as the paper's curve).
struct SpeedProfile {
  double speed = 1.0;          // m/s
  double acceleration = 0.0;   // m/s^2; 0: no ramp
  bool stop_at_end = false;
};

// Follows a curve by arc length at a speed profile, with the heading held at a constant offset
// from the tangent (offset 0: heading along the path; the paper's 60 deg case: offset = pi/3).
class PathReference final : public Reference {
 public:
  // Throws ConfigError for a degenerate curve (zero length, a cusp) or invalid profile/offset.
  PathReference(std::shared_ptr<const PlanarCurve> curve, SpeedProfile profile, double heading_offset);
  ReferenceSample sample(double t) const noexcept override;
  double duration() const noexcept override { return duration_; }
  double length() const noexcept { return length_; }

 private:
  double arc_length_at(double t, double* speed) const noexcept;
  double parameter_at(double s) const noexcept;

  std::shared_ptr<const PlanarCurve> curve_;
  SpeedProfile profile_;
  double heading_offset_;
  double length_ = 0.0;
  double duration_ = 0.0;
  double ramp_time_ = 0.0;
  // s -> u table from integrating du/ds = 1/|p'(u)| with RK4; Hermite-interpolated with the exact slope.
  std::vector<double> table_s_, table_u_, table_du_ds_;
};

// Curves. Each is a PlanarCurve; the factories below return ready references.
std::shared_ptr<const PlanarCurve> make_line_curve(const Eigen::Vector2d& start_world, double direction,
                                                   double length);
// Arc of `radius` starting at `start_world` with initial tangent `direction`, turning through
// `sweep` (> 0 CCW, < 0 CW).
std::shared_ptr<const PlanarCurve> make_arc_curve(const Eigen::Vector2d& start_world, double direction,
                                                  double radius, double sweep);
// The paper's curve (docs/paper.md, assumption 10): y = amplitude sin(2 pi x / wavelength),
// x in [0, length_x].
std::shared_ptr<const PlanarCurve> make_sine_curve(double amplitude, double wavelength, double length_x);
// Figure-eight (lemniscate of Gerono) of half-width `size`, centred on the origin, started at the
// centre heading up-right; `loops` full figure-eights.
std::shared_ptr<const PlanarCurve> make_figure_eight_curve(double size, int loops);

// Samples (t, x, y, psi[, vx, vy, r]) as a clamped cubic spline through the poses (psi unwrapped
// first; end slopes from a one-sided cubic, so the twist stays third-order accurate at the ends),
// with the given twists interpolated linearly, or the spline's rates turned into the body frame.
// The storage SampledReference and TrajectoryReference share: sized once, refilled without
// allocating.
class SplineTrajectory {
 public:
  explicit SplineTrajectory(int capacity = 0);
  // Rows already checked by the caller: 2..capacity rows of 4 or 7 finite columns, t increasing.
  // noexcept, no allocation.
  void assign(const Eigen::Ref<const Eigen::MatrixXd>& rows) noexcept;
  int size() const noexcept { return count_; }
  double first_time() const noexcept { return t_[0]; }
  double last_time() const noexcept { return t_[static_cast<std::size_t>(count_ - 1)]; }
  // At t on the samples' clock; before the first sample it holds the first pose, past the last the
  // last, with zero twist. Needs size() >= 2.
  ReferenceSample sample(double t) const noexcept;

 private:
  int count_ = 0;
  bool has_twist_ = false;
  // Per channel (x, y, psi unwrapped): values and spline second derivatives; given twists.
  std::vector<double> t_, value_[3], second_[3], twist_[3], scratch_;
};

// A recorded trajectory: rows (t, x, y, psi) with optional (vx, vy, r) in the body frame,
// interpolated as SplineTrajectory says; sample(t) is relative to the first row's time.
class SampledReference final : public Reference {
 public:
  // `rows`: each of size 4 or 7, strictly increasing t starting anywhere; throws ConfigError naming
  // the row and the value.
  explicit SampledReference(const std::vector<std::vector<double>>& rows);
  ReferenceSample sample(double t) const noexcept override;
  double duration() const noexcept override { return spline_.last_time() - spline_.first_time(); }

 private:
  SplineTrajectory spline_;
};

// Why a trajectory was refused by TrajectoryReference::publish (the previous one stays active).
enum class TrajectoryStatus {
  kAccepted,
  kTooFewSamples,     // fewer than 2
  kTooManySamples,    // more than the capacity
  kWrongWidth,        // columns other than 4 (t, x, y, psi) or 7 (+ vx, vy, r)
  kNonFinite,         // a NaN or inf value
  kTimeNotIncreasing, // t not greater than the previous sample's
  kBusy,              // another thread was publishing at the same time (one planner thread only)
};
const char* to_string(TrajectoryStatus status) noexcept;
struct TrajectoryCheck {
  TrajectoryStatus status = TrajectoryStatus::kAccepted;
  int sample = -1;  // the offending sample (row), or -1
  int column = -1;  // its column for kNonFinite, or -1
  bool accepted() const noexcept { return status == TrajectoryStatus::kAccepted; }
  std::string describe() const;  // "sample 3: t not increasing" (allocates: not for the control thread)
};

// A planner-fed reference (design card: "replaced at run time without blocking the control
// thread"). A planner thread publishes time-stamped samples (t, x, y, psi[, vx, vy, r]) on the
// controller's clock (the t it passes to step()); the controller's thread samples them as
// SampledReference does (a clamped cubic spline through the poses; twists from it unless given).
// Three buffers of fixed capacity, allocated at construction, hand trajectories over without a
// lock: publish() fills the one neither side holds and swaps it into the middle, and begin_cycle()
// swaps the middle one in when it is newer, so a cycle's window comes from one trajectory, neither
// side ever waits, and nothing allocates after construction. One publishing thread at a time.
// A trajectory whose first sample is more than `max_age` older than the cycle time is stale, and
// so is having none yet: unusable() says so, and the controller stops safely.
class TrajectoryReference final : public Reference {
 public:
  // Throws ConfigError for a capacity < 2 or a max_age that is not > 0 (infinity: never stale).
  explicit TrajectoryReference(int capacity, double max_age = std::numeric_limits<double>::infinity());
  TrajectoryReference(const TrajectoryReference&) = delete;
  TrajectoryReference& operator=(const TrajectoryReference&) = delete;

  // Planner thread. `samples`: one row per sample, 4 or 7 columns, strictly increasing t. noexcept,
  // no allocation; a refused trajectory leaves the active one in place.
  TrajectoryCheck publish(const Eigen::Ref<const Eigen::MatrixXd>& samples) noexcept;

  // Controller thread.
  void begin_cycle() const noexcept override;
  ReferenceSample sample(double t) const noexcept override;
  double duration() const noexcept override;  // the last sample's time (0 before any trajectory)
  const char* unusable(double t) const noexcept override;
  // Trajectories taken up by begin_cycle() so far.
  long version() const noexcept { return front_version_; }
  int capacity() const noexcept { return capacity_; }

 private:
  struct Buffer {
    SplineTrajectory spline;  // size() 0 until the first trajectory
    long version = 0;
  };
  static constexpr int kDirty = 4;  // the middle buffer holds a trajectory the reader has not taken
  int capacity_;
  double max_age_;
  mutable std::array<Buffer, 3> buffers_;
  mutable int front_ = 0;          // the controller thread's buffer
  mutable long front_version_ = 0;
  int back_ = 2;                   // the planner thread's buffer
  long published_ = 0;
  mutable std::atomic<int> middle_{1};
  std::atomic_flag publishing_ = ATOMIC_FLAG_INIT;
};

// Why a sample at (t, x, y) = `txy` cannot follow one at `previous_txy` in a recorded reference:
// its t is not after the previous one's, or, with a finite `max_speed` (m/s: the vehicle's drive
// speed), its position moves further than that speed covers in their time step (1 % of slack for
// rounding), a jump no vehicle of that kind can follow. Empty when it can. `previous_name` says
// where the previous sample is ("line 4", "sample 3"). Every reference file loader checks its rows
// with it.
std::string reference_step_problem(const Eigen::Vector3d& previous_txy, const Eigen::Vector3d& txy, double max_speed,
                                   const std::string& previous_name);

// Largest reference CSV accepted: about 250 000 rows of 7 full-precision columns (over 40 min at
// 100 Hz), while the rows read stay a few hundred MB at most.
inline constexpr std::size_t kMaxReferenceCsvBytes = std::size_t{16} << 20;  // 16 MiB
// Samples a CSV reference may hold, laps included.
inline constexpr std::size_t kMaxReferenceSamples = std::size_t{1} << 20;

// Loads a CSV with a header line naming the columns t,x,y,psi[,vx,vy,r]; errors name file and line.
// A missing file, one that is not a regular file (a directory, /dev/zero, a pipe) or one larger
// than kMaxReferenceCsvBytes is a ConfigError, refused before reading. So are a row whose t is not
// after the previous row's, fewer than two rows, and, with a finite `max_speed` (m/s: the
// vehicle's drive speed), a row whose position is further from the previous row's than that speed
// covers in their time step (1 % of slack for rounding): a jump no vehicle of that kind can follow.
// With `laps` > 1 (a shift of one duty cycle, repeated) the file's path is driven that many times,
// each lap from where and when the last one ended: its poses moved rigidly onto the last lap's end
// pose, its first sample the last lap's last. Throws ConfigError for laps < 1, or when the laps
// would hold more than kMaxReferenceSamples samples.
std::unique_ptr<SampledReference> load_reference_csv(const std::string& file_path,
                                                     double max_speed = std::numeric_limits<double>::infinity(),
                                                     int laps = 1);

}  // namespace swerve
