#include "swerve/app/trajectory_file.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "swerve/control/reference.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/core/error_text.hpp"
#include "swerve/core/option_fields.hpp"
#include "swerve/core/text_file.hpp"

namespace swerve {
namespace {

using Json = nlohmann::json;

// One file being read: its name as shown in messages, and the refusals that name it.
class JsonFile {
 public:
  JsonFile(const std::string& path, const char* kind_plural) : shown_(printable_value(path, std::string::npos)) {
    config::TextFileRules rules;
    rules.max_bytes = kMaxTrajectoryFileBytes;
    rules.kind_plural = kind_plural;
    rules.format = "JSON";
    const std::string text = config::read_text_file(path, rules);
    try {
      root_ = Json::parse(text);
    } catch (const Json::exception& error) {
      fail(std::string("not valid JSON: ") + error.what());
    }
  }

  const Json& root() const noexcept { return root_; }
  [[noreturn]] void fail(const std::string& message) const { throw ConfigError(shown_ + ": " + message); }
  [[noreturn]] void fail_at(int sample, const std::string& message) const {
    fail("sample " + std::to_string(sample) + ": " + message);
  }

  // `object[field]` (the field's path shown as `path`) as a finite number.
  double number(const Json& object, const char* field, int sample, const std::string& path) const {
    const Json& value = member(object, field, sample, path);
    if (!value.is_number()) fail_at(sample, "'" + path + "' must be a number, got " + type_of(value));
    const double number = value.get<double>();
    if (!std::isfinite(number)) fail_at(sample, "'" + path + "' = " + Bound::number(number) + " is not finite");
    return number;
  }
  // `object[field]` as an integer (a JSON number without a fraction).
  std::int64_t integer(const Json& object, const char* field, int sample, const std::string& path) const {
    const Json& value = member(object, field, sample, path);
    if (!value.is_number_integer()) fail_at(sample, "'" + path + "' must be an integer, got " + type_of(value));
    return value.get<std::int64_t>();
  }
  const Json& object(const Json& parent, const char* field, int sample, const std::string& path) const {
    const Json& value = member(parent, field, sample, path);
    if (!value.is_object()) fail_at(sample, "'" + path + "' must be an object, got " + type_of(value));
    return value;
  }
  const Json& member(const Json& object, const char* field, int sample, const std::string& path) const {
    const auto found = object.find(field);
    if (found == object.end()) fail_at(sample, "missing '" + path + "'");
    return *found;
  }
  static std::string type_of(const Json& value) {
    return std::string(value.type_name()) + (value.is_primitive() ? " " + printable_value(value.dump()) : "");
  }

 private:
  std::string shown_;
  Json root_;
};

// The rows' consecutive checks (time, speed) and their count, naming samples by `first_index` + row.
void check_rows(const JsonFile& file, const Eigen::MatrixXd& rows, double max_speed, int first_index) {
  if (rows.rows() < 2) {
    file.fail(std::to_string(rows.rows()) + " sample(s); a reference needs at least 2");
  }
  for (Eigen::Index k = 1; k < rows.rows(); ++k) {
    const std::string problem = reference_step_problem(rows.row(k - 1).head<3>().transpose(),
                                                       rows.row(k).head<3>().transpose(), max_speed,
                                                       "sample " + std::to_string(first_index + k - 1));
    if (!problem.empty()) file.fail_at(static_cast<int>(first_index + k), problem);
  }
}

// ChoreoLib's segments: starts at 0 and at each split index; segment k runs to the next start
// (inclusive) or to the last sample. Returns [first, last] sample indices.
std::pair<int, int> choreo_segment(const JsonFile& file, const Json& trajectory, int sample_count, int split) {
  std::vector<int> starts{0};
  const auto splits = trajectory.find("splits");
  if (splits != trajectory.end()) {
    if (!splits->is_array()) file.fail("'trajectory.splits' must be an array, got " + JsonFile::type_of(*splits));
    for (std::size_t i = 0; i < splits->size(); ++i) {
      const Json& index = (*splits)[i];
      const std::string field = "trajectory.splits[" + std::to_string(i) + "]";
      if (!index.is_number_integer() || index.get<std::int64_t>() < 0 || index.get<std::int64_t>() >= sample_count) {
        file.fail("'" + field + "' = " + printable_value(index.dump()) + ": must be a sample index in [0, " +
                  std::to_string(sample_count) + ")");
      }
      const int start = index.get<int>();
      if (start == starts.back() && starts.size() == 1) continue;  // a split at 0 is the first segment
      if (start <= starts.back()) {
        file.fail("'" + field + "' = " + std::to_string(start) + ": splits must increase");
      }
      starts.push_back(start);
    }
  }
  const int segments = static_cast<int>(starts.size());
  if (split >= segments) {
    file.fail("split " + std::to_string(split) + " asked for, but the trajectory has " + std::to_string(segments) +
              " segment(s) (0.." + std::to_string(segments - 1) + ")");
  }
  if (split < 0) return {0, sample_count - 1};
  const int first = starts[static_cast<std::size_t>(split)];
  const int last = split + 1 < segments ? starts[static_cast<std::size_t>(split) + 1] : sample_count - 1;
  return {first, last};
}

// Checks a sample's per-module forces (when it has any) against the vehicle's module count.
void check_module_forces(const JsonFile& file, const Json& sample, int index, int modules) {
  for (const char* field : {"fx", "fy"}) {
    const auto forces = sample.find(field);
    if (forces == sample.end()) continue;
    if (!forces->is_array()) file.fail_at(index, std::string("'") + field + "' must be an array, got " + JsonFile::type_of(*forces));
    if (forces->empty()) continue;
    if (modules > 0 && static_cast<int>(forces->size()) != modules) {
      file.fail_at(index, std::string("'") + field + "' has " + std::to_string(forces->size()) +
                              " module forces, but the vehicle has " + std::to_string(modules) + " modules");
    }
    for (std::size_t m = 0; m < forces->size(); ++m) {
      const Json& force = (*forces)[m];
      if (!force.is_number() || !std::isfinite(force.get<double>())) {
        file.fail_at(index, std::string("'") + field + "[" + std::to_string(m) + "]' = " +
                                printable_value(force.dump()) + " is not a finite number");
      }
    }
  }
}

std::string choreo_file_path(const std::string& path, const ChoreoOptions& options) {
  std::error_code error;
  if (!std::filesystem::is_directory(path, error)) return path;
  if (options.trajectory.empty()) {
    throw ConfigError(printable_value(path, std::string::npos) +
                      ": a folder; name the trajectory in it (trajectory: <name> reads <name>.traj)");
  }
  return (std::filesystem::path(path) / (options.trajectory + ".traj")).string();
}

void check_max_speed(const char* owner, double max_speed) {
  if (!(max_speed > 0.0)) throw_invalid_field(owner, "max_speed", max_speed, "must be > 0 m/s (infinity: unchecked)");
}

}  // namespace

Eigen::MatrixXd load_choreo_trajectory(const std::string& path, const ChoreoOptions& options) {
  check_max_speed("ChoreoOptions", options.max_speed);
  if (options.split < -1) throw_invalid_field("ChoreoOptions", "split", options.split, "must be -1 (all) or >= 0");
  if (options.modules < 0) throw_invalid_field("ChoreoOptions", "modules", options.modules, "must be >= 0");
  const std::string file_path = choreo_file_path(path, options);
  const bool from_folder = file_path != path;
  const JsonFile file(file_path, "trajectory files");
  const Json& root = file.root();
  if (!root.is_object()) file.fail("expected a Choreo trajectory object, got " + JsonFile::type_of(root));
  if (!from_folder && !options.trajectory.empty()) {
    const auto name = root.find("name");
    if (name == root.end() || !name->is_string() || name->get<std::string>() != options.trajectory) {
      file.fail("'name' = " + (name == root.end() ? std::string("(missing)") : printable_value(name->dump())) +
                ", but trajectory '" + printable_value(options.trajectory) + "' was asked for");
    }
  }
  const auto trajectory = root.find("trajectory");
  if (trajectory == root.end() || !trajectory->is_object()) {
    file.fail("missing the 'trajectory' object (Choreo 2025 and later; older files: re-save in Choreo)");
  }
  const auto sample_type = trajectory->find("sampleType");
  if (sample_type != trajectory->end() && !(sample_type->is_string() && sample_type->get<std::string>() == "Swerve")) {
    file.fail("'trajectory.sampleType' = " + printable_value(sample_type->dump()) + ": only \"Swerve\" trajectories");
  }
  const auto samples = trajectory->find("samples");
  if (samples == trajectory->end() || !samples->is_array()) file.fail("missing the 'trajectory.samples' array");
  const int count = static_cast<int>(samples->size());
  if (count < 2) file.fail(std::to_string(count) + " sample(s); a reference needs at least 2");
  const auto [first, last] = choreo_segment(file, *trajectory, count, options.split);

  const bool has_twist = (*samples)[0].is_object() && (*samples)[0].contains("vx");
  Eigen::MatrixXd rows(last - first + 1, has_twist ? 7 : 4);
  for (int k = 0; k < count; ++k) {
    const Json& sample = (*samples)[static_cast<std::size_t>(k)];
    if (!sample.is_object()) file.fail_at(k, "expected an object, got " + JsonFile::type_of(sample));
    // Every sample is checked, also outside the segment asked for: a broken file is refused whole.
    const double t = file.number(sample, "t", k, "t");
    const double x = file.number(sample, "x", k, "x");
    const double y = file.number(sample, "y", k, "y");
    const double heading = file.number(sample, "heading", k, "heading");
    double twist_field[3] = {0.0, 0.0, 0.0};
    if (has_twist) {
      twist_field[0] = file.number(sample, "vx", k, "vx");
      twist_field[1] = file.number(sample, "vy", k, "vy");
      twist_field[2] = file.number(sample, "omega", k, "omega");
    }
    for (const char* field : {"ax", "ay", "alpha"}) {
      if (sample.contains(field)) file.number(sample, field, k, field);
    }
    check_module_forces(file, sample, k, options.modules);
    if (k < first || k > last) continue;
    auto row = rows.row(k - first);
    row.head<4>() << t, x, y, heading;
    if (has_twist) {
      // Choreo's velocities are field-relative; the reference's twist is in the body frame.
      const double c = std::cos(heading), s = std::sin(heading);
      row.tail<3>() << c * twist_field[0] + s * twist_field[1], -s * twist_field[0] + c * twist_field[1],
          twist_field[2];
    }
  }
  check_rows(file, rows, options.max_speed, first);
  return rows;
}

Eigen::MatrixXd load_pose_list(const std::string& path, double max_speed) {
  check_max_speed("load_pose_list", max_speed);
  const JsonFile file(path, "trajectory files");
  const Json* list = &file.root();
  if (list->is_object()) {
    const auto poses = list->find("poses");
    if (poses == list->end()) file.fail("expected an array of poses, or an object with a 'poses' array");
    list = &*poses;
  }
  if (!list->is_array()) file.fail("expected an array of poses, got " + JsonFile::type_of(*list));
  const int count = static_cast<int>(list->size());
  if (count < 2) file.fail(std::to_string(count) + " sample(s); a reference needs at least 2");
  Eigen::MatrixXd rows(count, 4);
  bool stamped = false;
  std::int64_t first_sec = 0, first_nanosec = 0;
  for (int k = 0; k < count; ++k) {
    const Json& entry = (*list)[static_cast<std::size_t>(k)];
    if (!entry.is_object()) file.fail_at(k, "expected an object, got " + JsonFile::type_of(entry));
    const bool this_stamped = entry.contains("pose");
    if (k == 0) stamped = this_stamped;
    if (this_stamped != stamped) {
      file.fail_at(k, stamped ? "a flat {t, x, y, psi} pose among stamped ones" : "a stamped pose among flat ones");
    }
    if (!stamped) {
      rows.row(k) << file.number(entry, "t", k, "t"), file.number(entry, "x", k, "x"), file.number(entry, "y", k, "y"),
          file.number(entry, "psi", k, "psi");
      continue;
    }
    const Json& stamp = file.object(file.object(entry, "header", k, "header"), "stamp", k, "header.stamp");
    const std::int64_t sec = file.integer(stamp, "sec", k, "header.stamp.sec");
    // builtin_interfaces/Time holds an int32: a larger value is not a stamp (and would overflow below).
    if (sec < -(std::int64_t{1} << 31) || sec >= (std::int64_t{1} << 31)) {
      file.fail_at(k, "'header.stamp.sec' = " + std::to_string(sec) + ": must fit an int32, as ROS stamps do");
    }
    const std::int64_t nanosec = file.integer(stamp, "nanosec", k, "header.stamp.nanosec");
    if (nanosec < 0 || nanosec >= 1000000000) {
      file.fail_at(k, "'header.stamp.nanosec' = " + std::to_string(nanosec) + ": must be in [0, 1e9)");
    }
    if (k == 0) first_sec = sec, first_nanosec = nanosec;
    const Json& pose = file.object(entry, "pose", k, "pose");
    const Json& position = file.object(pose, "position", k, "pose.position");
    const Json& orientation = file.object(pose, "orientation", k, "pose.orientation");
    Eigen::Vector4d q(file.number(orientation, "x", k, "pose.orientation.x"),
                      file.number(orientation, "y", k, "pose.orientation.y"),
                      file.number(orientation, "z", k, "pose.orientation.z"),
                      file.number(orientation, "w", k, "pose.orientation.w"));
    if (!(q.norm() > 1e-6)) {
      file.fail_at(k, "'pose.orientation' has length " + Bound::number(q.norm()) + ": not a rotation");
    }
    q.normalize();
    // Yaw of the unit quaternion (x, y, z, w) about the world's z axis.
    const double psi = std::atan2(2.0 * (q[3] * q[2] + q[0] * q[1]), 1.0 - 2.0 * (q[1] * q[1] + q[2] * q[2]));
    const double t = static_cast<double>(sec - first_sec) + 1e-9 * static_cast<double>(nanosec - first_nanosec);
    rows.row(k) << t, file.number(position, "x", k, "pose.position.x"), file.number(position, "y", k, "pose.position.y"),
        psi;
  }
  check_rows(file, rows, max_speed, 0);
  return rows;
}

}  // namespace swerve
