// References: closed-form poses, twist/pose consistency by integration, exact heading offset.
#include "swerve/control/reference.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "support/config_errors.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

constexpr double kPiTest = 3.14159265358979323846;

// Integrates the reference's body twist in the world frame (RK4 on (x, y, psi)) from its start
// pose and returns the largest position and heading deviation from its own pose over [0, T].
std::pair<double, double> integration_drift(const Reference& reference, double dt) {
  Eigen::Vector3d pose = reference.sample(0.0).pose_world;
  auto rate = [&](double t, const Eigen::Vector3d& p) {
    const Eigen::Vector3d twist = reference.sample(t).twist_body;
    const double c = std::cos(p.z()), s = std::sin(p.z());
    return Eigen::Vector3d(c * twist.x() - s * twist.y(), s * twist.x() + c * twist.y(), twist.z());
  };
  double worst_position = 0.0, worst_heading = 0.0;
  const int steps = static_cast<int>(std::ceil(reference.duration() / dt));
  for (int k = 0; k < steps; ++k) {
    const double t = k * dt;
    const Eigen::Vector3d k1 = rate(t, pose);
    const Eigen::Vector3d k2 = rate(t + dt / 2, pose + dt / 2 * k1);
    const Eigen::Vector3d k3 = rate(t + dt / 2, pose + dt / 2 * k2);
    const Eigen::Vector3d k4 = rate(t + dt, pose + dt * k3);
    pose += dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    const Eigen::Vector3d truth = reference.sample(t + dt).pose_world;
    worst_position = std::max(worst_position, (pose.head<2>() - truth.head<2>()).norm());
    worst_heading = std::max(worst_heading, std::abs(wrap_angle(pose.z() - truth.z())));
  }
  return {worst_position, worst_heading};
}

TEST(Reference, WrapAngleMapsIntoHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(wrap_angle(kPiTest), kPiTest);
  EXPECT_DOUBLE_EQ(wrap_angle(-kPiTest), kPiTest);
  EXPECT_NEAR(wrap_angle(3 * kPiTest / 2), -kPiTest / 2, 1e-12);
  EXPECT_NEAR(wrap_angle(-7.0), -7.0 + 2 * kPiTest, 1e-12);
}

TEST(PathReference, StraightLineMatchesClosedForm) {
  const PathReference line(make_line_curve({1.0, 2.0}, kPiTest / 6, 10.0), {2.0, 0.0, false}, 0.0);
  EXPECT_NEAR(line.duration(), 5.0, 1e-9);
  const ReferenceSample at3 = line.sample(3.0);
  EXPECT_NEAR(at3.pose_world.x(), 1.0 + 6.0 * std::cos(kPiTest / 6), 1e-8);
  EXPECT_NEAR(at3.pose_world.y(), 2.0 + 6.0 * std::sin(kPiTest / 6), 1e-8);
  EXPECT_NEAR(at3.pose_world.z(), kPiTest / 6, 1e-12);
  EXPECT_NEAR(at3.twist_body.x(), 2.0, 1e-12);
  EXPECT_NEAR(at3.twist_body.y(), 0.0, 1e-12);
  EXPECT_NEAR(at3.twist_body.z(), 0.0, 1e-12);
}

TEST(PathReference, ArcMatchesClosedFormAndHasConstantYawRate) {
  const double radius = 4.0, speed = 1.5;
  const PathReference arc(make_arc_curve({0.0, 0.0}, 0.0, radius, kPiTest), {speed, 0.0, false}, 0.0);
  EXPECT_NEAR(arc.length(), kPiTest * radius, 1e-9);
  const double t = (kPiTest / 2 * radius) / speed;  // a quarter turn
  const ReferenceSample s = arc.sample(t);
  EXPECT_NEAR(s.pose_world.x(), radius, 1e-8);
  EXPECT_NEAR(s.pose_world.y(), radius, 1e-8);
  EXPECT_NEAR(s.pose_world.z(), kPiTest / 2, 1e-8);
  EXPECT_NEAR(s.twist_body.z(), speed / radius, 1e-8);
  const PathReference clockwise(make_arc_curve({0.0, 0.0}, 0.0, radius, -kPiTest), {speed, 0.0, false}, 0.0);
  EXPECT_NEAR(clockwise.sample(t).pose_world.y(), -radius, 1e-8);
  EXPECT_NEAR(clockwise.sample(t).twist_body.z(), -speed / radius, 1e-8);
}

TEST(PathReference, IntegratingTheTwistReproducesThePoseForEveryCurve) {
  const std::vector<std::pair<const char*, std::shared_ptr<const PlanarCurve>>> curves = {
      {"line", make_line_curve({0, 0}, 0.3, 12.0)},
      {"arc", make_arc_curve({1, -1}, 1.0, 3.0, 2.5)},
      {"paper sine curve", make_sine_curve(2.0, 20.0, 40.0)},
      {"figure eight", make_figure_eight_curve(5.0, 1)},
  };
  for (const auto& [name, curve] : curves) {
    for (double offset : {0.0, kPiTest / 3}) {
      SCOPED_TRACE(std::string(name) + " offset " + std::to_string(offset));
      const PathReference reference(curve, {1.0, 0.5, true}, offset);
      const auto [position, heading] = integration_drift(reference, 0.002);
      EXPECT_LT(position, 1e-4);
      EXPECT_LT(heading, 1e-4);
    }
  }
}

TEST(PathReference, HeadingOffsetIsKeptExactlyAlongTheWholePath) {
  const double offset = kPiTest / 3;  // the paper's 60 degree case
  const PathReference reference(make_sine_curve(2.0, 20.0, 40.0), {1.0, 0.0, false}, offset);
  for (double t = 0.1; t < reference.duration(); t += 0.37) {
    const ReferenceSample s = reference.sample(t);
    // Direction of travel in the world = heading + direction of the body-frame velocity.
    const double travel = s.pose_world.z() + std::atan2(s.twist_body.y(), s.twist_body.x());
    const double u = s.pose_world.x();  // the sine curve is parameterised by x
    const double tangent = std::atan2(2.0 * 2.0 * kPiTest / 20.0 * std::cos(2 * kPiTest * u / 20.0), 1.0);
    EXPECT_NEAR(wrap_angle(travel - tangent), 0.0, 1e-9);
    EXPECT_NEAR(wrap_angle(s.pose_world.z() - tangent - offset), 0.0, 1e-9);
    EXPECT_NEAR(s.twist_body.head<2>().norm(), 1.0, 1e-12);
  }
}

TEST(PathReference, SpeedProfileRampsUpAndStopsAtTheEnd) {
  const PathReference reference(make_line_curve({0, 0}, 0.0, 10.0), {2.0, 1.0, true}, 0.0);
  // Ramps of 2 s (4 m in total), 6 m at 2 m/s: 3 s of cruise.
  EXPECT_NEAR(reference.duration(), 7.0, 1e-12);
  EXPECT_NEAR(reference.sample(1.0).twist_body.x(), 1.0, 1e-12);
  EXPECT_NEAR(reference.sample(1.0).pose_world.x(), 0.5, 1e-9);
  EXPECT_NEAR(reference.sample(6.0).twist_body.x(), 1.0, 1e-12);
  EXPECT_NEAR(reference.sample(7.0).pose_world.x(), 10.0, 1e-9);
  EXPECT_EQ(reference.sample(8.0).twist_body.norm(), 0.0);
  EXPECT_EQ(reference.sample(-1.0).twist_body.norm(), 0.0);
}

TEST(PathReference, APathThatEndsAtSpeedGoesOnAlongItsFinalTwistPastItsEnd) {
  // Truth: a longer arc on the same circle. Past the end of a quarter circle that does not stop,
  // the reference continues on the circle at the same speed and turn rate.
  const double radius = 3.0, speed = 1.5, heading_offset = kPiTest / 3;
  const PathReference quarter(make_arc_curve({1.0, -2.0}, 0.4, radius, kPiTest / 2), {speed, 0.0, false},
                              heading_offset);
  const PathReference half(make_arc_curve({1.0, -2.0}, 0.4, radius, kPiTest), {speed, 0.0, false},
                           heading_offset);
  for (double t : {quarter.duration() + 0.05, quarter.duration() + 0.7, half.duration() - 0.01}) {
    SCOPED_TRACE(t);
    const ReferenceSample continued = quarter.sample(t), truth = half.sample(t);
    EXPECT_NEAR((continued.pose_world.head<2>() - truth.pose_world.head<2>()).norm(), 0.0, 1e-8);
    EXPECT_NEAR(wrap_angle(continued.pose_world.z() - truth.pose_world.z()), 0.0, 1e-8);
    EXPECT_NEAR((continued.twist_body - truth.twist_body).norm(), 0.0, 1e-8);
  }
  // One that stops at its end holds its final pose at rest.
  const PathReference stopping(make_arc_curve({1.0, -2.0}, 0.4, radius, kPiTest / 2), {speed, 0.5, true},
                               heading_offset);
  const ReferenceSample held = stopping.sample(stopping.duration() + 2.0);
  EXPECT_EQ(held.twist_body.norm(), 0.0);
  EXPECT_NEAR((held.pose_world - stopping.sample(stopping.duration()).pose_world).norm(), 0.0, 1e-12);
}

TEST(PathReference, ShortPathNeverReachesCruiseSpeed) {
  const PathReference reference(make_line_curve({0, 0}, 0.0, 1.0), {5.0, 1.0, true}, 0.0);
  EXPECT_NEAR(reference.duration(), 2.0, 1e-12);  // peak 1 m/s at 1 s
  EXPECT_NEAR(reference.sample(1.0).twist_body.x(), 1.0, 1e-12);
}

TEST(PathReference, InvalidArgumentsAreRejectedWithTheField) {
  EXPECT_THROW(make_line_curve({0, 0}, 0.0, 0.0), ConfigError);
  EXPECT_THROW(make_arc_curve({0, 0}, 0.0, -1.0, 1.0), ConfigError);
  EXPECT_THROW(make_figure_eight_curve(1.0, 0), ConfigError);
  try {
    PathReference(make_line_curve({0, 0}, 0.0, 1.0), {-1.0, 0.0, false}, 0.0);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "speed_profile.speed = -1: must be > 0");
  }
  EXPECT_THROW(PathReference(make_line_curve({0, 0}, 0.0, 1.0), {1.0, 0.0, false}, std::nan("")), ConfigError);
}

TEST(SampledReference, SplineTwistOfASampledCircleMatchesTheAnalyticTwist) {
  // A circle of radius 2 at 1 rad/s, heading along the tangent: body twist (2, 0, 1).
  std::vector<std::vector<double>> rows;
  for (int i = 0; i <= 400; ++i) {
    const double t = 0.02 * i;
    rows.push_back({t, 2 * std::sin(t), 2 - 2 * std::cos(t), wrap_angle(t)});
  }
  const SampledReference reference(rows);
  EXPECT_NEAR(reference.duration(), 8.0, 1e-12);
  for (double t = 1.0; t < 7.0; t += 0.77) {
    const ReferenceSample s = reference.sample(t);
    EXPECT_NEAR(s.twist_body.x(), 2.0, 1e-4);
    EXPECT_NEAR(s.twist_body.y(), 0.0, 1e-4);
    EXPECT_NEAR(s.twist_body.z(), 1.0, 1e-4);
    EXPECT_NEAR(s.pose_world.x(), 2 * std::sin(t), 1e-6);
  }
  const auto [position, heading] = integration_drift(reference, 0.002);
  EXPECT_LT(position, 1e-3);
  EXPECT_LT(heading, 1e-3);
}

TEST(SampledReference, GivenTwistIsInterpolatedAndRowsAreChecked) {
  const SampledReference reference({{0, 0, 0, 0, 1, 0, 0}, {1, 1, 0, 0, 3, 0, 0}});
  EXPECT_NEAR(reference.sample(0.5).twist_body.x(), 2.0, 1e-12);
  EXPECT_THROW(SampledReference({{0, 0, 0, 0}, {0, 1, 0, 0}}), ConfigError);  // t not increasing
  EXPECT_THROW(SampledReference({{0, 0, 0, 0}, {1, 1, 0}}), ConfigError);     // short row
  EXPECT_THROW(SampledReference({{0, 0, 0, 0}, {1, std::nan(""), 0, 0}}), ConfigError);
}

TEST(SampledReference, CsvLoaderNamesFileAndLine) {
  const std::string path = ::testing::TempDir() + "reference_test.csv";
  {
    std::ofstream out(path);
    out << "t,x,y,psi\n0,0,0,0\n1,1,0,zero\n";
  }
  try {
    load_reference_csv(path);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), path + ":3: 'zero' is not a number");
  }
  {
    std::ofstream out(path);
    out << "t,x,y,psi\n0,0,0,0\n1,1,0,0\n2,2,0,0\n";
  }
  EXPECT_NEAR(load_reference_csv(path)->sample(1.5).pose_world.x(), 1.5, 1e-9);
  std::remove(path.c_str());
}

TEST(SampledReference, LapsDriveTheFilesPathAgainFromWhereTheLastLapEnded) {
  // One lap: from the origin heading +x, 1 m ahead while turning left by 90 deg, in 2 s. The
  // second lap starts at (1, 0) heading +y, so its 1 m "ahead" is +y: it ends at (1, 1) heading
  // 180 deg; the third ends at (0, 1) heading 270 deg. Each lap starts when the last one ended.
  const std::string path = ::testing::TempDir() + "reference_laps_test.csv";
  const double quarter = 0.5 * std::acos(-1.0);
  {
    std::ofstream out(path);
    out.precision(17);
    out << "t,x,y,psi\n0,0,0,0\n1,0.5,0," << 0.5 * quarter << "\n2,1,0," << quarter << "\n";
  }
  const auto laps = load_reference_csv(path, std::numeric_limits<double>::infinity(), 3);
  EXPECT_NEAR(laps->duration(), 6.0, 1e-12);  // 3 laps of 2 s
  const Eigen::Vector3d second_start = laps->sample(2.0).pose_world, second_end = laps->sample(4.0).pose_world;
  const Eigen::Vector3d third_end = laps->sample(6.0).pose_world;
  // Through the seam the path goes on: half-way into the second lap it is at (1, 0.5), having
  // turned 135 deg.
  const Eigen::Vector3d second_middle = laps->sample(3.0).pose_world;
  const auto expect_pose = [&](const Eigen::Vector3d& pose, double x, double y, double psi) {
    EXPECT_NEAR(pose.x(), x, 1e-9);
    EXPECT_NEAR(pose.y(), y, 1e-9);
    EXPECT_NEAR(std::remainder(pose.z() - psi, 4.0 * quarter), 0.0, 1e-9);
  };
  expect_pose(second_start, 1.0, 0.0, quarter);
  expect_pose(second_end, 1.0, 1.0, 2.0 * quarter);
  expect_pose(third_end, 0.0, 1.0, 3.0 * quarter);
  expect_pose(second_middle, 1.0, 0.5, 1.5 * quarter);
  EXPECT_NE(testing::config_error_of([&] { load_reference_csv(path, 1.0, 1 << 20); }).find("samples a lap"),
            std::string::npos);
  EXPECT_NE(testing::config_error_of([&] { load_reference_csv(path, 1.0, 0); }).find("laps = 0: must be >= 1"),
            std::string::npos);
  std::remove(path.c_str());
}

// A duty-cycle CSV that no vehicle could follow is refused at load, naming the file, the line and
// the value: a time step that goes backwards, a position jump beyond the vehicle's drive speed in
// one sample, or fewer than two samples (blank lines do not count).
TEST(SampledReference, CsvLoaderRefusesTimeGoingBackAJumpBeyondTheDriveSpeedAndTooFewSamples) {
  const std::string path = ::testing::TempDir() + "reference_duty_test.csv";
  const auto error_of = [&](const std::string& text, double max_speed) {
    {
      std::ofstream out(path);
      out << text;
    }
    try {
      load_reference_csv(path, max_speed);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error_of("t,x,y,psi\n0,0,0,0\n0.1,0.1,0,0\n\n0.05,0.2,0,0\n", 2.0),
            path + ":5: t = 0.05 is not after line 3's t = 0.1");
  // 0.5 m in 0.1 s is 5 m/s against a 2 m/s drive; 0.2 m in 0.1 s (2 m/s) is allowed.
  EXPECT_EQ(error_of("t,x,y,psi\n0,0,0,0\n0.1,0.2,0,0\n0.2,0.5,0.4,0\n", 2.0),
            path + ":4: the position moves 0.5 m in 0.1 s from line 3 (5 m/s), faster than the vehicle's drive "
                   "speed of 2 m/s");
  EXPECT_EQ(error_of("t,x,y,psi\n0,0,0,0\n0.1,0.2,0,0\n", 2.0), "no error");
  EXPECT_EQ(error_of("t,x,y,psi\n0,0,0,0\n0.2,0.5,0.4,0\n", std::numeric_limits<double>::infinity()), "no error");
  EXPECT_EQ(error_of("t,x,y,psi\n0,0,0,0\n\n", 2.0), path + ": 1 sample(s); a reference needs at least 2");
  std::remove(path.c_str());
}

std::string csv_error_of(const std::string& path) {
  try {
    load_reference_csv(path);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

// Found by tests/fuzz/config_fuzzer: `reference: {type: csv, file: /dev/zero}` in a scenario made
// the loader's first getline grow without end until the process ran out of memory.
TEST(SampledReference, CsvLoaderRejectsADeviceWithoutReadingIt) {
  EXPECT_EQ(csv_error_of("/dev/zero"), "/dev/zero: a character device, not a regular file: give a CSV file");
}

TEST(SampledReference, CsvLoaderRejectsADirectoryAndAMissingFile) {
  const std::string directory = SWERVE_SOURCE_DIR "/tests/control";
  EXPECT_EQ(csv_error_of(directory), directory + ": a directory, not a regular file: give a CSV file");
  EXPECT_EQ(csv_error_of("/nonexistent/reference.csv"), "/nonexistent/reference.csv: cannot open the file for reading");
}

TEST(SampledReference, CsvLoaderRejectsAFileOverTheSizeLimitBeforeReadingIt) {
  const std::string path = ::testing::TempDir() + "reference_test_oversized.csv";
  {
    std::ofstream out(path);
    out << "t,x,y,psi\n";
  }
  std::filesystem::resize_file(path, kMaxReferenceCsvBytes + 1);  // sparse: nothing is written
  const std::string message = csv_error_of(path);
  std::filesystem::remove(path);
  EXPECT_EQ(message, path + ": " + std::to_string(kMaxReferenceCsvBytes + 1) +
                         " bytes: reference CSV files are limited to 16 MiB (16777216 bytes)");
}

TEST(SampledReference, CsvLoaderShortensALongFieldInItsError) {
  const std::string path = ::testing::TempDir() + "reference_test_long_field.csv";
  {
    std::ofstream out(path);
    out << "t,x,y,psi\n0,0,0,0\n1," << std::string(5000, 'z') << ",0,0\n";
  }
  const std::string message = csv_error_of(path);
  std::remove(path.c_str());
  EXPECT_LT(message.size(), 300U) << message;
  EXPECT_NE(message.find(path + ":3: 'zzz"), std::string::npos) << message;
  EXPECT_NE(message.find("... (5000 bytes)' is not a number"), std::string::npos) << message;
}

}  // namespace
}  // namespace swerve
