#include "swerve/app/run_logs.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "swerve/core/config_error.hpp"
#include "swerve/core/error_text.hpp"
#include "swerve/version.hpp"

namespace swerve {
namespace {

// Little-endian bytes, as both formats store their integers and floats.
class Bytes {
 public:
  void u8(std::uint8_t v) { data_.push_back(static_cast<char>(v)); }
  void le(std::uint64_t v, int width) {
    for (int i = 0; i < width; ++i) u8(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void u16(std::uint16_t v) { le(v, 2); }
  void u32(std::uint32_t v) { le(v, 4); }
  void u64(std::uint64_t v) { le(v, 8); }
  void f64(double v) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    u64(bits);
  }
  void raw(const std::string& s) { data_ += s; }
  void string32(const std::string& s) {  // uint32 length, then the bytes
    u32(static_cast<std::uint32_t>(s.size()));
    raw(s);
  }
  const std::string& data() const noexcept { return data_; }
  std::size_t size() const noexcept { return data_.size(); }

 private:
  std::string data_;
};

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  if (!out || !out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())) || !out.flush()) {
    throw std::runtime_error(path + ": cannot write");
  }
}

double module_speed(double wheel_speed, const LogContext& context) { return wheel_speed * context.wheel_radius; }

// ---- WPILib DataLog ----------------------------------------------------------------------------

// Bytes needed for v in a record header's variable-width field (at least 1).
int width_of(std::uint64_t v) {
  int width = 1;
  while (width < 8 && (v >> (8 * width)) != 0) ++width;
  return width;
}

class DataLog {
 public:
  explicit DataLog(const std::string& extra_header) {
    out_.raw("WPILOG");
    out_.u16(0x0100);  // version 1.0
    out_.string32(extra_header);
  }

  // Starts an entry (a control record at time 0); returns its id.
  std::uint32_t start(const std::string& name, const std::string& type) {
    const std::uint32_t id = next_id_++;
    Bytes payload;
    payload.u8(0);  // Start
    payload.u32(id);
    payload.string32(name);
    payload.string32(type);
    payload.string32("");  // metadata
    record(0, 0, payload.data());
    return id;
  }

  void record(std::uint32_t entry, std::uint64_t timestamp_us, const std::string& payload) {
    const int id_width = std::min(width_of(entry), 4);
    const int size_width = std::min(width_of(payload.size()), 4);
    const int time_width = width_of(timestamp_us);
    out_.u8(static_cast<std::uint8_t>((id_width - 1) | ((size_width - 1) << 2) | ((time_width - 1) << 4)));
    out_.le(entry, id_width);
    out_.le(payload.size(), size_width);
    out_.le(timestamp_us, time_width);
    out_.raw(payload);
  }

  const std::string& bytes() const noexcept { return out_.data(); }

 private:
  Bytes out_;
  std::uint32_t next_id_ = 1;
};

std::string pose2d(const Eigen::Vector3d& pose) {  // Translation2d (x, y), Rotation2d (value)
  Bytes b;
  b.f64(pose.x());
  b.f64(pose.y());
  b.f64(pose.z());
  return b.data();
}

std::uint64_t microseconds(double t) { return t <= 0.0 ? 0 : static_cast<std::uint64_t>(std::llround(t * 1e6)); }
std::uint64_t nanoseconds(double t) { return t <= 0.0 ? 0 : static_cast<std::uint64_t>(std::llround(t * 1e9)); }

// ---- MCAP ----------------------------------------------------------------------------------------

constexpr char kMcapMagic[] = {'\x89', 'M', 'C', 'A', 'P', '0', '\r', '\n'};

class McapFile {
 public:
  McapFile() {
    out_.raw(std::string(kMcapMagic, sizeof kMcapMagic));
    Bytes header;
    header.string32("");  // profile: none
    header.string32(std::string("SwerveMPC ") + kVersion);
    record(0x01, header.data());
  }
  std::uint16_t schema(const std::string& name, const nlohmann::json& json_schema) {
    const std::uint16_t id = next_schema_++;
    Bytes b;
    b.u16(id);
    b.string32(name);
    b.string32("jsonschema");
    b.string32(json_schema.dump());
    record(0x03, b.data());
    return id;
  }
  std::uint16_t channel(std::uint16_t schema_id, const std::string& topic) {
    const std::uint16_t id = next_channel_++;
    Bytes b;
    b.u16(id);
    b.u16(schema_id);
    b.string32(topic);
    b.string32("json");
    b.u32(0);  // metadata: an empty map
    record(0x04, b.data());
    return id;
  }
  void message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t time_ns, const nlohmann::json& data) {
    Bytes b;
    b.u16(channel_id);
    b.u32(sequence);
    b.u64(time_ns);  // log time
    b.u64(time_ns);  // publish time
    b.raw(data.dump());
    record(0x05, b.data());
  }
  std::string finish() {
    Bytes data_end;
    data_end.u32(0);  // no CRC of the data section
    record(0x0F, data_end.data());
    Bytes footer;
    footer.u64(0);  // no summary section
    footer.u64(0);  // no summary offsets
    footer.u32(0);  // no summary CRC
    record(0x02, footer.data());
    out_.raw(std::string(kMcapMagic, sizeof kMcapMagic));
    return out_.data();
  }

 private:
  void record(std::uint8_t opcode, const std::string& content) {
    out_.u8(opcode);
    out_.u64(content.size());
    out_.raw(content);
  }
  Bytes out_;
  std::uint16_t next_schema_ = 1;
  std::uint16_t next_channel_ = 1;
};

nlohmann::json number_schema() { return {{"type", "number"}}; }
nlohmann::json object_schema(const nlohmann::json& properties) {
  return {{"type", "object"}, {"properties", properties}};
}

nlohmann::json pose_in_frame_schema() {
  const nlohmann::json xyz = object_schema({{"x", number_schema()}, {"y", number_schema()}, {"z", number_schema()}});
  const nlohmann::json xyzw = object_schema(
      {{"x", number_schema()}, {"y", number_schema()}, {"z", number_schema()}, {"w", number_schema()}});
  return object_schema({{"timestamp", object_schema({{"sec", {{"type", "integer"}}}, {"nsec", {{"type", "integer"}}}})},
                        {"frame_id", {{"type", "string"}}},
                        {"pose", object_schema({{"position", xyz}, {"orientation", xyzw}})}});
}

nlohmann::json pose_in_frame(double t, const Eigen::Vector3d& pose) {
  const std::uint64_t ns = nanoseconds(t);
  return {{"timestamp", {{"sec", ns / 1000000000u}, {"nsec", ns % 1000000000u}}},
          {"frame_id", "world"},
          {"pose",
           {{"position", {{"x", pose.x()}, {"y", pose.y()}, {"z", 0.0}}},
            {"orientation", {{"x", 0.0}, {"y", 0.0}, {"z", std::sin(0.5 * pose.z())}, {"w", std::cos(0.5 * pose.z())}}}}}};
}

nlohmann::json finite_or_null(double value) { return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(); }

}  // namespace

LogFormats parse_log_formats(const std::string& text) {
  LogFormats formats;
  formats.csv = false;
  std::stringstream words(text);
  std::string word;
  int count = 0;
  while (std::getline(words, word, ',')) {
    if (word == "csv") {
      formats.csv = true;
    } else if (word == "wpilog") {
      formats.wpilog = true;
    } else if (word == "mcap") {
      formats.mcap = true;
    } else {
      throw ConfigError("--log '" + printable_value(text) + "': unknown format '" + printable_value(word) +
                        "' (formats: csv, wpilog, mcap)");
    }
    ++count;
  }
  if (count == 0) throw ConfigError("--log '': name at least one format (csv, wpilog, mcap)");
  return formats;
}

void write_wpilog(const LogContext& context, const std::vector<ControllerRun>& runs, const std::string& path) {
  DataLog log("SwerveMPC " + std::string(kVersion) + ", scenario " + context.scenario);
  // The struct schemas AdvantageScope decodes (WPILib's wpimath layouts).
  const std::pair<const char*, const char*> schemas[] = {
      {"Rotation2d", "double value"},
      {"Translation2d", "double x;double y"},
      {"Pose2d", "Translation2d translation;Rotation2d rotation"},
      {"SwerveModuleState", "double speed;Rotation2d angle"},
  };
  for (const auto& [name, schema] : schemas) {
    log.record(log.start(std::string("/.schema/struct:") + name, "structschema"), 0, schema);
  }
  for (const ControllerRun& run : runs) {
    const std::string prefix = "/SwerveMPC/" + run.name + "/";
    const std::uint32_t pose = log.start(prefix + "Pose", "struct:Pose2d");
    const std::uint32_t reference = log.start(prefix + "ReferencePose", "struct:Pose2d");
    const std::uint32_t measured = log.start(prefix + "ModuleStates/Measured", "struct:SwerveModuleState[]");
    const std::uint32_t commanded = log.start(prefix + "ModuleStates/Commanded", "struct:SwerveModuleState[]");
    const std::uint32_t wear = log.start(prefix + "WearPerModule", "double[]");
    const std::uint32_t error = log.start(prefix + "PositionError", "double");
    const std::uint32_t solve_time = log.start(prefix + "SolveTimeMs", "double");
    const std::uint32_t source = log.start(prefix + "CommandSource", "string");
    const std::uint32_t status = log.start(prefix + "SolveStatus", "string");
    for (const StepRecord& step : run.log) {
      const std::uint64_t t = microseconds(step.t);
      log.record(pose, t, pose2d(step.pose_world));
      log.record(reference, t, pose2d(step.reference_pose_world));
      Bytes plant, sent, wear_values;
      for (const PlantModuleSample& m : step.modules) {
        plant.f64(module_speed(m.wheel_speed, context));
        plant.f64(m.steering_angle);
        wear_values.f64(m.wear);
      }
      for (const ModuleCommand& c : step.commands) {
        sent.f64(module_speed(c.wheel_speed, context));
        sent.f64(c.steering_angle);
      }
      log.record(measured, t, plant.data());
      log.record(commanded, t, sent.data());
      log.record(wear, t, wear_values.data());
      Bytes position_error;
      position_error.f64(step.position_error());
      log.record(error, t, position_error.data());
      if (step.solve_time_s >= 0.0) {
        Bytes ms;
        ms.f64(step.solve_time_s * 1e3);
        log.record(solve_time, t, ms.data());
      }
      log.record(source, t, to_string(step.source));
      log.record(status, t, to_string(step.solve_status));
    }
  }
  write_file(path, log.bytes());
}

void write_mcap(const LogContext& context, const std::vector<ControllerRun>& runs, const std::string& path) {
  McapFile mcap;
  const nlohmann::json module_list = {
      {"type", "array"}, {"items", object_schema({{"speed", number_schema()}, {"angle", number_schema()}})}};
  const std::uint16_t pose_schema = mcap.schema("foxglove.PoseInFrame", pose_in_frame_schema());
  const std::uint16_t modules_schema =
      mcap.schema("swervempc.ModuleStates", object_schema({{"measured", module_list}, {"commanded", module_list}}));
  const std::uint16_t wear_schema = mcap.schema(
      "swervempc.Wear",
      object_schema({{"per_module", {{"type", "array"}, {"items", number_schema()}}}, {"total", number_schema()}}));
  const std::uint16_t solver_schema = mcap.schema(
      "swervempc.SolverStatus",
      object_schema({{"source", {{"type", "string"}}},
                     {"status", {{"type", "string"}}},
                     {"solve_time_ms", {{"type", {"number", "null"}}}},
                     {"iterations", {{"type", "integer"}}},
                     {"position_error_m", number_schema()}}));
  for (const ControllerRun& run : runs) {
    const std::string prefix = "/" + run.name + "/";
    const std::uint16_t pose = mcap.channel(pose_schema, prefix + "pose");
    const std::uint16_t reference = mcap.channel(pose_schema, prefix + "reference");
    const std::uint16_t modules = mcap.channel(modules_schema, prefix + "module_states");
    const std::uint16_t wear = mcap.channel(wear_schema, prefix + "wear");
    const std::uint16_t solver = mcap.channel(solver_schema, prefix + "solver");
    std::uint32_t sequence = 0;
    for (const StepRecord& step : run.log) {
      const std::uint64_t t = nanoseconds(step.t);
      mcap.message(pose, sequence, t, pose_in_frame(step.t, step.pose_world));
      mcap.message(reference, sequence, t, pose_in_frame(step.t, step.reference_pose_world));
      nlohmann::json measured = nlohmann::json::array(), commanded = nlohmann::json::array(),
                     per_module = nlohmann::json::array();
      double total = 0.0;
      for (const PlantModuleSample& m : step.modules) {
        measured.push_back({{"speed", module_speed(m.wheel_speed, context)}, {"angle", m.steering_angle}});
        per_module.push_back(m.wear);
        total += m.wear;
      }
      for (const ModuleCommand& c : step.commands) {
        commanded.push_back({{"speed", module_speed(c.wheel_speed, context)}, {"angle", c.steering_angle}});
      }
      mcap.message(modules, sequence, t, {{"measured", measured}, {"commanded", commanded}});
      mcap.message(wear, sequence, t, {{"per_module", per_module}, {"total", total}});
      mcap.message(solver, sequence, t,
                   {{"source", to_string(step.source)},
                    {"status", to_string(step.solve_status)},
                    {"solve_time_ms", step.solve_time_s >= 0.0 ? finite_or_null(step.solve_time_s * 1e3) : nlohmann::json()},
                    {"iterations", step.solve_iterations},
                    {"position_error_m", finite_or_null(step.position_error())}});
      ++sequence;
    }
  }
  write_file(path, mcap.finish());
}

}  // namespace swerve
