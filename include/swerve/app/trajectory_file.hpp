// Trajectories from the files planners write, as the sample rows SampledReference and
// TrajectoryReference::publish take (t, x, y, psi[, vx, vy, r], twist in the body frame): Choreo's
// `.traj` (JSON, swerve samples) and a JSON pose list (flat t/x/y/psi objects, or ROS
// nav_msgs/Path-like stamped poses). Errors name the file, the sample index and the field.
#pragma once

#include <Eigen/Core>

#include <limits>
#include <string>

namespace swerve {

// Largest trajectory file accepted: a Choreo trajectory of 1 min at 100 Hz with 16 modules' forces
// is about 3 MB.
inline constexpr std::size_t kMaxTrajectoryFileBytes = std::size_t{32} << 20;  // 32 MiB

struct ChoreoOptions {
  // With a folder as the path (ChoreoLib's deploy/choreo), the trajectory `<folder>/<name>.traj`;
  // with a file, when not empty, the name its "name" field must have (a guard against the wrong file).
  std::string trajectory;
  // -1: the whole trajectory; k >= 0: its k-th segment, from the k-th split (ChoreoLib's
  // getSplit(k)): segments start at sample 0 and at each index in "splits", and each ends on the
  // next one's first sample.
  int split = -1;
  // > 0: the per-module forces (fx, fy), when a sample has any, must have this many entries each.
  int modules = 0;
  // m/s: a position jump between samples faster than this is refused (reference_step_problem).
  double max_speed = std::numeric_limits<double>::infinity();
};

// A Choreo swerve trajectory ("trajectory": {"sampleType": "Swerve", "samples": [...]}): each
// sample's t, x, y, heading and, when every sample has them, the field-relative vx, vy and omega,
// turned into the body frame. The rows are 7 wide with velocities, else 4. Accelerations (ax, ay,
// alpha) are checked to be finite numbers and not otherwise used: Choreo holds each interval's
// acceleration constant, so the reference's linear twist between samples already follows them.
// Throws ConfigError naming file, sample and field for a missing or non-numeric field, a non-finite
// value, time not increasing, a differential trajectory, a module count other than
// options.modules, an unknown split, or fewer than two samples.
Eigen::MatrixXd load_choreo_trajectory(const std::string& path, const ChoreoOptions& options = {});

// A JSON pose list: an array, or an object whose "poses" is one, of either
//  - {"t": s, "x": m, "y": m, "psi": rad}, t as given; or
//  - {"header": {"stamp": {"sec": s, "nanosec": ns}}, "pose": {"position": {"x", "y"},
//    "orientation": {"x", "y", "z", "w"}}} (nav_msgs/Path's poses), t counted from the first stamp
//    and psi the yaw of the quaternion (normalised; refused when near zero length).
// Rows are 4 wide; the twist comes from the pose spline, as for a 4-column CSV. Errors as above.
Eigen::MatrixXd load_pose_list(const std::string& path,
                               double max_speed = std::numeric_limits<double>::infinity());

}  // namespace swerve
