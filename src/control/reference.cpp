#include "swerve/control/reference.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "swerve/core/config_error.hpp"
#include "swerve/core/constants.hpp"
#include "swerve/core/option_fields.hpp"
#include "swerve/core/text_file.hpp"
#include "swerve/kinematics/se2.hpp"

namespace swerve {
namespace {

constexpr int kTableIntervals = 4000;  // Hermite interpolation error ~ h^4: far below 1e-9 m here

[[noreturn]] void reject(const std::string& what) { throw ConfigError(what); }

std::string number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

class LineCurve final : public PlanarCurve {
 public:
  LineCurve(const Eigen::Vector2d& start, double direction, double length)
      : start_(start), unit_(std::cos(direction), std::sin(direction)), length_(length) {}
  double parameter_end() const override { return length_; }
  Eigen::Vector2d point(double u) const override { return start_ + u * unit_; }
  Eigen::Vector2d first_derivative(double) const override { return unit_; }
  Eigen::Vector2d second_derivative(double) const override { return Eigen::Vector2d::Zero(); }

 private:
  Eigen::Vector2d start_, unit_;
  double length_;
};

class ArcCurve final : public PlanarCurve {
 public:
  ArcCurve(const Eigen::Vector2d& start, double direction, double radius, double sweep)
      : radius_(radius), turn_(sweep > 0 ? 1.0 : -1.0), sweep_(std::abs(sweep)) {
    const Eigen::Vector2d left_normal(-std::sin(direction), std::cos(direction));
    center_ = start + turn_ * radius * left_normal;
    phase0_ = direction - turn_ * kPi / 2.0;
  }
  double parameter_end() const override { return sweep_; }
  Eigen::Vector2d point(double u) const override {
    const double phase = phase0_ + turn_ * u;
    return center_ + radius_ * Eigen::Vector2d(std::cos(phase), std::sin(phase));
  }
  Eigen::Vector2d first_derivative(double u) const override {
    const double phase = phase0_ + turn_ * u;
    return turn_ * radius_ * Eigen::Vector2d(-std::sin(phase), std::cos(phase));
  }
  Eigen::Vector2d second_derivative(double u) const override {
    const double phase = phase0_ + turn_ * u;
    return -radius_ * Eigen::Vector2d(std::cos(phase), std::sin(phase));
  }

 private:
  Eigen::Vector2d center_;
  double radius_, turn_, sweep_, phase0_ = 0.0;
};

class SineCurve final : public PlanarCurve {
 public:
  SineCurve(double amplitude, double wavelength, double length_x)
      : amplitude_(amplitude), wavenumber_(2.0 * kPi / wavelength), length_x_(length_x) {}
  double parameter_end() const override { return length_x_; }
  Eigen::Vector2d point(double u) const override { return {u, amplitude_ * std::sin(wavenumber_ * u)}; }
  Eigen::Vector2d first_derivative(double u) const override {
    return {1.0, amplitude_ * wavenumber_ * std::cos(wavenumber_ * u)};
  }
  Eigen::Vector2d second_derivative(double u) const override {
    return {0.0, -amplitude_ * wavenumber_ * wavenumber_ * std::sin(wavenumber_ * u)};
  }

 private:
  double amplitude_, wavenumber_, length_x_;
};

// Lemniscate of Gerono: (a sin u, a sin u cos u); |p'| = a sqrt(cos^2 u + cos^2 2u) never vanishes.
class FigureEightCurve final : public PlanarCurve {
 public:
  FigureEightCurve(double size, int loops) : size_(size), loops_(loops) {}
  double parameter_end() const override { return 2.0 * kPi * loops_; }
  Eigen::Vector2d point(double u) const override {
    return size_ * Eigen::Vector2d(std::sin(u), 0.5 * std::sin(2.0 * u));
  }
  Eigen::Vector2d first_derivative(double u) const override {
    return size_ * Eigen::Vector2d(std::cos(u), std::cos(2.0 * u));
  }
  Eigen::Vector2d second_derivative(double u) const override {
    return size_ * Eigen::Vector2d(-std::sin(u), -2.0 * std::sin(2.0 * u));
  }

 private:
  double size_;
  int loops_;
};

void require_positive(const char* field, double value) {
  if (!std::isfinite(value) || value <= 0.0) reject(std::string(field) + " = " + number(value) + ": must be > 0");
}

// Cubic Hermite interpolation on [x0, x1] with values and slopes.
double hermite(double x, double x0, double x1, double y0, double y1, double m0, double m1) {
  const double h = x1 - x0;
  const double s = (x - x0) / h;
  const double s2 = s * s, s3 = s2 * s;
  return (2 * s3 - 3 * s2 + 1) * y0 + (s3 - 2 * s2 + s) * h * m0 + (-2 * s3 + 3 * s2) * y1 +
         (s3 - s2) * h * m1;
}

// Slope at x[at] of the interpolating polynomial through up to 4 points starting at `first`
// (Lagrange form): third-order accurate end slopes for the clamped spline.
double end_slope(const double* x, const double* y, std::size_t first, std::size_t count, std::size_t at) {
  double slope = 0.0;
  for (std::size_t j = first; j < first + count; ++j) {
    double derivative = 0.0;  // L_j'(x[at])
    if (j == at) {
      for (std::size_t k = first; k < first + count; ++k) {
        if (k != j) derivative += 1.0 / (x[at] - x[k]);
      }
    } else {
      derivative = 1.0 / (x[j] - x[at]);
      for (std::size_t k = first; k < first + count; ++k) {
        if (k != j && k != at) derivative *= (x[at] - x[k]) / (x[j] - x[k]);
      }
    }
    slope += derivative * y[j];
  }
  return slope;
}

// Clamped cubic spline second derivatives m (end slopes from end_slope) of n >= 2 points, by the
// Thomas algorithm; `scratch` holds 3n values. No allocation: the planner-fed reference calls it.
void clamped_spline_second_derivatives(const double* x, const double* y, std::size_t n, double* m, double* scratch) {
  const std::size_t fit = std::min<std::size_t>(4, n);
  const double slope_start = end_slope(x, y, 0, fit, 0);
  const double slope_end = end_slope(x, y, n - fit, fit, n - 1);
  double* lower = scratch;
  double* diagonal = scratch + n;
  double* upper = scratch + 2 * n;
  double* rhs = m;  // solved in place
  const double h_first = x[1] - x[0], h_last = x[n - 1] - x[n - 2];
  lower[0] = 0.0;
  diagonal[0] = h_first / 3.0;
  upper[0] = h_first / 6.0;
  rhs[0] = (y[1] - y[0]) / h_first - slope_start;
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const double h0 = x[i] - x[i - 1], h1 = x[i + 1] - x[i];
    lower[i] = h0 / 6.0;
    diagonal[i] = (h0 + h1) / 3.0;
    upper[i] = h1 / 6.0;
    rhs[i] = (y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0;
  }
  lower[n - 1] = h_last / 6.0;
  diagonal[n - 1] = h_last / 3.0;
  upper[n - 1] = 0.0;
  rhs[n - 1] = slope_end - (y[n - 1] - y[n - 2]) / h_last;
  for (std::size_t i = 1; i < n; ++i) {
    const double factor = lower[i] / diagonal[i - 1];
    diagonal[i] -= factor * upper[i - 1];
    rhs[i] -= factor * rhs[i - 1];
  }
  m[n - 1] = rhs[n - 1] / diagonal[n - 1];
  for (std::size_t i = n - 1; i-- > 0;) m[i] = (rhs[i] - upper[i] * m[i + 1]) / diagonal[i];
}

}  // namespace

std::shared_ptr<const PlanarCurve> make_line_curve(const Eigen::Vector2d& start, double direction, double length) {
  if (!start.allFinite()) reject("line.start is not finite");
  if (!std::isfinite(direction)) reject("line.direction = " + number(direction) + ": must be finite");
  require_positive("line.length", length);
  return std::make_shared<LineCurve>(start, direction, length);
}

std::shared_ptr<const PlanarCurve> make_arc_curve(const Eigen::Vector2d& start, double direction, double radius,
                                                  double sweep) {
  if (!start.allFinite()) reject("arc.start is not finite");
  if (!std::isfinite(direction)) reject("arc.direction = " + number(direction) + ": must be finite");
  require_positive("arc.radius", radius);
  if (!std::isfinite(sweep) || sweep == 0.0) reject("arc.sweep = " + number(sweep) + ": must be non-zero");
  return std::make_shared<ArcCurve>(start, direction, radius, sweep);
}

std::shared_ptr<const PlanarCurve> make_sine_curve(double amplitude, double wavelength, double length_x) {
  if (!std::isfinite(amplitude)) reject("curve.amplitude = " + number(amplitude) + ": must be finite");
  require_positive("curve.wavelength", wavelength);
  require_positive("curve.length", length_x);
  return std::make_shared<SineCurve>(amplitude, wavelength, length_x);
}

std::shared_ptr<const PlanarCurve> make_figure_eight_curve(double size, int loops) {
  require_positive("figure_eight.size", size);
  if (loops < 1) reject("figure_eight.loops = " + std::to_string(loops) + ": must be >= 1");
  return std::make_shared<FigureEightCurve>(size, loops);
}

PathReference::PathReference(std::shared_ptr<const PlanarCurve> curve, SpeedProfile profile, double heading_offset)
    : curve_(std::move(curve)), profile_(profile), heading_offset_(heading_offset) {
  if (!curve_) reject("PathReference.curve: must not be null");
  require_positive("speed_profile.speed", profile_.speed);
  if (!std::isfinite(profile_.acceleration) || profile_.acceleration < 0.0) {
    reject("speed_profile.acceleration = " + number(profile_.acceleration) + ": must be >= 0");
  }
  if (!std::isfinite(heading_offset_)) reject("heading_offset = " + number(heading_offset_) + ": must be finite");
  const double u_end = curve_->parameter_end();
  require_positive("curve.parameter_end", u_end);

  // Arc length by Simpson's rule on each interval; du/ds = 1/|p'(u)| exactly at the nodes.
  const double h = u_end / kTableIntervals;
  table_s_.resize(kTableIntervals + 1);
  table_u_.resize(kTableIntervals + 1);
  table_du_ds_.resize(kTableIntervals + 1);
  double s = 0.0;
  for (int j = 0; j <= kTableIntervals; ++j) {
    const double u = h * j;
    const double speed = curve_->first_derivative(u).norm();
    if (!(speed > 1e-9)) reject("curve: the path has a cusp (zero tangent) at parameter " + number(u));
    if (j > 0) {
      const double u_prev = u - h;
      s += h / 6.0 *
           (curve_->first_derivative(u_prev).norm() + 4.0 * curve_->first_derivative(u_prev + h / 2).norm() + speed);
    }
    const auto index = static_cast<std::size_t>(j);
    table_s_[index] = s;
    table_u_[index] = u;
    table_du_ds_[index] = 1.0 / speed;
  }
  length_ = s;

  // Trapezoidal (or triangular) speed profile over the length.
  const double v = profile_.speed, a = profile_.acceleration;
  if (a <= 0.0) {
    ramp_time_ = 0.0;
    duration_ = length_ / v;
  } else {
    const double ramps = profile_.stop_at_end ? 2.0 : 1.0;
    const double ramp_distance = v * v / (2.0 * a);
    if (ramps * ramp_distance <= length_) {
      ramp_time_ = v / a;
      duration_ = ramps * ramp_time_ + (length_ - ramps * ramp_distance) / v;
    } else {  // never reaches cruise speed: peak where the ramps meet (or at the end)
      const double peak = std::sqrt(2.0 * a * length_ / ramps);
      profile_.speed = peak;
      ramp_time_ = peak / a;
      duration_ = ramps * ramp_time_;
    }
  }
}

double PathReference::arc_length_at(double t, double* speed) const noexcept {
  const double v = profile_.speed, a = profile_.acceleration;
  if (t < 0.0) {
    *speed = 0.0;
    return 0.0;
  }
  if (t > duration_) {
    *speed = 0.0;
    return length_;
  }
  if (ramp_time_ <= 0.0) {
    *speed = v;
    return v * t;
  }
  if (t < ramp_time_) {
    *speed = a * t;
    return 0.5 * a * t * t;
  }
  const double ramp_distance = 0.5 * a * ramp_time_ * ramp_time_;
  if (profile_.stop_at_end && t > duration_ - ramp_time_) {
    const double remaining = duration_ - t;
    *speed = a * remaining;
    return length_ - 0.5 * a * remaining * remaining;
  }
  *speed = v;
  return ramp_distance + v * (t - ramp_time_);
}

double PathReference::parameter_at(double s) const noexcept {
  if (s <= 0.0) return 0.0;
  if (s >= length_) return table_u_.back();
  const auto upper = std::upper_bound(table_s_.begin(), table_s_.end(), s);
  const auto j = static_cast<std::size_t>(std::max<std::ptrdiff_t>(1, upper - table_s_.begin())) - 1;
  return hermite(s, table_s_[j], table_s_[j + 1], table_u_[j], table_u_[j + 1], table_du_ds_[j],
                 table_du_ds_[j + 1]);
}

ReferenceSample PathReference::sample(double t) const noexcept {
  if (t > duration_ && !profile_.stop_at_end) {
    // A path that ends at speed describes a vehicle still moving when the path (or the experiment)
    // ends: past its end it goes on at its final twist, on the arc that twist draws. Holding the
    // final pose instead would ask for a stop in zero distance, which a controller that looks past
    // the end can only meet by braking before it.
    ReferenceSample out = sample(duration_);
    out.pose_world = compose_pose(out.pose_world, out.twist_body * (t - duration_));
    return out;
  }
  double speed = 0.0;
  const double s = arc_length_at(t, &speed);
  const double u = parameter_at(s);
  const Eigen::Vector2d p = curve_->point(u);
  const Eigen::Vector2d dp = curve_->first_derivative(u);
  const Eigen::Vector2d ddp = curve_->second_derivative(u);
  const double tangent = std::atan2(dp.y(), dp.x());
  const double norm = dp.norm();
  const double curvature = (dp.x() * ddp.y() - dp.y() * ddp.x()) / (norm * norm * norm);
  ReferenceSample out;
  out.pose_world << p.x(), p.y(), wrap_angle(tangent + heading_offset_);
  // World velocity speed*(cos tangent, sin tangent) seen from a body whose heading is
  // tangent + offset: the body sees it rotated by -offset. The heading turns with the tangent.
  out.twist_body << speed * std::cos(heading_offset_), -speed * std::sin(heading_offset_), curvature * speed;
  return out;
}

SplineTrajectory::SplineTrajectory(int capacity) {
  const auto n = static_cast<std::size_t>(std::max(capacity, 0));
  t_.assign(n, 0.0);
  for (int c = 0; c < 3; ++c) {
    value_[c].assign(n, 0.0);
    second_[c].assign(n, 0.0);
    twist_[c].assign(n, 0.0);
  }
  scratch_.assign(3 * n, 0.0);
}

void SplineTrajectory::assign(const Eigen::Ref<const Eigen::MatrixXd>& rows) noexcept {
  count_ = static_cast<int>(rows.rows());
  has_twist_ = rows.cols() == 7;
  double previous_psi = 0.0;
  for (int i = 0; i < count_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    t_[k] = rows(i, 0);
    value_[0][k] = rows(i, 1);
    value_[1][k] = rows(i, 2);
    // Unwrapped, so the spline never sees a 2 pi jump.
    const double psi = i == 0 ? rows(i, 3) : previous_psi + wrap_angle(rows(i, 3) - previous_psi);
    value_[2][k] = previous_psi = psi;
    for (int c = 0; c < 3 && has_twist_; ++c) twist_[c][k] = rows(i, 4 + c);
  }
  const auto n = static_cast<std::size_t>(count_);
  for (int c = 0; c < 3; ++c) {
    clamped_spline_second_derivatives(t_.data(), value_[c].data(), n, second_[c].data(), scratch_.data());
  }
}

ReferenceSample SplineTrajectory::sample(double t_query) const noexcept {
  ReferenceSample out;
  const auto n = static_cast<std::size_t>(count_);
  const double first = t_[0], last = t_[n - 1];
  const double t = std::clamp(t_query, first, last);
  const bool outside = t_query < first || t_query > last;
  const auto upper = std::upper_bound(t_.begin(), t_.begin() + count_, t);
  const auto j = std::min(static_cast<std::size_t>(std::max<std::ptrdiff_t>(1, upper - t_.begin())) - 1, n - 2);
  const double h = t_[j + 1] - t_[j];
  const double a = (t_[j + 1] - t) / h, b = (t - t_[j]) / h;
  double value[3], rate[3];
  for (int c = 0; c < 3; ++c) {
    const std::vector<double>& y = value_[c];
    const std::vector<double>& m = second_[c];
    value[c] = a * y[j] + b * y[j + 1] + ((a * a * a - a) * m[j] + (b * b * b - b) * m[j + 1]) * h * h / 6.0;
    rate[c] = (y[j + 1] - y[j]) / h + (-(3 * a * a - 1) * m[j] + (3 * b * b - 1) * m[j + 1]) * h / 6.0;
  }
  out.pose_world << value[0], value[1], wrap_angle(value[2]);
  if (outside) return out;  // before the start or past the end: hold the pose, zero twist
  if (has_twist_) {
    for (int c = 0; c < 3; ++c) out.twist_body[c] = a * twist_[c][j] + b * twist_[c][j + 1];
  } else {
    const double c = std::cos(value[2]), s = std::sin(value[2]);
    out.twist_body << c * rate[0] + s * rate[1], -s * rate[0] + c * rate[1], rate[2];
  }
  return out;
}

SampledReference::SampledReference(const std::vector<std::vector<double>>& rows)
    : spline_(static_cast<int>(std::min<std::size_t>(rows.size(), std::numeric_limits<int>::max()))) {
  if (rows.size() < 2) reject("reference: need at least 2 rows, got " + std::to_string(rows.size()));
  const std::size_t width = rows.front().size();
  if (width != 4 && width != 7) {
    reject("reference row 0: expected 4 (t, x, y, psi) or 7 (+ vx, vy, r) values, got " + std::to_string(width));
  }
  Eigen::MatrixXd checked(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(width));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& row = rows[i];
    if (row.size() != width) {
      reject("reference row " + std::to_string(i) + ": expected " + std::to_string(width) + " values, got " +
             std::to_string(row.size()));
    }
    for (std::size_t c = 0; c < width; ++c) {
      if (!std::isfinite(row[c])) reject("reference row " + std::to_string(i) + " column " + std::to_string(c) +
                                         " = " + number(row[c]) + ": must be finite");
      checked(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(c)) = row[c];
    }
    if (i > 0 && !(row[0] > rows[i - 1][0])) {
      reject("reference row " + std::to_string(i) + ": t = " + number(row[0]) + ": must be greater than the previous t");
    }
  }
  spline_.assign(checked);
}

ReferenceSample SampledReference::sample(double t_relative) const noexcept {
  return spline_.sample(spline_.first_time() + t_relative);
}

std::string reference_step_problem(const Eigen::Vector3d& previous_txy, const Eigen::Vector3d& txy, double max_speed,
                                   const std::string& previous_name) {
  const double dt = txy[0] - previous_txy[0];
  if (!(dt > 0.0)) {
    return "t = " + Bound::number(txy[0]) + " is not after " + previous_name + "'s t = " + Bound::number(previous_txy[0]);
  }
  const double step = std::hypot(txy[1] - previous_txy[1], txy[2] - previous_txy[2]);
  if (std::isfinite(max_speed) && step > 1.01 * max_speed * dt) {
    return "the position moves " + Bound::number(step) + " m in " + Bound::number(dt) + " s from " + previous_name +
           " (" + Bound::number(step / dt) + " m/s), faster than the vehicle's drive speed of " +
           Bound::number(max_speed) + " m/s";
  }
  return {};
}

namespace {

// `lap` (rows of t, x, y, psi[, twist in the body frame]) driven `laps` times, each lap moved
// rigidly so that it starts where and when the previous one ended: its first sample is the
// previous lap's last, so a path that ends at speed goes on at speed.
std::vector<std::vector<double>> repeated_laps(const std::vector<std::vector<double>>& lap, int laps) {
  std::vector<std::vector<double>> rows = lap;
  const std::vector<double>& first = lap.front();
  const double lap_time = lap.back()[0] - first[0];
  for (int l = 1; l < laps; ++l) {
    const std::vector<double> end = rows.back();  // the last lap's end: t, x, y, psi
    const double turn = end[3] - first[3];
    const double c = std::cos(turn), s = std::sin(turn);
    for (std::size_t k = 1; k < lap.size(); ++k) {
      const std::vector<double>& sample = lap[k];
      std::vector<double> row = sample;
      const double dx = sample[1] - first[1], dy = sample[2] - first[2];
      row[0] = sample[0] + l * lap_time;
      row[1] = end[1] + c * dx - s * dy;
      row[2] = end[2] + s * dx + c * dy;
      row[3] = sample[3] + turn;
      rows.push_back(std::move(row));
    }
  }
  return rows;
}

}  // namespace

std::unique_ptr<SampledReference> load_reference_csv(const std::string& file_path, double max_speed, int laps) {
  // Read whole and bounded: a directory, /dev/zero or a pipe named as the CSV is refused before
  // reading (a getline on /dev/zero grew one line until the process ran out of memory).
  config::TextFileRules rules;
  rules.max_bytes = kMaxReferenceCsvBytes;
  rules.kind_plural = "reference CSV files";
  rules.format = "CSV";
  std::istringstream in(config::read_text_file(file_path, rules));
  const std::string shown = printable_value(file_path, std::string::npos);
  std::string line;
  if (!std::getline(in, line)) reject(shown + ": empty file (expected a header t,x,y,psi[,vx,vy,r])");
  const std::string header = line.substr(0, line.find_last_not_of(" \r") + 1);
  std::size_t width = 0;
  if (header == "t,x,y,psi") {
    width = 4;
  } else if (header == "t,x,y,psi,vx,vy,r") {
    width = 7;
  } else {
    reject(shown + ":1: header '" + printable_value(header) + "': expected 't,x,y,psi' or 't,x,y,psi,vx,vy,r'");
  }
  std::vector<std::vector<double>> rows;
  int line_number = 1;
  int previous_line = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.find_first_not_of(" \r\t") == std::string::npos) continue;
    std::vector<double> row;
    std::stringstream fields(line);
    std::string field;
    while (std::getline(fields, field, ',')) {
      char* end = nullptr;
      const double value = std::strtod(field.c_str(), &end);
      if (end == field.c_str() || std::string(end).find_first_not_of(" \r\t") != std::string::npos) {
        reject(shown + ":" + std::to_string(line_number) + ": '" + printable_value(field) + "' is not a number");
      }
      row.push_back(value);
    }
    if (row.size() != width) {
      reject(shown + ":" + std::to_string(line_number) + ": expected " + std::to_string(width) +
             " values, got " + std::to_string(row.size()));
    }
    if (!rows.empty() && std::isfinite(row[0]) && std::isfinite(rows.back()[0])) {
      const std::vector<double>& previous = rows.back();
      const std::string problem =
          reference_step_problem({previous[0], previous[1], previous[2]}, {row[0], row[1], row[2]}, max_speed,
                                 "line " + std::to_string(previous_line));
      if (!problem.empty()) reject(shown + ":" + std::to_string(line_number) + ": " + problem);
    }
    rows.push_back(std::move(row));
    previous_line = line_number;
  }
  if (rows.size() < 2) {
    reject(shown + ": " + std::to_string(rows.size()) + " sample(s); a reference needs at least 2");
  }
  if (laps < 1) reject(shown + ": laps = " + std::to_string(laps) + ": must be >= 1");
  if (static_cast<double>(laps) * static_cast<double>(rows.size()) > static_cast<double>(kMaxReferenceSamples)) {
    reject(shown + ": laps = " + std::to_string(laps) + ": " + std::to_string(rows.size()) +
           " samples a lap would make more than " + std::to_string(kMaxReferenceSamples) + " in all");
  }
  try {
    return std::make_unique<SampledReference>(laps > 1 ? repeated_laps(rows, laps) : rows);
  } catch (const ConfigError& error) {
    reject(shown + ": " + error.what());
  }
}

const char* to_string(TrajectoryStatus status) noexcept {
  switch (status) {
    case TrajectoryStatus::kAccepted:
      return "accepted";
    case TrajectoryStatus::kTooFewSamples:
      return "fewer than 2 samples";
    case TrajectoryStatus::kTooManySamples:
      return "more samples than the capacity";
    case TrajectoryStatus::kWrongWidth:
      return "expected 4 columns (t, x, y, psi) or 7 (+ vx, vy, r)";
    case TrajectoryStatus::kNonFinite:
      return "a value is NaN or infinite";
    case TrajectoryStatus::kTimeNotIncreasing:
      return "t must be greater than the previous sample's";
    case TrajectoryStatus::kBusy:
      return "another thread was publishing (one planner thread only)";
  }
  return "unknown";
}

std::string TrajectoryCheck::describe() const {
  std::string text;
  if (sample >= 0) text += "sample " + std::to_string(sample);
  if (column >= 0) text += " column " + std::to_string(column);
  if (!text.empty()) text += ": ";
  return text + to_string(status);
}

TrajectoryReference::TrajectoryReference(int capacity, double max_age) : capacity_(capacity), max_age_(max_age) {
  if (capacity < 2) reject("TrajectoryReference.capacity = " + std::to_string(capacity) + ": must be >= 2");
  if (std::isnan(max_age) || max_age <= 0.0) {
    reject("TrajectoryReference.max_age = " + number(max_age) + ": must be > 0 (s; infinity: never stale)");
  }
  for (Buffer& b : buffers_) b.spline = SplineTrajectory(capacity);
}

TrajectoryCheck TrajectoryReference::publish(const Eigen::Ref<const Eigen::MatrixXd>& samples) noexcept {
  TrajectoryCheck check;
  const auto rows = static_cast<int>(samples.rows());
  const auto width = static_cast<int>(samples.cols());
  if (width != 4 && width != 7) check.status = TrajectoryStatus::kWrongWidth;
  else if (rows < 2) check.status = TrajectoryStatus::kTooFewSamples;
  else if (rows > capacity_) check.status = TrajectoryStatus::kTooManySamples;
  for (int i = 0; i < rows && check.accepted(); ++i) {
    for (int c = 0; c < width; ++c) {
      if (!std::isfinite(samples(i, c))) {
        check = {TrajectoryStatus::kNonFinite, i, c};
        break;
      }
    }
    if (check.accepted() && i > 0 && !(samples(i, 0) > samples(i - 1, 0))) {
      check = {TrajectoryStatus::kTimeNotIncreasing, i, 0};
    }
  }
  if (!check.accepted()) return check;
  if (publishing_.test_and_set(std::memory_order_acquire)) return {TrajectoryStatus::kBusy, -1, -1};
  Buffer& b = buffers_[static_cast<std::size_t>(back_)];
  b.spline.assign(samples);
  b.version = ++published_;
  // Hand the filled buffer over; take whichever the middle held (never the reader's).
  back_ = middle_.exchange(back_ | kDirty, std::memory_order_acq_rel) & ~kDirty;
  publishing_.clear(std::memory_order_release);
  return check;
}

void TrajectoryReference::begin_cycle() const noexcept {
  if ((middle_.load(std::memory_order_acquire) & kDirty) == 0) return;
  front_ = middle_.exchange(front_, std::memory_order_acq_rel) & ~kDirty;
  front_version_ = buffers_[static_cast<std::size_t>(front_)].version;
}

ReferenceSample TrajectoryReference::sample(double t) const noexcept {
  const SplineTrajectory& spline = buffers_[static_cast<std::size_t>(front_)].spline;
  return spline.size() < 2 ? ReferenceSample{} : spline.sample(t);
}

double TrajectoryReference::duration() const noexcept {
  const SplineTrajectory& spline = buffers_[static_cast<std::size_t>(front_)].spline;
  return spline.size() < 2 ? 0.0 : spline.last_time();
}

const char* TrajectoryReference::unusable(double t) const noexcept {
  const SplineTrajectory& spline = buffers_[static_cast<std::size_t>(front_)].spline;
  if (spline.size() < 2) return "reference: no trajectory published yet";
  if (t - spline.first_time() > max_age_) {
    return "reference: the trajectory is stale (its first sample is older than max_age)";
  }
  return nullptr;
}

}  // namespace swerve
