#include "swerve/app/envelope.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "swerve/app/run_report.hpp"
#include "swerve/app/scenario_config.hpp"
#include "swerve/app/scenario_runner.hpp"
#include "swerve/control/latency_compensator.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/core/random.hpp"
#include "swerve/core/text_file.hpp"
#include "swerve/kinematics/module_layout.hpp"
#include "swerve/ocp/deadline.hpp"

namespace swerve {
namespace {

constexpr double kGravity = 9.81;
constexpr double kDegree = kPi / 180.0;
// The share of the friction limit a drawn path may ask for as lateral acceleration: a planner
// keeps well inside it, and the goals judge tracking, not the tires' limit.
constexpr double kLateralFrictionShare = 0.3;
// The share of the drive speed limit any wheel may need (translation plus yaw): the rest is the
// controllers' room to correct errors.
constexpr double kWheelSpeedShare = 0.9;
constexpr double kCsvRowStep = 0.02;  // s between the rows of a sampled reference
constexpr int kWorstShown = 10;
constexpr double kSmootherstepPeakRate = 15.0 / 8.0;  // max of d/dx x^3 (10 - 15 x + 6 x^2)

// Noise values and observer of configs/scenarios/crab90_noisy.yaml.
constexpr double kNoisePosition = 0.005, kNoiseHeading = 0.005, kNoiseVelocity = 0.02, kNoiseYawRate = 0.01,
                 kNoiseSteering = 0.02, kObserverGain = 0.3;

// Per-(seed, index) stream: a draw never depends on the draws before it, so a draw can be
// reproduced alone and --jobs cannot change it.
class DrawRandom {
 public:
  DrawRandom(std::uint64_t seed, int index) {
    std::uint64_t mixed = seed;
    state_ = splitmix64(&mixed) ^ (0xD1B54A32D192ED03ull * (static_cast<std::uint64_t>(index) + 1u));
  }
  double uniform() { return unit_interval(splitmix64(&state_)); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  double log_uniform(double lo, double hi) { return lo * std::exp(std::log(hi / lo) * uniform()); }
  int integer(int lo, int hi) {  // inclusive
    const auto span = static_cast<std::uint64_t>(hi - lo + 1);
    return lo + static_cast<int>(splitmix64(&state_) % span);
  }
  bool chance(double p) { return uniform() < p; }
  double sign() { return chance(0.5) ? 1.0 : -1.0; }

 private:
  std::uint64_t state_ = 0;
};

// `value` to 1 / per_unit (per_unit an integer count per unit): the quotient of two exact
// integers is the double nearest the decimal, so files show 0.35, not 0.35000000000000003.
double round_to(double value, double per_unit) { return std::round(value * per_unit) / per_unit; }

// The shortest decimal text that reads back as the same double (the files reproduce the draw).
std::string number(double value) {
  char text[40];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(text, sizeof text, "%.*g", precision, value);
    if (std::strtod(text, nullptr) == value) break;
  }
  std::string out = text;
  // A bare integer stays a YAML number either way; keep a decimal point for readers.
  if (out.find_first_of(".eEn") == std::string::npos) out += ".0";
  return out;
}

std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

// ---- Vehicles ---------------------------------------------------------------------------------

VehicleDraw draw_vehicle(DrawRandom& rng) {
  VehicleDraw v;
  const bool triangle = rng.chance(0.15);
  v.mass = round_to(rng.log_uniform(50.0, 5000.0), 1.0);
  // Geometry grows with the cube root of the mass (a 50 kg base ~0.5 m across, a 1.2 t carrier
  // ~1.4 m of track, as the shipped vehicles); the wheel a little slower, within 0.08-0.35 m.
  const double scale = std::cbrt(v.mass / 50.0);
  v.wheel_radius =
      round_to(std::clamp(0.08 * std::pow(v.mass / 50.0, 0.32) * rng.uniform(0.9, 1.1), 0.08, 0.35), 200.0);
  if (triangle) {
    v.layout = "triangle";
    const double r = round_to(0.35 * scale * rng.uniform(0.85, 1.15), 100.0);
    for (int i = 0; i < 3; ++i) {
      const double angle = 2.0 * kPi * i / 3.0;
      v.module_positions.emplace_back(round_to(r * std::cos(angle), 1e4), round_to(r * std::sin(angle), 1e4));
    }
  } else {
    v.layout = "grid";
    v.axles = rng.integer(1, 8);
    const double half_track = round_to(0.25 * scale * rng.uniform(0.85, 1.15), 100.0);
    const double spacing = round_to(0.45 * scale * rng.uniform(0.8, 1.2), 100.0);
    for (int a = 0; a < v.axles; ++a) {
      const double x = round_to((0.5 * (v.axles - 1) - a) * spacing, 1e4);
      v.module_positions.emplace_back(x, half_track);
      v.module_positions.emplace_back(x, -half_track);
    }
  }
  double x_min = 0.0, x_max = 0.0, y_min = 0.0, y_max = 0.0;
  for (const Eigen::Vector2d& p : v.module_positions) {
    x_min = std::min(x_min, p.x());
    x_max = std::max(x_max, p.x());
    y_min = std::min(y_min, p.y());
    y_max = std::max(y_max, p.y());
  }
  // The body reaches a wheel and 10 cm past the outermost modules.
  const double margin = v.wheel_radius + 0.1;
  v.footprint_length = round_to(x_max - x_min + 2.0 * margin, 100.0);
  v.footprint_width = round_to(y_max - y_min + 2.0 * margin, 100.0);
  v.yaw_inertia = round_to(
      v.mass * (v.footprint_length * v.footprint_length + v.footprint_width * v.footprint_width) / 12.0,
      10.0);
  v.steering_limit = rng.chance(0.5) ? kPi / 2.0 : kPi;
  v.mu = round_to(rng.uniform(0.3, 1.0), 100.0);
  v.steering_time_constant = round_to(rng.uniform(0.02, 0.1), 1000.0);
  v.drive_time_constant = round_to(rng.uniform(0.02, 0.1), 1000.0);
  v.drive_speed = round_to(rng.uniform(1.5, 3.0), 20.0);
  v.drive_acceleration = round_to(rng.uniform(0.5, 2.0), 20.0);
  v.steering_rate = round_to(rng.uniform(1.0, 4.0), 20.0);
  return v;
}

// ---- References -------------------------------------------------------------------------------

// A stop-to-stop speed trapezoid of about `duration`: each ramp takes at most 30 % of it, at no
// more than the drive's acceleration (the cruise speed gives way when both cannot hold).
struct Trapezoid {
  double speed = 0.0, acceleration = 0.0, length = 0.0;
  double ramp() const { return speed / acceleration; }
};
Trapezoid trapezoid(double duration, double speed, double acceleration, double max_acceleration) {
  Trapezoid t;
  if (speed / acceleration > 0.3 * duration) acceleration = speed / (0.3 * duration);
  if (acceleration > max_acceleration) {
    acceleration = max_acceleration;
    speed = 0.3 * duration * acceleration;
  }
  t.speed = round_to(speed, 100.0);
  t.acceleration = round_to(std::max(acceleration, 0.01), 100.0);
  t.length = round_to(t.speed * (duration - t.ramp()), 100.0);
  return t;
}

// A sampled motion: the speed along the path (piecewise linear through knots, 0 after the last),
// the path's direction theta(s) = direction + bump(s), and the body heading: along the path or
// held at `direction`, plus a turn (smootherstep) over [turn_start, turn_start + turn_time].
struct Motion {
  std::vector<std::array<double, 2>> knots;  // (t, speed), from (0, 0)
  double direction = 0.0;
  double bump_start = 0.0, bump_length = 0.0, bump_peak = 0.0;  // theta += peak (1 - cos 2 pi u) / 2
  bool heading_follows_path = true;
  double turn_start = 0.0, turn_time = 0.0, turn = 0.0;
};

double speed_at(const Motion& m, double t) {
  if (t <= m.knots.front()[0]) return m.knots.front()[1];
  for (std::size_t i = 1; i < m.knots.size(); ++i) {
    if (t <= m.knots[i][0]) {
      const double span = m.knots[i][0] - m.knots[i - 1][0];
      const double u = span > 0.0 ? (t - m.knots[i - 1][0]) / span : 1.0;
      return m.knots[i - 1][1] + u * (m.knots[i][1] - m.knots[i - 1][1]);
    }
  }
  return m.knots.back()[1];
}

double theta_at(const Motion& m, double s, double* dtheta_ds) {
  *dtheta_ds = 0.0;
  if (m.bump_length <= 0.0 || s <= m.bump_start || s >= m.bump_start + m.bump_length) return m.direction;
  const double u = (s - m.bump_start) / m.bump_length;
  *dtheta_ds = m.bump_peak * kPi * std::sin(2.0 * kPi * u) / m.bump_length;
  return m.direction + 0.5 * m.bump_peak * (1.0 - std::cos(2.0 * kPi * u));
}

double turn_at(const Motion& m, double t, double* rate) {
  *rate = 0.0;
  if (m.turn_time <= 0.0 || t <= m.turn_start) return 0.0;
  if (t >= m.turn_start + m.turn_time) return m.turn;
  const double x = (t - m.turn_start) / m.turn_time;
  *rate = m.turn * 30.0 * x * x * (1.0 - x) * (1.0 - x) / m.turn_time;
  return m.turn * x * x * x * (10.0 - 15.0 * x + 6.0 * x * x);
}

// Rows (t, x, y, psi, vx, vy, r) every kCsvRowStep from the start to the last knot; the pose by
// RK4 on (s, x, y), the twist from the motion's exact rates, so the two agree.
std::vector<std::array<double, 7>> sample_motion(const Motion& m) {
  const int rows = static_cast<int>(std::ceil(m.knots.back()[0] / kCsvRowStep - 1e-9)) + 1;
  constexpr int kSubsteps = 10;
  const double h = kCsvRowStep / kSubsteps;
  std::vector<std::array<double, 7>> out;
  out.reserve(static_cast<std::size_t>(rows));
  double s = 0.0, x = 0.0, y = 0.0, unused = 0.0;
  const auto rates = [&m, &unused](double t, double arc, double* ds, double* dx, double* dy) {
    const double v = speed_at(m, t);
    const double theta = theta_at(m, arc, &unused);
    *ds = v;
    *dx = v * std::cos(theta);
    *dy = v * std::sin(theta);
  };
  for (int k = 0; k < rows; ++k) {
    const double t = k * kCsvRowStep;
    double dtheta_ds = 0.0, turn_rate = 0.0;
    const double v = speed_at(m, t);
    const double theta = theta_at(m, s, &dtheta_ds);
    const double psi = (m.heading_follows_path ? theta : m.direction) + turn_at(m, t, &turn_rate);
    const double r = (m.heading_follows_path ? dtheta_ds * v : 0.0) + turn_rate;
    out.push_back({t, x, y, psi, v * std::cos(theta - psi), v * std::sin(theta - psi), r});
    for (int j = 0; j < kSubsteps; ++j) {
      const double tj = t + j * h;
      double s1, x1, y1, s2, x2, y2, s3, x3, y3, s4, x4, y4;
      rates(tj, s, &s1, &x1, &y1);
      rates(tj + 0.5 * h, s + 0.5 * h * s1, &s2, &x2, &y2);
      rates(tj + 0.5 * h, s + 0.5 * h * s2, &s3, &x3, &y3);
      rates(tj + h, s + h * s3, &s4, &x4, &y4);
      s += h / 6.0 * (s1 + 2.0 * s2 + 2.0 * s3 + s4);
      x += h / 6.0 * (x1 + 2.0 * x2 + 2.0 * x3 + x4);
      y += h / 6.0 * (y1 + 2.0 * y2 + 2.0 * y3 + y4);
    }
  }
  return out;
}

std::vector<std::array<double, 2>> trapezoid_knots(const Trapezoid& tz) {
  const double cruise_end = tz.length / tz.speed;  // the ramps together cover one ramp's time at speed
  return {{0.0, 0.0}, {tz.ramp(), tz.speed}, {cruise_end, tz.speed}, {cruise_end + tz.ramp(), 0.0}};
}

// The largest curvature and the length of a unit-size figure-eight (the curve scales linearly).
void figure_eight_unit(double* max_curvature, double* length) {
  const std::shared_ptr<const PlanarCurve> curve = make_figure_eight_curve(1.0, 1);
  const int samples = 4000;
  const double end = curve->parameter_end(), h = end / samples;
  *max_curvature = 0.0;
  *length = 0.0;
  for (int j = 0; j <= samples; ++j) {
    const Eigen::Vector2d d1 = curve->first_derivative(h * j), d2 = curve->second_derivative(h * j);
    const double speed = d1.norm();
    *max_curvature =
        std::max(*max_curvature, std::abs(d1.x() * d2.y() - d1.y() * d2.x()) / (speed * speed * speed));
    if (j > 0) *length += 0.5 * h * (speed + curve->first_derivative(h * (j - 1)).norm());
  }
}

// The built-in reference's duration, from the same classes the scenario loader builds.
double built_in_duration(const ReferenceDraw& r) {
  SpeedProfile profile;
  profile.speed = r.speed;
  profile.acceleration = r.acceleration;
  profile.stop_at_end = true;
  std::shared_ptr<const PlanarCurve> curve;
  if (r.type == "line") {
    curve = make_line_curve(Eigen::Vector2d::Zero(), r.direction, r.length);
  } else if (r.type == "arc") {
    curve = make_arc_curve(Eigen::Vector2d::Zero(), r.direction, r.radius, r.sweep);
  } else {
    curve = make_figure_eight_curve(r.size, 1);
  }
  return PathReference(curve, profile, r.heading_offset).duration();
}

std::string speed_text(double speed) { return fixed(speed, 2) + " m/s"; }

ReferenceDraw line_reference(const Trapezoid& tz, double direction, double offset, const std::string& what) {
  ReferenceDraw r;
  r.type = "line";
  r.direction = direction;
  r.length = tz.length;
  r.speed = tz.speed;
  r.acceleration = tz.acceleration;
  r.heading_offset = offset;
  r.summary = what + ", line " + fixed(tz.length, 2) + " m at " + speed_text(tz.speed);
  return r;
}

// Whether a module of `v` would have to roll across one of its steering end stops to follow `rows`.
// Over each stretch in which a module rolls, its directions of travel must fit within the steering
// range turned by a whole number of half turns: a direction and its opposite are one steering angle,
// with the wheel reversed. A planner hands a vehicle with end stops no reference that needs a swing
// across its range while it rolls (scripts/warehouse_duty_cycle.py checks its missions the same way).
bool rolls_across_an_end_stop(const std::vector<std::array<double, 7>>& rows, const VehicleDraw& v) {
  if (v.steering_limit >= kPi) return false;
  constexpr double kRolling = 1e-3;  // m/s
  const double tolerance = 0.5 * kDegree;
  for (const Eigen::Vector2d& p : v.module_positions) {
    bool rolling = false;
    double low = 0.0, high = 0.0, previous = 0.0;
    const auto fits = [&] {
      return std::ceil((high - v.steering_limit - tolerance) / kPi) <=
             std::floor((low + v.steering_limit + tolerance) / kPi);
    };
    for (const auto& row : rows) {
      const double vx = row[4] - row[6] * p.y(), vy = row[5] + row[6] * p.x();
      if (std::hypot(vx, vy) <= kRolling) {
        if (rolling && !fits()) return true;
        rolling = false;
        continue;
      }
      double angle = std::atan2(vy, vx);
      if (rolling) {
        angle = previous + std::remainder(angle - previous, 2.0 * kPi);
      } else {
        low = high = angle;
      }
      low = std::min(low, angle);
      high = std::max(high, angle);
      previous = angle;
      rolling = true;
    }
    if (rolling && !fits()) return true;
  }
  return false;
}

// Shrinks `*angle` (a motion's turn or path-angle bump) by tenths until its vehicle can follow the
// motion without rolling a module across an end stop. No random draw: the other draws stay as
// they were.
void keep_within_the_steering_range(Motion* m, double* angle, const VehicleDraw& v) {
  while (std::abs(*angle) > kDegree && rolls_across_an_end_stop(sample_motion(*m), v)) *angle *= 0.9;
}

ReferenceDraw csv_reference(const Motion& m, const std::string& summary) {
  ReferenceDraw r;
  r.type = "csv";
  r.direction = m.direction;
  r.rows = sample_motion(m);
  r.summary = summary;
  return r;
}

bool is_curved(ReferenceFamily family) {
  return family == ReferenceFamily::kArc || family == ReferenceFamily::kSCurve ||
         family == ReferenceFamily::kLaneChange || family == ReferenceFamily::kFigureEight ||
         family == ReferenceFamily::kHeadingChange;
}

// What every family draws first (in this order, so a seed gives the same draw), and the limits its
// shape keeps to.
struct ReferenceBasis {
  const VehicleDraw& v;
  double duration, speed, acceleration, direction;
  double radius;   // the vehicle's
  double lateral;  // the lateral acceleration allowed, m/s^2

  Trapezoid profile() const { return trapezoid(duration, speed, acceleration, v.drive_acceleration); }
  // The smallest path radius: twice the vehicle's (the inner wheels keep turning forwards) and the
  // one the lateral-acceleration share allows; lowers the cruise speed to what the wheels allow.
  double min_path_radius() {
    const double geometric = 2.0 * radius + 0.5;
    speed = std::min(speed, kWheelSpeedShare * v.drive_speed / (1.0 + radius / geometric));
    return std::max(geometric, speed * speed / lateral);
  }
};

ReferenceDraw draw_arc(ReferenceBasis b, DrawRandom& rng) {
  const double min_radius = b.min_path_radius();
  const Trapezoid tz = b.profile();
  const double turn = rng.sign() * rng.uniform(kPi / 3.0, 1.5 * kPi);
  ReferenceDraw r;
  r.type = "arc";
  r.direction = b.direction;
  r.radius = round_to(std::max(tz.length / std::abs(turn), min_radius), 100.0);
  r.sweep = std::copysign(round_to(tz.length / r.radius, 1e4), turn);
  r.speed = tz.speed;
  r.acceleration = tz.acceleration;
  r.summary = "arc R=" + fixed(r.radius, 2) + " m, sweep " + fixed(r.sweep / kDegree, 1) + " deg at " +
              speed_text(tz.speed);
  return r;
}

ReferenceDraw draw_figure_eight(ReferenceBasis b) {
  const double min_radius = b.min_path_radius();
  const Trapezoid tz = b.profile();
  double unit_curvature = 0.0, unit_length = 0.0;
  figure_eight_unit(&unit_curvature, &unit_length);
  ReferenceDraw r;
  r.type = "figure_eight";
  r.direction = 0.0;
  r.size = round_to(std::max(tz.length / unit_length, unit_curvature * min_radius), 100.0);
  r.speed = tz.speed;
  r.acceleration = tz.acceleration;
  r.summary = "figure-eight " + fixed(r.size, 2) + " m at " + speed_text(tz.speed);
  return r;
}

// A lane change or an S-curve: one smooth bump of the path angle.
ReferenceDraw draw_bump(bool lane_change, const ReferenceBasis& b, DrawRandom& rng) {
  const Trapezoid tz = b.profile();
  Motion m;
  m.knots = trapezoid_knots(tz);
  m.direction = b.direction;
  m.heading_follows_path = rng.chance(0.5);
  double peak = 0.0;
  if (lane_change) {
    m.bump_start = rng.uniform(0.15, 0.35) * tz.length;
    m.bump_length = rng.uniform(0.3, 0.5) * tz.length;
    const double shift = rng.uniform(1.0, 1.5) * b.v.footprint_width;
    peak = std::min(2.0 * shift / m.bump_length, 35.0 * kDegree);  // small-angle shift = peak L / 2
  } else {
    m.bump_start = 0.1 * tz.length;
    m.bump_length = 0.8 * tz.length;
    peak = rng.uniform(60.0, 120.0) * kDegree;
  }
  // Curvature within the lateral-acceleration share, and within the wheel speeds (heading
  // along the path) or the steering rate (heading held: the modules steer with the path).
  double max_curvature = b.lateral / (tz.speed * tz.speed);
  max_curvature = std::min(max_curvature, m.heading_follows_path
                                              ? (kWheelSpeedShare * b.v.drive_speed / tz.speed - 1.0) / b.radius
                                              : 0.5 * b.v.steering_rate / tz.speed);
  peak = std::min(peak, max_curvature * m.bump_length / kPi);
  m.bump_peak = rng.sign() * peak;
  keep_within_the_steering_range(&m, &m.bump_peak, b.v);
  ReferenceDraw r = csv_reference(m, std::string(lane_change ? "lane change" : "s-curve") + ", peak path angle " +
                                         fixed(m.bump_peak / kDegree, 1) + " deg, heading " +
                                         (m.heading_follows_path ? "along the path" : "held") + ", " +
                                         fixed(tz.length, 2) + " m at " + speed_text(tz.speed));
  r.speed = tz.speed;
  r.acceleration = tz.acceleration;
  r.length = tz.length;
  return r;
}

ReferenceDraw draw_heading_change(const ReferenceBasis& b, DrawRandom& rng) {
  const Trapezoid tz = b.profile();
  Motion m;
  m.knots = trapezoid_knots(tz);
  m.direction = b.direction;
  m.heading_follows_path = false;
  const double cruise = tz.length / tz.speed - tz.ramp();
  m.turn_time = rng.uniform(0.5, 0.9) * cruise;
  m.turn_start = tz.ramp() + rng.uniform(0.0, cruise - m.turn_time);
  double turn = rng.uniform(45.0, 180.0) * kDegree;
  // Yaw rate within the wheel speeds the translation leaves and half the steering rate.
  const double max_yaw_rate =
      std::min((kWheelSpeedShare * b.v.drive_speed - tz.speed) / b.radius, 0.5 * b.v.steering_rate);
  turn = std::min(turn, max_yaw_rate * m.turn_time / kSmootherstepPeakRate);
  m.turn = rng.sign() * turn;
  keep_within_the_steering_range(&m, &m.turn, b.v);
  ReferenceDraw r = csv_reference(m, "heading change " + fixed(m.turn / kDegree, 1) + " deg over " +
                                         fixed(m.turn_time, 1) + " s, " + fixed(tz.length, 2) + " m at " +
                                         speed_text(tz.speed));
  r.speed = tz.speed;
  r.acceleration = tz.acceleration;
  r.length = tz.length;
  return r;
}

// The acceleration and cruise speed that fit ramps up and down into `room` seconds.
void fit_ramps(double room, double max_acceleration, double* acceleration, double* cruise_speed) {
  if (2.0 * *cruise_speed / *acceleration > room) *acceleration = 2.0 * *cruise_speed / room;
  if (*acceleration > max_acceleration) {
    *acceleration = max_acceleration;
    *cruise_speed = 0.5 * *acceleration * room;
  }
}

ReferenceDraw draw_creep_to_stop(const ReferenceBasis& b, DrawRandom& rng) {
  const double creep = rng.uniform(0.02, 0.08);
  const double creep_time = rng.uniform(2.0, 4.0);
  double a = b.acceleration;
  double cruise_speed = b.speed;
  fit_ramps(b.duration - creep_time - 1.0, b.v.drive_acceleration, &a, &cruise_speed);  // >= 1 s of room
  const double cruise_time = b.duration - creep_time - 2.0 * cruise_speed / a;
  Motion m;
  m.direction = b.direction;
  double t = cruise_speed / a;
  m.knots = {{0.0, 0.0}, {t, cruise_speed}};
  t += cruise_time;
  m.knots.push_back({t, cruise_speed});
  t += (cruise_speed - creep) / a;
  m.knots.push_back({t, creep});
  t += creep_time;
  m.knots.push_back({t, creep});
  t += creep / a;
  m.knots.push_back({t, 0.0});
  ReferenceDraw r = csv_reference(m, "creep to stop: " + speed_text(cruise_speed) + ", then " +
                                         fixed(creep * 100.0, 1) + " cm/s for " + fixed(creep_time, 1) + " s");
  r.speed = cruise_speed;
  r.acceleration = a;
  return r;
}

ReferenceDraw draw_stop_and_go(const ReferenceBasis& b, DrawRandom& rng) {
  const int cycles = b.duration < 10.0 ? 2 : 3;
  const double dwell = rng.uniform(0.5, 2.0);
  const double period = b.duration / cycles;
  double a = b.acceleration;
  double cruise_speed = b.speed;
  fit_ramps(period - dwell - 0.5, b.v.drive_acceleration, &a, &cruise_speed);  // at least 0.5 s of cruise
  const double ramp = cruise_speed / a;
  const double cruise_time = period - dwell - 2.0 * ramp;
  Motion m;
  m.direction = b.direction;
  m.knots = {{0.0, 0.0}};
  for (int c = 0; c < cycles; ++c) {
    const double t0 = c * period;
    if (c > 0) m.knots.push_back({t0, 0.0});
    m.knots.push_back({t0 + ramp, cruise_speed});
    m.knots.push_back({t0 + ramp + cruise_time, cruise_speed});
    m.knots.push_back({t0 + 2.0 * ramp + cruise_time, 0.0});
  }
  m.knots.push_back({cycles * period, 0.0});
  ReferenceDraw r = csv_reference(m, "stop and go: " + std::to_string(cycles) + " x " + speed_text(cruise_speed) +
                                         ", stops of " + fixed(dwell, 1) + " s");
  r.speed = cruise_speed;
  r.acceleration = a;
  return r;
}

// A warehouse vehicle's turn to face a bay: a turn in place of 45-180 deg, a dwell (none in a
// quarter of the draws: the leg follows the turn at once), then a straight leg along the basis
// direction at the heading the turn left, so the leg runs at minus the turn in the body frame (a
// crab for a quarter turn).
ReferenceDraw draw_turn_then_go(const ReferenceBasis& b, DrawRandom& rng) {
  Motion m;
  m.direction = b.direction;
  m.heading_follows_path = false;
  const double turn = rng.uniform(45.0, 180.0) * kDegree;
  // Yaw rate within the wheel speeds; a turn in place needs no steering while it lasts.
  const double max_yaw_rate = kWheelSpeedShare * b.v.drive_speed / b.radius;
  m.turn_start = 0.5;
  m.turn_time = std::max(1.0, turn * kSmootherstepPeakRate / max_yaw_rate) * rng.uniform(1.0, 1.5);
  const double dwell = rng.chance(0.25) ? 0.0 : rng.uniform(0.2, 1.5);
  m.turn = rng.sign() * turn;
  const double go = m.turn_start + m.turn_time + dwell;
  const Trapezoid tz = trapezoid(std::max(b.duration - go, 3.0), b.speed, b.acceleration, b.v.drive_acceleration);
  m.knots = {{0.0, 0.0}};
  for (const auto& knot : trapezoid_knots(tz)) m.knots.push_back({go + knot[0], knot[1]});
  keep_within_the_steering_range(&m, &m.turn, b.v);
  ReferenceDraw r = csv_reference(m, "turn in place " + fixed(m.turn / kDegree, 1) + " deg over " +
                                         fixed(m.turn_time, 1) + " s, dwell " + fixed(dwell, 1) + " s, then " +
                                         fixed(tz.length, 2) + " m at " + speed_text(tz.speed));
  r.speed = tz.speed;
  r.acceleration = tz.acceleration;
  r.length = tz.length;
  return r;
}

ReferenceDraw draw_reference(ReferenceFamily family, const VehicleDraw& v, DrawRandom& rng) {
  const double duration = rng.uniform(6.0, 20.0);
  // Curved families leave part of the drive speed for the yaw's share of the wheel speeds.
  const double speed = rng.uniform(0.3, is_curved(family) ? 0.6 : 0.8) * v.drive_speed;
  const double acceleration = rng.uniform(0.3, 0.8) * v.drive_acceleration;
  const double direction = round_to(rng.uniform(-kPi, kPi), 1000.0);
  const ReferenceBasis b{v, duration, speed, acceleration, direction, v.radius(), kLateralFrictionShare * v.mu * kGravity};
  ReferenceDraw r;
  switch (family) {
    case ReferenceFamily::kLine: r = line_reference(b.profile(), direction, 0.0, "straight"); break;
    case ReferenceFamily::kHeadingOffset: {
      const double offset = round_to(rng.uniform(0.0, 0.5 * kPi), 1000.0);
      r = line_reference(b.profile(), direction, offset, "heading offset " + fixed(offset / kDegree, 1) + " deg");
      break;
    }
    case ReferenceFamily::kCrab: {
      const double offset = rng.sign() * 0.5 * kPi;
      r = line_reference(b.profile(), direction, offset, "crab " + fixed(offset / kDegree, 0) + " deg");
      break;
    }
    case ReferenceFamily::kReverse: r = line_reference(b.profile(), direction, kPi, "reverse"); break;
    case ReferenceFamily::kArc: r = draw_arc(b, rng); break;
    case ReferenceFamily::kFigureEight: r = draw_figure_eight(b); break;
    case ReferenceFamily::kLaneChange: r = draw_bump(true, b, rng); break;
    case ReferenceFamily::kSCurve: r = draw_bump(false, b, rng); break;
    case ReferenceFamily::kHeadingChange: r = draw_heading_change(b, rng); break;
    case ReferenceFamily::kCreepToStop: r = draw_creep_to_stop(b, rng); break;
    case ReferenceFamily::kStopAndGo: r = draw_stop_and_go(b, rng); break;
    case ReferenceFamily::kTurnThenGo: r = draw_turn_then_go(b, rng); break;
  }
  r.duration = r.type == "csv" ? r.rows.back()[0] : built_in_duration(r);
  return r;
}

ConditionsDraw draw_conditions(DrawRandom& rng) {
  ConditionsDraw c;
  c.control_period = round_to(rng.uniform(0.010, 0.050), 1000.0);
  c.solve_budget = round_to(0.4 * c.control_period, 1e5);  // 0.4 ms steps, shown as such
  // Latency up to 150 ms, but no more than the latency compensation rolls forward: an older
  // measurement is stale by design (StalenessOptions::max_age), and the controller stops safely.
  const double max_latency = std::min(0.150, LatencyCompensator::kMaxSteps * c.control_period);
  // Whole periods, never past the limit: the largest count that fits, drawn uniformly from 0 on.
  const int most_steps = static_cast<int>(std::floor(max_latency / c.control_period + 1e-9));
  c.measurement_delay_steps = rng.integer(0, most_steps);
  c.latency = c.measurement_delay_steps * c.control_period;
  c.noise = rng.chance(0.5);
  c.simulator_seed = 1 + rng.integer(0, 999999);
  return c;
}

// ---- Files ------------------------------------------------------------------------------------

std::string draw_name(const Draw& draw) {
  return "envelope_s" + std::to_string(draw.seed) + "_d" + std::to_string(draw.index);
}

std::string vehicle_summary(const VehicleDraw& v) {
  return std::to_string(v.modules()) + "-module " +
         (v.layout == "grid" ? "grid (" + std::to_string(v.axles) + " axles)" : std::string("triangle")) +
         ", " + fixed(v.mass, 0) + " kg, steering " + (v.steering_limit < kPi ? "+-90 deg" : "unlimited");
}

std::string conditions_summary(const ConditionsDraw& c) {
  return "period " + fixed(c.control_period * 1000.0, 0) + " ms, latency " + fixed(c.latency * 1000.0, 0) +
         " ms, noise " + (c.noise ? "on" : "off");
}

// Lines of `text`, each without its newline.
std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  return lines;
}

// Sets `controller.<key>` (a line "  key: ..." directly under `controller:`) to `value`, or inserts
// it after `controller.<after>`; a file without either cannot be adjusted and is an error.
void set_controller_key(std::vector<std::string>* lines, const std::string& source_name,
                        const std::string& key, const std::string& value, const std::string& after) {
  const std::string line = "  " + key + ": " + value + "   # set by swerve-mpc envelope";
  for (std::string& l : *lines) {
    if (l.rfind("  " + key + ":", 0) == 0) {
      l = line;
      return;
    }
  }
  for (std::size_t i = 0; i < lines->size(); ++i) {
    if ((*lines)[i].rfind("  " + after + ":", 0) == 0) {
      lines->insert(lines->begin() + static_cast<std::ptrdiff_t>(i) + 1, line);
      return;
    }
  }
  throw ConfigError(source_name + ": has no controller." + key + " or controller." + after +
                    " line (two-space indent) to set controller." + key + " = " + value + " on");
}

std::string joined(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& l : lines) text += l + "\n";
  return text;
}

nlohmann::json number_or_null(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
}

nlohmann::json run_json(const EnvelopeRun& run) {
  nlohmann::json j = {{"ran", run.ran}, {"completed", run.completed}};
  if (!run.failure.empty()) j["failure"] = run.failure;
  if (!run.ran) return j;
  const RunMetrics& m = run.metrics;
  j["wear_total"] = number_or_null(m.wear_total);
  j["tracking_rmse_m"] = number_or_null(m.tracking_rmse_m);
  j["heading_rmse_rad"] = number_or_null(m.heading_rmse_rad);
  j["steering_effort_rad2_s"] = number_or_null(m.steering_effort);
  j["steering_command_jerk_rad_s2"] = number_or_null(m.steering_command_jerk);
  j["deadline_misses"] = m.deadline_misses;
  j["safe_stops"] = run.safe_stops;
  j["steps"] = m.steps;
  return j;
}

constexpr double kEffortRatioFloor = 0.1;  // rad^2/s: the smallest yardstick of the steering-effort ratio

double safe_ratio(double value, double yardstick) {
  if (yardstick > 0.0) return value / yardstick;
  return value <= 0.0 ? 1.0 : std::numeric_limits<double>::infinity();
}

std::string ratio_text(double value) { return std::isfinite(value) ? fixed(value, 3) : "inf"; }

}  // namespace

// ---- Families and options ---------------------------------------------------------------------

const char* to_string(ReferenceFamily family) noexcept {
  switch (family) {
    case ReferenceFamily::kLine:
      return "line";
    case ReferenceFamily::kArc:
      return "arc";
    case ReferenceFamily::kSCurve:
      return "s_curve";
    case ReferenceFamily::kLaneChange:
      return "lane_change";
    case ReferenceFamily::kFigureEight:
      return "figure_eight";
    case ReferenceFamily::kHeadingOffset:
      return "heading_offset";
    case ReferenceFamily::kHeadingChange:
      return "heading_change";
    case ReferenceFamily::kCrab:
      return "crab";
    case ReferenceFamily::kReverse:
      return "reverse";
    case ReferenceFamily::kCreepToStop:
      return "creep_to_stop";
    case ReferenceFamily::kStopAndGo:
      return "stop_and_go";
    case ReferenceFamily::kTurnThenGo:
      return "turn_then_go";
  }
  return "unknown";
}

const std::vector<ReferenceFamily>& all_reference_families() {
  static const std::vector<ReferenceFamily> families = {
      ReferenceFamily::kLine,          ReferenceFamily::kArc,         ReferenceFamily::kSCurve,
      ReferenceFamily::kLaneChange,    ReferenceFamily::kFigureEight, ReferenceFamily::kHeadingOffset,
      ReferenceFamily::kHeadingChange, ReferenceFamily::kCrab,        ReferenceFamily::kReverse,
      ReferenceFamily::kCreepToStop,   ReferenceFamily::kStopAndGo,   ReferenceFamily::kTurnThenGo,
  };
  return families;
}

std::optional<ReferenceFamily> reference_family_named(const std::string& name) {
  for (const ReferenceFamily family : all_reference_families()) {
    if (name == to_string(family)) return family;
  }
  return std::nullopt;
}

std::string reference_family_names() {
  std::string names;
  for (const ReferenceFamily family : all_reference_families()) {
    names += (names.empty() ? "" : ", ") + std::string(to_string(family));
  }
  return names;
}

double VehicleDraw::radius() const {
  double r = 0.0;
  for (const Eigen::Vector2d& p : module_positions) r = std::max(r, p.norm());
  return r;
}

std::vector<ReferenceFamily> EnvelopeOptions::family_list() const {
  if (families.empty()) return all_reference_families();
  std::vector<ReferenceFamily> list;
  for (const std::string& name : families) {
    if (const auto family = reference_family_named(name)) list.push_back(*family);
  }
  return list;
}

void EnvelopeOptions::validate() const {
  constexpr const char* kOwner = "EnvelopeOptions";
  if (draws < 1) throw_invalid_field(kOwner, "draws", draws, "must be >= 1");
  if (jobs < 1 || jobs > 1024) throw_invalid_field(kOwner, "jobs", jobs, "must be in [1, 1024]");
  for (const std::string& name : families) {
    if (!reference_family_named(name)) {
      throw_invalid_field(kOwner, "families", "'" + name + "'",
                          "unknown family (families: " + reference_family_names() + ")");
    }
  }
  if (out_dir.empty()) throw_invalid_field(kOwner, "out_dir", "''", "must name a directory");
  shard.validate();
  if (controller_file.empty())
    throw_invalid_field(kOwner, "controller_file", "''", "must name a controller file");
  if (baseline_file.empty())
    throw_invalid_field(kOwner, "baseline_file", "''", "must name a controller file");
  if (!(work_clock >= 0.0 && work_clock <= 1.0)) {
    throw_invalid_field(kOwner, "work_clock", work_clock, "must be in [0, 1] s per read (0: the wall clock)");
  }
  if (!(work_clock_evaluation >= 0.0 && work_clock_evaluation <= 1.0)) {
    throw_invalid_field(kOwner, "work_clock_evaluation", work_clock_evaluation,
                        "must be in [0, 1] s per module evaluation (0: reads only)");
  }
}

// ---- Drawing ----------------------------------------------------------------------------------

Draw draw_case(std::uint64_t seed, int index, const std::vector<ReferenceFamily>& families) {
  if (families.empty()) throw_invalid_field("draw_case", "families", "[]", "must name at least one family");
  if (index < 0) throw_invalid_field("draw_case", "index", index, "must be >= 0");
  DrawRandom rng(seed, index);
  Draw draw;
  draw.seed = seed;
  draw.index = index;
  draw.family = families[static_cast<std::size_t>(index) % families.size()];
  draw.vehicle = draw_vehicle(rng);
  draw.conditions = draw_conditions(rng);
  draw.reference = draw_reference(draw.family, draw.vehicle, rng);
  draw.duration = draw.reference.duration;
  return draw;
}

std::string vehicle_yaml(const Draw& draw) {
  const VehicleDraw& v = draw.vehicle;
  std::ostringstream out;
  out << "# Envelope draw " << draw.index << " of seed " << draw.seed
      << " (swerve-mpc envelope): a drawn vehicle.\n"
      << "# Yaw inertia = m (L^2 + W^2) / 12 of its " << number(v.footprint_length) << " x "
      << number(v.footprint_width) << " m footprint plate; tire and wear as the shipped vehicles.\n"
      << "vehicle:\n"
      << "  name: " << draw_name(draw) << "\n"
      << "  description: \"" << vehicle_summary(v) << "\"\n"
      << "  mass: " << number(v.mass) << "\n"
      << "  yaw_inertia: " << number(v.yaw_inertia) << "\n"
      << "  center_of_mass: [0.0, 0.0]\n"
      << "  wheel_radius: " << number(v.wheel_radius) << "\n"
      << "  modules:\n";
  for (const Eigen::Vector2d& p : v.module_positions) {
    out << "    - {position: [" << number(p.x()) << ", " << number(p.y()) << "]}\n";
  }
  out << "  limits:\n"
      << "    drive_speed: " << number(v.drive_speed) << "\n"
      << "    drive_acceleration: " << number(v.drive_acceleration) << "\n"
      << "    steering_rate: " << number(v.steering_rate) << "\n"
      << "    steering_angle: [" << number(-v.steering_limit) << ", " << number(v.steering_limit) << "]\n"
      << "  actuators:\n"
      << "    steering_time_constant: " << number(v.steering_time_constant) << "\n"
      << "    drive_time_constant: " << number(v.drive_time_constant) << "\n"
      << "  tire:\n"
      << "    mu: " << number(v.mu) << "\n"
      << "    longitudinal: {B: 10.0, C: 1.65, E: 0.0}\n"
      << "    lateral: {B: 15.0, C: 1.3, E: 0.0}\n"
      << "  wear:\n"
      << "    model: frictional_power\n"
      << "    coefficient: 1.0\n"
      << "  plant:\n"
      << "    actuator_lag: true\n"
      << "    actuator_saturation: true\n";
  return out.str();
}

std::string scenario_yaml(const Draw& draw) {
  const ReferenceDraw& r = draw.reference;
  const ConditionsDraw& c = draw.conditions;
  std::ostringstream out;
  out << "# Envelope draw " << draw.index << " of seed " << draw.seed << " (swerve-mpc envelope), family "
      << to_string(draw.family) << ".\n"
      << "# Written by the generator and loaded back from here: `swerve-mpc run` on this file reproduces the "
         "draw.\n"
      << "scenario:\n"
      << "  name: " << draw_name(draw) << "\n"
      << "  description: \"" << to_string(draw.family) << "; " << vehicle_summary(draw.vehicle) << "; "
      << conditions_summary(c) << "\"\n"
      << "  vehicle: vehicle.yaml\n"
      << "  duration: " << number(draw.duration) << "\n"
      << "  reference:\n"
      << "    type: " << r.type << "\n";
  if (r.type == "csv") {
    out << "    file: reference.csv   # " << r.summary << "\n";
  } else {
    out << "    speed: " << number(r.speed) << "\n"
        << "    acceleration: " << number(r.acceleration) << "\n"
        << "    stop_at_end: true\n"
        << "    heading_offset: " << number(r.heading_offset) << "\n";
    if (r.type == "line") {
      out << "    direction: " << number(r.direction) << "\n    length: " << number(r.length) << "\n";
    } else if (r.type == "arc") {
      out << "    direction: " << number(r.direction) << "\n    radius: " << number(r.radius) << "\n"
          << "    sweep: " << number(r.sweep) << "\n";
    } else {
      out << "    size: " << number(r.size) << "\n";
    }
  }
  if (c.noise) {
    out << "  measurement_filter: {pose_gain: " << number(kObserverGain)
        << ", steering_gain: " << number(kObserverGain) << "}\n";
  }
  out << "  simulator:\n"
      << "    seed: " << c.simulator_seed << "\n"
      << "    measurement_delay_steps: " << c.measurement_delay_steps << "\n";
  if (c.noise) {
    out << "    noise: {position: " << number(kNoisePosition) << ", heading: " << number(kNoiseHeading)
        << ", velocity: " << number(kNoiseVelocity) << ", yaw_rate: " << number(kNoiseYawRate)
        << ", steering_angle: " << number(kNoiseSteering) << "}\n";
  }
  out << "  controllers:\n"
      << "    - {name: wear_mpc, config: wear_mpc.yaml}\n"
      << "    - {name: kinematic_baseline, config: kinematic_baseline.yaml}\n";
  return out.str();
}

std::string reference_csv(const Draw& draw) {
  if (draw.reference.type != "csv") return "";
  std::string text = "t,x,y,psi,vx,vy,r\n";
  char line[256];
  for (const std::array<double, 7>& row : draw.reference.rows) {
    std::snprintf(line, sizeof line, "%.12g,%.12g,%.12g,%.12g,%.12g,%.12g,%.12g\n", row[0], row[1], row[2],
                  row[3], row[4], row[5], row[6]);
    text += line;
  }
  return text;
}

std::string controller_yaml(const std::string& source_text, const std::string& source_name,
                            const Draw& draw) {
  std::vector<std::string> lines = lines_of(source_text);
  const ConditionsDraw& c = draw.conditions;
  set_controller_key(&lines, source_name, "control_period", number(c.control_period), "dt");
  set_controller_key(&lines, source_name, "solve_budget", number(c.solve_budget), "control_period");
  lines.insert(lines.begin(), "# Copied from " + source_name + " by swerve-mpc envelope (draw " +
                                  std::to_string(draw.index) + " of seed " + std::to_string(draw.seed) +
                                  "): control_period and solve_budget (0.4 x period) set for the draw.");
  return joined(lines);
}

std::string baseline_yaml(const std::string& source_text, const std::string& source_name, const Draw& draw,
                          double lookahead_s) {
  std::vector<std::string> lines = lines_of(source_text);
  // The baseline steps every dt: it runs at the draw's period, its weights rescaled by
  // baseline.weights_step, as `swerve-mpc tune` runs it at a target's period.
  // Its horizon grows so that it still looks as far ahead as the file's own (horizon x dt), as the
  // wear-aware controller does at any period (its dt stays): a baseline planning 0.2 s ahead at a
  // 10 ms period would be a baseline tuned down.
  const double period = draw.conditions.control_period;
  const int horizon = std::max(1, static_cast<int>(std::lround(lookahead_s / period)));
  set_controller_key(&lines, source_name, "dt", number(period), "type");
  set_controller_key(&lines, source_name, "horizon", std::to_string(horizon), "type");
  lines.insert(lines.begin(), "# Copied from " + source_name + " by swerve-mpc envelope (draw " +
                                  std::to_string(draw.index) + " of seed " + std::to_string(draw.seed) +
                                  "): dt set to the draw's control period, horizon to the file's look-ahead.");
  return joined(lines);
}

std::string write_draw(const Draw& draw, const std::string& dir, const EnvelopeOptions& options) {
  namespace fs = std::filesystem;
  const std::string controller_text = config::read_text_file(options.controller_file);
  const std::string baseline_text = config::read_text_file(options.baseline_file);
  std::error_code error;
  fs::create_directories(dir, error);
  if (error || !fs::is_directory(dir)) throw std::runtime_error(dir + ": cannot create the draw's directory");
  const auto write = [&dir](const std::string& name, const std::string& text) {
    const std::string path = (fs::path(dir) / name).string();
    std::ofstream out(path);
    if (!out || !(out << text) || !out.flush()) throw std::runtime_error(path + ": cannot write");
  };
  write("vehicle.yaml", vehicle_yaml(draw));
  if (draw.reference.type == "csv") write("reference.csv", reference_csv(draw));
  write("wear_mpc.yaml", controller_yaml(controller_text, options.controller_file, draw));
  const ControllerConfig baseline = load_controller_config_file(options.baseline_file);
  write("kinematic_baseline.yaml",
        baseline_yaml(baseline_text, options.baseline_file, draw, baseline.baseline.horizon * baseline.baseline.dt));
  write("scenario.yaml", scenario_yaml(draw));
  return (fs::path(dir) / "scenario.yaml").string();
}

// ---- Running and judging ----------------------------------------------------------------------

int count_safe_stops(const std::vector<StepRecord>& log) {
  return static_cast<int>(std::count_if(
      log.begin(), log.end(), [](const StepRecord& r) { return r.source == CommandSource::kSafeStop; }));
}

EnvelopeGoals evaluate_goals(const EnvelopeRun& wear_mpc, const EnvelopeRun& baseline) {
  EnvelopeGoals g;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  g.wear_ratio = g.steering_effort_ratio = g.rmse_excess_m = nan;
  g.ran = wear_mpc.ran && baseline.ran && wear_mpc.completed && baseline.completed;
  if (!wear_mpc.ran || !baseline.ran) return g;
  const RunMetrics& m = wear_mpc.metrics;
  const RunMetrics& b = baseline.metrics;
  g.wear_ratio = safe_ratio(m.wear_total, b.wear_total);
  // Against the baseline's effort, or 0.1 rad^2/s where it is smaller: a baseline that hardly
  // steers (a straight line) would make any ratio astronomical and the distribution meaningless.
  g.steering_effort_ratio = safe_ratio(m.steering_effort, std::max(b.steering_effort, kEffortRatioFloor));
  g.rmse_excess_m = m.tracking_rmse_m - b.tracking_rmse_m;
  g.wear = m.wear_total <= b.wear_total;
  g.position = m.tracking_rmse_m <= std::max(1.1 * b.tracking_rmse_m, b.tracking_rmse_m + 0.02);
  g.heading = m.heading_rmse_rad <= std::max(1.1 * b.heading_rmse_rad, b.heading_rmse_rad + 0.5 * kDegree);
  g.steering_effort = m.steering_effort <= std::max(1.5 * b.steering_effort, b.steering_effort + 0.5);
  g.deadlines = m.deadline_misses == 0;
  g.no_safe_stop = wear_mpc.safe_stops == 0;
  g.gross = m.wear_total > 2.0 * b.wear_total || m.tracking_rmse_m > b.tracking_rmse_m + 0.05;
  return g;
}

DrawResult run_draw(const Draw& draw, const std::string& dir, const EnvelopeOptions& options) {
  DrawResult result;
  result.draw = draw;
  result.scenario_file = (std::filesystem::path(dir) / "scenario.yaml").string();
  try {
    result.scenario_file = write_draw(draw, dir, options);
    const ScenarioConfig scenario = load_scenario_config_file(result.scenario_file);
    // The file must say what was drawn: a controller file whose layout defeated the key edits
    // would otherwise run at its own period unnoticed.
    if (std::abs(scenario.simulator.control_period - draw.conditions.control_period) > 1e-12) {
      throw std::runtime_error(result.scenario_file + ": loads with a control period of " +
                               number(scenario.simulator.control_period) + " s, not the drawn " +
                               number(draw.conditions.control_period) + " s");
    }
    for (const ScenarioController& controller : scenario.controllers) {
      const bool mpc = controller.config.kind == ControllerKind::kWearMpc;
      if (mpc && std::abs(controller.config.mpc.solve_budget - draw.conditions.solve_budget) > 1e-12) {
        throw std::runtime_error(controller.config_file + ": loads with a solve budget of " +
                                 number(controller.config.mpc.solve_budget) + " s, not the drawn " +
                                 number(draw.conditions.solve_budget) + " s");
      }
      EnvelopeRun& run = mpc ? result.wear_mpc : result.baseline;
      // Each run on its own clock from zero, so a run does not depend on the one before it.
      std::optional<WorkClock> clock;
      if (options.work_clock > 0.0) clock.emplace(options.work_clock, options.work_clock_evaluation);
      const ControllerRun controller_run =
          run_controller(scenario, controller, {}, 0, clock ? &*clock : nullptr);
      run.ran = true;
      run.completed = controller_run.completed;
      run.failure = controller_run.failure;
      run.metrics = controller_run.metrics;
      run.safe_stops = count_safe_stops(controller_run.log);
    }
    if (!result.wear_mpc.ran || !result.baseline.ran) {
      throw std::runtime_error(result.scenario_file +
                               ": needs a wear_mpc and a kinematic_baseline controller");
    }
  } catch (const std::exception& error) {
    result.error = error.what();
  }
  result.goals = evaluate_goals(result.wear_mpc, result.baseline);
  return result;
}

EnvelopeResult run_envelope(const EnvelopeOptions& options, const EnvelopeCallback& on_done) {
  options.validate();
  // Unreadable controller files fail the whole command at once, not every draw.
  (void)config::read_text_file(options.controller_file);
  (void)config::read_text_file(options.baseline_file);
  prepare_output_directory(options.out_dir);
  const std::vector<ReferenceFamily> families = options.family_list();
  EnvelopeResult result;
  result.options = options;
  std::vector<int> indices;  // this shard's draws
  for (int i = 0; i < options.draws; ++i) {
    if (options.shard.owns(i)) indices.push_back(i);
  }
  const auto total = static_cast<int>(indices.size());
  result.draws.resize(indices.size());
  std::atomic<int> next{0};
  std::mutex done_lock;
  int done = 0;
  const auto worker = [&]() {
    for (int k = next++; k < total; k = next++) {
      const int i = indices[static_cast<std::size_t>(k)];
      const std::string dir = (std::filesystem::path(options.out_dir) / "draws" / std::to_string(i)).string();
      DrawResult r;
      try {
        r = run_draw(draw_case(options.seed, i, families), dir, options);
      } catch (const std::exception& error) {  // drawing itself failed: still reported, never dropped
        r = undrawn_result(options.seed, i, families, dir, error.what());
      }
      const std::lock_guard<std::mutex> hold(done_lock);
      result.draws[static_cast<std::size_t>(k)] = std::move(r);
      ++done;
      if (on_done) on_done(result.draws[static_cast<std::size_t>(k)], done, total);
    }
  };
  const int threads = std::max(1, std::min(options.jobs, total));
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  count_goals(&result);
  return result;
}

DrawResult undrawn_result(std::uint64_t seed, int index, const std::vector<ReferenceFamily>& families,
                          const std::string& dir, const std::string& why) {
  DrawResult r;
  r.draw.seed = seed;
  r.draw.index = index;
  r.draw.family = families[static_cast<std::size_t>(index) % families.size()];
  r.scenario_file = (std::filesystem::path(dir) / "scenario.yaml").string();
  r.error = "drawing failed: " + why;
  r.goals = evaluate_goals(r.wear_mpc, r.baseline);
  return r;
}

void count_goals(EnvelopeResult* result) {
  result->met = result->gross = result->failed = 0;
  for (const DrawResult& r : result->draws) {
    if (r.goals.all()) ++result->met;
    if (r.goals.gross) ++result->gross;
    if (!r.error.empty() || !r.goals.ran) ++result->failed;
  }
}

// ---- Reports ----------------------------------------------------------------------------------

namespace {

struct Spread {
  double median = std::numeric_limits<double>::quiet_NaN();
  double p90 = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
  int count = 0;
};

Spread spread_of(const EnvelopeResult& result, double EnvelopeGoals::*ratio) {
  std::vector<double> values;
  for (const DrawResult& r : result.draws) {
    if (r.goals.ran && !std::isnan(r.goals.*ratio)) values.push_back(r.goals.*ratio);
  }
  Spread s;
  s.count = static_cast<int>(values.size());
  if (values.empty()) return s;
  s.median = percentile(values, 50.0);
  s.p90 = percentile(values, 90.0);
  s.max = *std::max_element(values.begin(), values.end());
  return s;
}

// Worst first: draws that did not run, then by wear ratio, ties by RMSE excess, then by index.
std::vector<const DrawResult*> worst_draws(const EnvelopeResult& result) {
  std::vector<const DrawResult*> order;
  for (const DrawResult& r : result.draws) order.push_back(&r);
  std::stable_sort(order.begin(), order.end(), [](const DrawResult* a, const DrawResult* b) {
    if (a->goals.ran != b->goals.ran) return !a->goals.ran;
    if (!a->goals.ran) return false;
    if (a->goals.wear_ratio != b->goals.wear_ratio) return a->goals.wear_ratio > b->goals.wear_ratio;
    return a->goals.rmse_excess_m > b->goals.rmse_excess_m;
  });
  if (order.size() > static_cast<std::size_t>(kWorstShown))
    order.resize(static_cast<std::size_t>(kWorstShown));
  return order;
}

std::string clock_text(const EnvelopeOptions& o) {
  if (o.work_clock > 0.0) {
    char text[128];
    std::snprintf(text, sizeof text, "a work clock (%g s per read, %g s per module evaluation)", o.work_clock,
                  o.work_clock_evaluation);
    return text;
  }
  return "the wall clock";
}

std::string families_text(const EnvelopeOptions& o) {
  std::string text;
  for (const ReferenceFamily f : o.family_list())
    text += (text.empty() ? "" : ",") + std::string(to_string(f));
  return text;
}

nlohmann::json spread_json(const Spread& s) {
  return {{"median", number_or_null(s.median)},
          {"p90", number_or_null(s.p90)},
          {"max", number_or_null(s.max)},
          {"draws", s.count}};
}

}  // namespace

std::string envelope_report(const EnvelopeResult& result) {
  const EnvelopeOptions& o = result.options;
  const auto total = static_cast<int>(result.draws.size());
  std::ostringstream out;
  out << "envelope: " << total << " draws of seed " << o.seed << " (families " << families_text(o) << "), "
      << o.jobs << " job(s), deadlines on " << clock_text(o) << "\n";
  out << "goals met: " << result.met << " of " << total << " (rate " << fixed(result.rate(), 3) << ")\n";
  int wear = 0, position = 0, heading = 0, effort = 0, deadlines = 0, no_stop = 0;
  for (const DrawResult& r : result.draws) {
    wear += r.goals.ran && r.goals.wear;
    position += r.goals.ran && r.goals.position;
    heading += r.goals.ran && r.goals.heading;
    effort += r.goals.ran && r.goals.steering_effort;
    deadlines += r.goals.ran && r.goals.deadlines;
    no_stop += r.goals.ran && r.goals.no_safe_stop;
  }
  out << "  each goal: wear " << wear << ", position " << position << ", heading " << heading
      << ", steering effort " << effort << ", no deadline miss " << deadlines << ", no safe stop " << no_stop
      << " (of " << total << ")\n";
  const Spread effort_spread = spread_of(result, &EnvelopeGoals::steering_effort_ratio);
  const Spread wear_spread = spread_of(result, &EnvelopeGoals::wear_ratio);
  out << "steering-effort ratio (wear_mpc / max(baseline, 0.1 rad^2/s)): median " << ratio_text(effort_spread.median)
      << ", p90 " << ratio_text(effort_spread.p90) << ", max " << ratio_text(effort_spread.max) << "\n";
  out << "wear ratio (wear_mpc / baseline):            median " << ratio_text(wear_spread.median) << ", p90 "
      << ratio_text(wear_spread.p90) << ", max " << ratio_text(wear_spread.max) << "  (over "
      << wear_spread.count << " draws that ran)\n";
  out << "gross draws (wear > 2x the baseline's or RMSE > the baseline's + 5 cm): " << result.gross << "\n";
  out << "draws that failed to run: " << result.failed << "\n";
  for (const DrawResult& r : result.draws) {
    if (r.error.empty() && r.goals.ran) continue;
    const std::string why = !r.error.empty()              ? r.error
                            : !r.wear_mpc.failure.empty() ? "wear_mpc: " + r.wear_mpc.failure
                                                          : "kinematic_baseline: " + r.baseline.failure;
    out << "  draw " << r.draw.index << " (" << r.scenario_file << "): " << why << "\n";
  }
  out << "worst draws (by wear ratio, ties by RMSE excess):\n";
  char line[1024];
  std::snprintf(line, sizeof line, "  %5s %-15s %-18s %-38s %10s %11s %5s  %s\n", "draw", "family", "vehicle",
                "conditions", "wear ratio", "rmse +[mm]", "goals", "scenario");
  out << line;
  for (const DrawResult* r : worst_draws(result)) {
    const std::string vehicle =
        std::to_string(r->draw.vehicle.modules()) + " mod, " + fixed(r->draw.vehicle.mass, 0) + " kg";
    std::snprintf(line, sizeof line, "  %5d %-15s %-18s %-38s %10s %11s %5s  %s\n", r->draw.index,
                  to_string(r->draw.family), vehicle.c_str(), conditions_summary(r->draw.conditions).c_str(),
                  r->goals.ran ? ratio_text(r->goals.wear_ratio).c_str() : "failed",
                  r->goals.ran ? fixed(r->goals.rmse_excess_m * 1000.0, 1).c_str() : "-",
                  r->goals.all() ? "met" : "not", r->scenario_file.c_str());
    out << line;
  }
  return out.str();
}

std::string envelope_json(const EnvelopeResult& result) {
  const EnvelopeOptions& o = result.options;
  nlohmann::json draws = nlohmann::json::array();
  for (const DrawResult& r : result.draws) {
    const VehicleDraw& v = r.draw.vehicle;
    const ConditionsDraw& c = r.draw.conditions;
    const EnvelopeGoals& g = r.goals;
    nlohmann::json d = {
        {"index", r.draw.index},
        {"scenario_file", r.scenario_file},
        {"family", to_string(r.draw.family)},
        {"reference", r.draw.reference.summary},
        {"duration_s", r.draw.duration},
        {"vehicle",
         {{"modules", v.modules()},
          {"layout", v.layout},
          {"mass_kg", v.mass},
          {"yaw_inertia_kg_m2", v.yaw_inertia},
          {"wheel_radius_m", v.wheel_radius},
          {"steering_limit_rad", v.steering_limit},
          {"mu", v.mu},
          {"drive_speed_m_s", v.drive_speed},
          {"drive_acceleration_m_s2", v.drive_acceleration},
          {"steering_rate_rad_s", v.steering_rate},
          {"steering_time_constant_s", v.steering_time_constant},
          {"drive_time_constant_s", v.drive_time_constant}}},
        {"conditions",
         {{"control_period_s", c.control_period},
          {"solve_budget_s", c.solve_budget},
          {"measurement_delay_steps", c.measurement_delay_steps},
          {"latency_s", c.latency},
          {"noise", c.noise},
          {"simulator_seed", c.simulator_seed}}},
        {"ran", g.ran},
        {"error", r.error.empty() ? nlohmann::json() : nlohmann::json(r.error)},
        {"wear_mpc", run_json(r.wear_mpc)},
        {"kinematic_baseline", run_json(r.baseline)},
        {"wear_ratio", number_or_null(g.wear_ratio)},
        {"steering_effort_ratio", number_or_null(g.steering_effort_ratio)},
        {"rmse_excess_m", number_or_null(g.rmse_excess_m)},
        {"goals",
         {{"wear", g.wear},
          {"position_rmse", g.position},
          {"heading_rms", g.heading},
          {"steering_effort", g.steering_effort},
          {"no_deadline_miss", g.deadlines},
          {"no_safe_stop", g.no_safe_stop},
          {"all", g.all()}}},
        {"gross", g.gross},
    };
    draws.push_back(std::move(d));
  }
  const nlohmann::json j = {
      {"seed", o.seed},
      {"draws", static_cast<int>(result.draws.size())},
      {"families", families_text(o)},
      {"jobs", o.jobs},
      {"clock", o.work_clock > 0.0 ? nlohmann::json({{"work_clock_s_per_read", o.work_clock},
                                                   {"work_clock_s_per_module_evaluation", o.work_clock_evaluation}})
                                   : nlohmann::json("wall")},
      {"controller_file", o.controller_file},
      {"baseline_file", o.baseline_file},
      {"goals_met", result.met},
      {"rate", result.rate()},
      {"gross", result.gross},
      {"failed", result.failed},
      {"wear_ratio", spread_json(spread_of(result, &EnvelopeGoals::wear_ratio))},
      {"steering_effort_ratio", spread_json(spread_of(result, &EnvelopeGoals::steering_effort_ratio))},
      {"per_draw", draws},
  };
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

void write_envelope_json(const EnvelopeResult& result, const std::string& path) {
  config::write_text_file_atomically(path, envelope_json(result));
}

}  // namespace swerve
