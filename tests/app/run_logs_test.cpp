// The run's WPILib DataLog, read back by a reader written here from WPILib's datalog.adoc (it
// shares no code with the writer): every entry started once with its type, every sample of every
// step there with the values logged, and the struct schemas AdvantageScope needs. The --log word
// list is checked naming the unknown word.
#include "swerve/app/run_logs.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

// ---- a DataLog reader from the spec ----------------------------------------------------------------
struct Entry {
  std::string name, type;
  std::vector<std::pair<std::uint64_t, std::string>> samples;  // timestamp (us), payload
};

std::uint64_t little_endian(const std::string& bytes, std::size_t at, std::size_t width) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < width; ++i) {
    v |= static_cast<std::uint64_t>(static_cast<unsigned char>(bytes.at(at + i))) << (8 * i);
  }
  return v;
}

double f64_at(const std::string& payload, std::size_t at) {
  const std::uint64_t bits = little_endian(payload, at, 8);
  double v = 0.0;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

// Entries by name; fails the test on anything the spec does not allow.
std::map<std::string, Entry> read_datalog(const std::string& bytes, std::string* extra_header) {
  std::map<std::string, Entry> by_name;
  std::map<std::uint64_t, std::string> names;
  EXPECT_EQ(bytes.substr(0, 6), "WPILOG");
  EXPECT_EQ(little_endian(bytes, 6, 2), 0x0100u);
  const std::uint64_t extra = little_endian(bytes, 8, 4);
  *extra_header = bytes.substr(12, extra);
  std::size_t at = 12 + extra;
  while (at < bytes.size()) {
    const auto lengths = static_cast<unsigned char>(bytes[at++]);
    const std::size_t id_width = (lengths & 0x3u) + 1, size_width = ((lengths >> 2) & 0x3u) + 1,
                      time_width = ((lengths >> 4) & 0x7u) + 1;
    const std::uint64_t id = little_endian(bytes, at, id_width);
    at += id_width;
    const std::uint64_t size = little_endian(bytes, at, size_width);
    at += size_width;
    const std::uint64_t timestamp = little_endian(bytes, at, time_width);
    at += time_width;
    const std::string payload = bytes.substr(at, size);
    at += size;
    if (id != 0) {
      EXPECT_TRUE(names.count(id)) << "data for entry " << id << " before its start";
      by_name[names[id]].samples.emplace_back(timestamp, payload);
      continue;
    }
    EXPECT_EQ(payload.at(0), 0) << "only Start control records are written";
    const std::uint64_t entry = little_endian(payload, 1, 4);
    std::size_t p = 5;
    const auto string32 = [&]() {
      const std::uint64_t n = little_endian(payload, p, 4);
      std::string s = payload.substr(p + 4, n);
      p += 4 + n;
      return s;
    };
    const std::string name = string32(), type = string32(), metadata = string32();
    EXPECT_EQ(p, payload.size());
    EXPECT_FALSE(names.count(entry)) << "entry " << entry << " started twice";
    EXPECT_FALSE(by_name.count(name)) << name << " started twice";
    names[entry] = name;
    by_name[name].name = name;
    by_name[name].type = type;
  }
  EXPECT_EQ(at, bytes.size());
  return by_name;
}

// Two controllers, three steps, two modules; the first step has no solve.
std::vector<ControllerRun> two_runs() {
  std::vector<ControllerRun> runs(2);
  runs[0].name = "wear_mpc";
  runs[1].name = "kinematic_baseline";
  for (int r = 0; r < 2; ++r) {
    for (int k = 0; k < 3; ++k) {
      StepRecord s;
      s.t = 0.05 * k;
      s.pose_world = Eigen::Vector3d(1.0 + k, 2.0 + r, 0.1 * k);
      s.reference_pose_world = Eigen::Vector3d(1.0 + k, 2.0, 0.1 * k + 0.01);
      s.modules.resize(2);
      s.commands.resize(2);
      for (int i = 0; i < 2; ++i) {
        s.modules[static_cast<std::size_t>(i)].wheel_speed = 10.0 * (k + 1) + i;
        s.modules[static_cast<std::size_t>(i)].steering_angle = 0.2 * i - 0.1 * k;
        s.modules[static_cast<std::size_t>(i)].wear = 0.5 * k + i;
        s.commands[static_cast<std::size_t>(i)].wheel_speed = 11.0 * (k + 1);
        s.commands[static_cast<std::size_t>(i)].steering_angle = 0.3 * i;
      }
      s.solve_time_s = k == 0 ? -1.0 : 0.001 * k;
      s.source = CommandSource::kOptimizer;
      s.solve_status = SolveStatus::kConverged;
      runs[static_cast<std::size_t>(r)].log.push_back(s);
    }
  }
  return runs;
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(RunLogs, DataLogHoldsEveryEntryAndSampleWithWpilibStructLayouts) {
  const std::string path = ::testing::TempDir() + "run_logs_test_" + std::to_string(::getpid()) + ".wpilog";
  const std::vector<ControllerRun> runs = two_runs();
  write_wpilog({"unit", 0.1}, runs, path);
  std::string header;
  const std::map<std::string, Entry> entries = read_datalog(file_bytes(path), &header);
  EXPECT_NE(header.find("scenario unit"), std::string::npos) << header;
  // The schemas, each once at time 0.
  EXPECT_EQ(entries.at("/.schema/struct:Pose2d").samples.at(0).second, "Translation2d translation;Rotation2d rotation");
  EXPECT_EQ(entries.at("/.schema/struct:SwerveModuleState").samples.at(0).second, "double speed;Rotation2d angle");
  EXPECT_EQ(entries.at("/.schema/struct:Translation2d").samples.at(0).second, "double x;double y");
  EXPECT_EQ(entries.at("/.schema/struct:Rotation2d").samples.at(0).second, "double value");
  EXPECT_EQ(entries.size(), 4u + 2u * 9u);
  for (const ControllerRun& run : runs) {
    const std::string prefix = "/SwerveMPC/" + run.name + "/";
    const Entry& pose = entries.at(prefix + "Pose");
    EXPECT_EQ(pose.type, "struct:Pose2d");
    ASSERT_EQ(pose.samples.size(), 3u);
    EXPECT_EQ(entries.at(prefix + "ReferencePose").samples.size(), 3u);
    EXPECT_EQ(entries.at(prefix + "ModuleStates/Commanded").samples.size(), 3u);
    EXPECT_EQ(entries.at(prefix + "PositionError").samples.size(), 3u);
    EXPECT_EQ(entries.at(prefix + "CommandSource").samples.at(2).second, "optimizer");
    EXPECT_EQ(entries.at(prefix + "SolveStatus").type, "string");
    // No solve at the first step: two samples, at 50 and 100 ms.
    const Entry& solve = entries.at(prefix + "SolveTimeMs");
    ASSERT_EQ(solve.samples.size(), 2u);
    EXPECT_EQ(solve.samples[0].first, 50000u);
    EXPECT_DOUBLE_EQ(f64_at(solve.samples[1].second, 0), 2.0);
    for (std::size_t k = 0; k < 3; ++k) {
      const StepRecord& step = run.log[k];
      EXPECT_EQ(pose.samples[k].first, static_cast<std::uint64_t>(50000 * k));
      ASSERT_EQ(pose.samples[k].second.size(), 24u);  // Pose2d: x, y, rotation
      EXPECT_EQ(f64_at(pose.samples[k].second, 0), step.pose_world.x());
      EXPECT_EQ(f64_at(pose.samples[k].second, 8), step.pose_world.y());
      EXPECT_EQ(f64_at(pose.samples[k].second, 16), step.pose_world.z());
      const Entry& measured = entries.at(prefix + "ModuleStates/Measured");
      EXPECT_EQ(measured.type, "struct:SwerveModuleState[]");
      ASSERT_EQ(measured.samples[k].second.size(), 32u);  // two of (speed, angle)
      // Module 1: speed = wheel speed x radius 0.1 m, then its angle.
      EXPECT_DOUBLE_EQ(f64_at(measured.samples[k].second, 16), 0.1 * step.modules[1].wheel_speed);
      EXPECT_EQ(f64_at(measured.samples[k].second, 24), step.modules[1].steering_angle);
      const Entry& wear = entries.at(prefix + "WearPerModule");
      EXPECT_EQ(wear.type, "double[]");
      EXPECT_EQ(f64_at(wear.samples[k].second, 8), step.modules[1].wear);
    }
  }
  std::remove(path.c_str());
}

TEST(RunLogs, FormatListNamesTheUnknownWord) {
  const LogFormats all = parse_log_formats("mcap,csv,wpilog");
  EXPECT_TRUE(all.csv && all.wpilog && all.mcap);
  const LogFormats one = parse_log_formats("wpilog");
  EXPECT_FALSE(one.csv);
  EXPECT_TRUE(one.wpilog);
  try {
    parse_log_formats("csv,rosbag");
    FAIL();
  } catch (const ConfigError& error) {
    EXPECT_EQ(std::string(error.what()), "--log 'csv,rosbag': unknown format 'rosbag' (formats: csv, wpilog, mcap)");
  }
  EXPECT_THROW(parse_log_formats(""), ConfigError);
}

}  // namespace
}  // namespace swerve
