// Choreo trajectories and JSON pose lists read into reference rows: hand-written files with values
// worked out by hand, the same reference as the equivalent CSV, and every malformed file refused
// naming the file, the sample and the field.
#include "swerve/app/trajectory_file.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <fstream>
#include <string>

#include "swerve/app/scenario_config.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

std::string write_file(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream out(path);
  out << text;
  return path;
}

// A Choreo sample with the given pose, field velocities and four modules' forces.
std::string choreo_sample(double t, double x, double y, double heading, double vx, double vy, double omega,
                          const std::string& forces = "\"fx\": [1, 2, 3, 4], \"fy\": [0.5, -0.5, 0, 0]") {
  char text[400];
  std::snprintf(text, sizeof text,
                "{\"t\": %.17g, \"x\": %.17g, \"y\": %.17g, \"heading\": %.17g, \"vx\": %.17g, \"vy\": %.17g, "
                "\"omega\": %.17g, \"ax\": 0.0, \"ay\": 0.0, \"alpha\": 0.0, %s}",
                t, x, y, heading, vx, vy, omega, forces.c_str());
  return text;
}

std::string choreo_file(const std::string& name, const std::string& samples, const std::string& splits = "[]") {
  return "{\"name\": \"" + name + "\", \"version\": 1, \"trajectory\": {\"sampleType\": \"Swerve\", \"waypoints\": [], "
         "\"samples\": [" + samples + "], \"splits\": " + splits + "}, \"events\": []}";
}

// Three samples driving along +x while the robot faces +y (heading pi/2), turning at 0.2 rad/s.
std::string sideways_samples() {
  const double half_pi = std::acos(0.0);
  return choreo_sample(0.0, 1.0, 2.0, half_pi, 1.0, 0.0, 0.2) + ", " +
         choreo_sample(0.5, 1.5, 2.0, half_pi + 0.1, 1.0, 0.0, 0.2) + ", " +
         choreo_sample(1.0, 2.0, 2.0, half_pi + 0.2, 1.0, 0.0, 0.2);
}

std::string error_of(const std::function<void()>& load) {
  try {
    load();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(ChoreoTrajectoryFile, ReadsPosesAndTurnsFieldVelocitiesIntoTheBodyFrame) {
  const std::string path = write_file("sideways.traj", choreo_file("sideways", sideways_samples()));
  const Eigen::MatrixXd rows = load_choreo_trajectory(path);
  ASSERT_EQ(rows.rows(), 3);
  ASSERT_EQ(rows.cols(), 7);
  EXPECT_DOUBLE_EQ(rows(1, 0), 0.5);
  EXPECT_DOUBLE_EQ(rows(1, 1), 1.5);
  EXPECT_DOUBLE_EQ(rows(1, 2), 2.0);
  EXPECT_DOUBLE_EQ(rows(1, 3), std::acos(0.0) + 0.1);
  // Facing +y, moving along +x is moving to the robot's right: body (0, -1).
  EXPECT_NEAR(rows(0, 4), 0.0, 1e-15);
  EXPECT_NEAR(rows(0, 5), -1.0, 1e-15);
  EXPECT_DOUBLE_EQ(rows(0, 6), 0.2);
  // At heading pi/2 + 0.1 the same field velocity is (cos, -sin)(pi/2 + 0.1) = (-sin 0.1, -cos 0.1).
  EXPECT_NEAR(rows(1, 4), -std::sin(0.1), 1e-15);
  EXPECT_NEAR(rows(1, 5), -std::cos(0.1), 1e-15);
}

TEST(ChoreoTrajectoryFile, GivesTheSameReferenceAsTheEquivalentCsvThroughAScenario) {
  write_file("equivalent.traj", choreo_file("equivalent", sideways_samples()));
  // The same samples with the body-frame twists worked out by hand: (-sin a, -cos a) at pi/2 + a.
  const double half_pi = std::acos(0.0);
  char csv[400];
  std::snprintf(csv, sizeof csv,
                "t,x,y,psi,vx,vy,r\n0,1,2,%.17g,0,-1,0.2\n0.5,1.5,2,%.17g,%.17g,%.17g,0.2\n1,2,2,%.17g,%.17g,%.17g,0.2\n",
                half_pi, half_pi + 0.1, -std::sin(0.1), -std::cos(0.1), half_pi + 0.2, -std::sin(0.2),
                -std::cos(0.2));
  write_file("equivalent.csv", csv);
  const std::string vehicle = std::string(SWERVE_SOURCE_DIR) + "/configs/vehicles/agv_4wheel.yaml";
  const std::string controller = std::string(SWERVE_SOURCE_DIR) + "/configs/controllers/kinematic_baseline.yaml";
  const auto scenario = [&](const std::string& reference) {
    return write_file(reference.find("csv") != std::string::npos ? "equivalent_csv.yaml" : "equivalent_choreo.yaml",
                      "scenario:\n  name: equivalent\n  vehicle: " + vehicle + "\n  reference: " + reference +
                          "\n  controllers:\n    - {name: kinematic_baseline, config: " + controller + "}\n");
  };
  const ScenarioConfig from_choreo =
      load_scenario_config_file(scenario("{type: choreo, file: equivalent.traj, trajectory: equivalent}"));
  const ScenarioConfig from_csv = load_scenario_config_file(scenario("{type: csv, file: equivalent.csv}"));
  EXPECT_EQ(from_choreo.reference->duration(), from_csv.reference->duration());
  for (double t = -0.1; t <= 1.2; t += 0.01) {
    const ReferenceSample a = from_choreo.reference->sample(t), b = from_csv.reference->sample(t);
    EXPECT_NEAR((a.pose_world - b.pose_world).norm(), 0.0, 1e-14) << "t = " << t;
    EXPECT_NEAR((a.twist_body - b.twist_body).norm(), 0.0, 1e-14) << "t = " << t;
  }
}

TEST(ChoreoTrajectoryFile, ReadsASplitAndATrajectoryNamedInAFolder) {
  const std::string folder = ::testing::TempDir() + "choreo_deploy";
  std::filesystem::create_directories(folder);
  std::string samples;
  for (int k = 0; k < 5; ++k) {
    samples += (k ? ", " : "") + choreo_sample(0.1 * k, 0.1 * k, 0.0, 0.0, 1.0, 0.0, 0.0);
  }
  write_file("choreo_deploy/twoParts.traj", choreo_file("twoParts", samples, "[0, 2]"));
  ChoreoOptions options;
  options.trajectory = "twoParts";
  EXPECT_EQ(load_choreo_trajectory(folder, options).rows(), 5);
  options.split = 0;
  const Eigen::MatrixXd first = load_choreo_trajectory(folder, options);
  ASSERT_EQ(first.rows(), 3);  // samples 0..2: a segment ends on the next one's first sample
  EXPECT_DOUBLE_EQ(first(2, 1), 0.2);
  options.split = 1;
  const Eigen::MatrixXd second = load_choreo_trajectory(folder, options);
  ASSERT_EQ(second.rows(), 3);  // samples 2..4
  EXPECT_DOUBLE_EQ(second(0, 0), 0.2);
  options.split = 2;
  EXPECT_EQ(error_of([&] { load_choreo_trajectory(folder, options); }),
            folder + "/twoParts.traj: split 2 asked for, but the trajectory has 2 segment(s) (0..1)");
  options.split = -1;
  options.trajectory.clear();
  EXPECT_EQ(error_of([&] { load_choreo_trajectory(folder, options); }),
            folder + ": a folder; name the trajectory in it (trajectory: <name> reads <name>.traj)");
  options.trajectory = "other";
  EXPECT_EQ(error_of([&] { load_choreo_trajectory(folder + "/twoParts.traj", options); }),
            folder + "/twoParts.traj: 'name' = \"twoParts\", but trajectory 'other' was asked for");
}

TEST(ChoreoTrajectoryFile, RefusesMalformedFilesNamingTheSampleAndField) {
  const double half_pi = std::acos(0.0);
  const std::string good = choreo_sample(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
  const auto error_with = [&](const std::string& second_sample, int modules = 0) {
    const std::string path = write_file("bad.traj", choreo_file("bad", good + ", " + second_sample));
    ChoreoOptions options;
    options.modules = modules;
    const std::string message = error_of([&] { load_choreo_trajectory(path, options); });
    return message.substr(0, path.size()) == path ? message.substr(path.size()) : message;
  };
  EXPECT_EQ(error_with("{\"t\": 0.1, \"x\": 0, \"heading\": 0, \"vx\": 0, \"vy\": 0, \"omega\": 0}"),
            ": sample 1: missing 'y'");
  EXPECT_EQ(error_with("{\"t\": 0.1, \"x\": \"1\", \"y\": 0, \"heading\": 0, \"vx\": 0, \"vy\": 0, \"omega\": 0}"),
            ": sample 1: 'x' must be a number, got string \"1\"");
  EXPECT_EQ(error_with(choreo_sample(0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0)), ": sample 1: t = 0 is not after sample 0's t = 0");
  // JSON has no NaN or infinity; a number beyond double's range is refused by the parser.
  EXPECT_EQ(error_with("{\"t\": 0.1, \"x\": 1e999, \"y\": 0, \"heading\": 0, \"vx\": 0, \"vy\": 0, \"omega\": 0}"),
            ": not valid JSON: [json.exception.out_of_range.406] number overflow parsing '1e999'");
  EXPECT_EQ(error_with(choreo_sample(0.1, 0.1, 0.0, half_pi, 0.0, 0.0, 0.0, "\"fx\": [], \"fy\": [1, 2]"), 4),
            ": sample 1: 'fy' has 2 module forces, but the vehicle has 4 modules");
  EXPECT_EQ(error_with(choreo_sample(0.1, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0, "\"fx\": [1, null], \"fy\": [0, 0]")),
            ": sample 1: 'fx[1]' = null is not a finite number");
  EXPECT_EQ(error_with("{\"t\": 0.1, \"x\": 0, \"y\": 0, \"heading\": 0}"), ": sample 1: missing 'vx'");
  EXPECT_EQ(error_with("[1, 2]"), ": sample 1: expected an object, got array");

  const std::string differential = write_file(
      "differential.traj", "{\"name\": \"d\", \"trajectory\": {\"sampleType\": \"Differential\", \"samples\": []}}");
  EXPECT_EQ(error_of([&] { load_choreo_trajectory(differential); }),
            differential + ": 'trajectory.sampleType' = \"Differential\": only \"Swerve\" trajectories");
  const std::string old_format = write_file("old.traj", "{\"samples\": [], \"eventMarkers\": []}");
  EXPECT_EQ(error_of([&] { load_choreo_trajectory(old_format); }),
            old_format + ": missing the 'trajectory' object (Choreo 2025 and later; older files: re-save in Choreo)");
  const std::string broken = write_file("broken.traj", "{\"name\": ");
  EXPECT_NE(error_of([&] { load_choreo_trajectory(broken); }).find(broken + ": not valid JSON: "), std::string::npos);
  const std::string one = write_file("one.traj", choreo_file("one", good));
  EXPECT_EQ(error_of([&] { load_choreo_trajectory(one); }), one + ": 1 sample(s); a reference needs at least 2");
  const std::string bad_split = write_file("bad_split.traj", choreo_file("s", good + ", " + choreo_sample(0.1, 0, 0, 0, 0, 0, 0), "[7]"));
  EXPECT_EQ(error_of([&] { load_choreo_trajectory(bad_split); }),
            bad_split + ": 'trajectory.splits[0]' = 7: must be a sample index in [0, 2)");
}

TEST(PoseListFile, ReadsFlatPosesAsGiven) {
  const std::string path = write_file(
      "flat.json", "{\"poses\": [{\"t\": 2.0, \"x\": 0, \"y\": 0, \"psi\": 0}, {\"t\": 3.0, \"x\": 1, \"y\": 0.5, "
                   "\"psi\": 0.25}]}");
  const Eigen::MatrixXd rows = load_pose_list(path);
  ASSERT_EQ(rows.rows(), 2);
  ASSERT_EQ(rows.cols(), 4);
  EXPECT_EQ(rows.row(1), Eigen::RowVector4d(3.0, 1.0, 0.5, 0.25));
  // The bare array is the same list.
  const std::string bare = write_file("bare.json", "[{\"t\": 2.0, \"x\": 0, \"y\": 0, \"psi\": 0}, "
                                                   "{\"t\": 3.0, \"x\": 1, \"y\": 0.5, \"psi\": 0.25}]");
  EXPECT_EQ(load_pose_list(bare), rows);
}

TEST(PoseListFile, ReadsStampedPosesWithTimeFromTheFirstStampAndYawFromTheQuaternion) {
  // A unit quaternion about z by pi/4 (x, y, z, w) = (0, 0, sin(pi/8), cos(pi/8)), given twice its
  // length (normalised on reading); stamps 100.5 s and 101.0 s.
  const double s = std::sin(std::acos(-1.0) / 8.0), c = std::cos(std::acos(-1.0) / 8.0);
  char text[600];
  std::snprintf(text, sizeof text,
                "{\"header\": {\"frame_id\": \"map\"}, \"poses\": ["
                "{\"header\": {\"stamp\": {\"sec\": 100, \"nanosec\": 500000000}}, \"pose\": {\"position\": {\"x\": 1, "
                "\"y\": 2, \"z\": 0}, \"orientation\": {\"x\": 0, \"y\": 0, \"z\": 0, \"w\": 1}}},"
                "{\"header\": {\"stamp\": {\"sec\": 101, \"nanosec\": 0}}, \"pose\": {\"position\": {\"x\": 1.5, "
                "\"y\": 2, \"z\": 0}, \"orientation\": {\"x\": 0, \"y\": 0, \"z\": %.17g, \"w\": %.17g}}}]}",
                2 * s, 2 * c);
  const Eigen::MatrixXd rows = load_pose_list(write_file("stamped.json", text));
  ASSERT_EQ(rows.rows(), 2);
  EXPECT_EQ(rows.row(0), Eigen::RowVector4d(0.0, 1.0, 2.0, 0.0));
  EXPECT_DOUBLE_EQ(rows(1, 0), 0.5);
  EXPECT_DOUBLE_EQ(rows(1, 1), 1.5);
  EXPECT_NEAR(rows(1, 3), std::acos(-1.0) / 4.0, 1e-15);
}

TEST(PoseListFile, RefusesMalformedListsNamingTheSampleAndField) {
  const auto error_with = [&](const std::string& text, double max_speed = std::numeric_limits<double>::infinity()) {
    const std::string path = write_file("bad_poses.json", text);
    const std::string message = error_of([&] { load_pose_list(path, max_speed); });
    return message.substr(0, path.size()) == path ? message.substr(path.size()) : message;
  };
  const std::string first = "{\"t\": 0, \"x\": 0, \"y\": 0, \"psi\": 0}";
  const std::string stamped =
      "{\"header\": {\"stamp\": {\"sec\": 1, \"nanosec\": 0}}, \"pose\": {\"position\": {\"x\": 0, \"y\": 0}, "
      "\"orientation\": {\"x\": 0, \"y\": 0, \"z\": 0, \"w\": 1}}}";
  EXPECT_EQ(error_with("[" + first + ", {\"t\": 1, \"x\": 0, \"y\": 0}]"), ": sample 1: missing 'psi'");
  EXPECT_EQ(error_with("[" + first + ", {\"t\": -1, \"x\": 0, \"y\": 0, \"psi\": 0}]"),
            ": sample 1: t = -1 is not after sample 0's t = 0");
  EXPECT_EQ(error_with("[" + first + ", {\"t\": 0.1, \"x\": 5, \"y\": 0, \"psi\": 0}]", 2.0),
            ": sample 1: the position moves 5 m in 0.1 s from sample 0 (50 m/s), faster than the vehicle's drive "
            "speed of 2 m/s");
  EXPECT_EQ(error_with("[" + first + ", " + stamped + "]"), ": sample 1: a stamped pose among flat ones");
  EXPECT_EQ(error_with("[" + stamped + ", {\"header\": {\"stamp\": {\"sec\": 1, \"nanosec\": 2000000000}}, "
                       "\"pose\": {}}]"),
            ": sample 1: 'header.stamp.nanosec' = 2000000000: must be in [0, 1e9)");
  EXPECT_EQ(error_with("[" + stamped + ", {\"header\": {\"stamp\": {\"sec\": 2, \"nanosec\": 0}}, \"pose\": "
                       "{\"position\": {\"x\": 0, \"y\": 0}, \"orientation\": {\"x\": 0, \"y\": 0, \"z\": 0, \"w\": 0}}}]"),
            ": sample 1: 'pose.orientation' has length 0: not a rotation");
  EXPECT_EQ(error_with("[" + stamped + ", {\"header\": {\"stamp\": {\"sec\": 2.5, \"nanosec\": 0}}, \"pose\": {}}]"),
            ": sample 1: 'header.stamp.sec' must be an integer, got number 2.5");
  EXPECT_EQ(error_with("[" + stamped + ", {\"header\": {\"stamp\": {\"sec\": 9223372036854775807, \"nanosec\": 0}}, "
                       "\"pose\": {}}]"),
            ": sample 1: 'header.stamp.sec' = 9223372036854775807: must fit an int32, as ROS stamps do");
  EXPECT_EQ(error_of([] { load_pose_list("unused.json", std::nan("")); }),
            "load_pose_list.max_speed = nan: must be > 0 m/s (infinity: unchecked)");
  EXPECT_EQ(error_with("{\"path\": []}"), ": expected an array of poses, or an object with a 'poses' array");
  EXPECT_EQ(error_with("[" + first + "]"), ": 1 sample(s); a reference needs at least 2");
}

TEST(ScenarioReference, RefusesAChoreoTrajectoryForAnotherModuleCountNamingTheKey) {
  write_file("four_forces.traj",
             choreo_file("four", choreo_sample(0, 0, 0, 0, 0, 0, 0, "\"fx\": [0, 0, 0], \"fy\": [0, 0, 0]") + ", " +
                                     choreo_sample(0.1, 0.01, 0, 0, 0.1, 0, 0, "\"fx\": [0, 0, 0], \"fy\": [0, 0, 0]")));
  const std::string scenario = write_file(
      "three_forces.yaml", "scenario:\n  name: three\n  vehicle: " + std::string(SWERVE_SOURCE_DIR) +
                               "/configs/vehicles/agv_4wheel.yaml\n  reference: {type: choreo, file: four_forces.traj}\n"
                               "  controllers:\n    - {name: kinematic_baseline, config: " +
                               std::string(SWERVE_SOURCE_DIR) + "/configs/controllers/kinematic_baseline.yaml}\n");
  const std::string message = error_of([&] { load_scenario_config_file(scenario); });
  EXPECT_NE(message.find("reference.file"), std::string::npos) << message;
  EXPECT_NE(message.find("sample 0: 'fx' has 3 module forces, but the vehicle has 4 modules"), std::string::npos)
      << message;
}

}  // namespace
}  // namespace swerve
