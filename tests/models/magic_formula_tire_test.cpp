// Magic Formula tire and slip definitions against independent truth: symmetry, the slope B C D at
// the origin, the peak D at the closed-form peak slip, saturation to D sin(C pi/2), a hand table,
// the friction ellipse under combined slip, and exact signs and zeros down to a wheel at rest.
#include "swerve/models/magic_formula_tire.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "swerve/core/config_error.hpp"
#include "swerve/models/jet.hpp"

namespace swerve {
namespace {

constexpr double kPiTest = 3.14159265358979323846;
constexpr double kFz = 1000.0;  // N
constexpr double kMu = 0.8;     // D = 800 N

MagicFormulaParams table_params() {
  MagicFormulaParams p;
  p.mu = kMu;
  p.longitudinal = {10.0, 1.65, 0.3};
  p.lateral = {15.0, 1.3, -0.5};
  p.combined_slip = CombinedSlipMethod::kNone;
  return p;
}

TEST(MagicFormulaTire, LongitudinalForceMatchesHandTable) {
  const MagicFormulaTire<double> tire(table_params());
  // D sin(C atan(B x - E (B x - atan B x))) with B = 10, C = 1.65, E = 0.3, D = 800, evaluated by
  // hand (e.g. x = 0.1: B x = 1, 1 - 0.3 (1 - 0.7854) = 0.93562, atan = 0.75210, x 1.65 = 1.24097,
  // sin = 0.94612, x 800 = 756.90).
  const std::vector<std::pair<double, double>> table = {
      {-0.5, -656.5956768678545}, {-0.05, -545.6388977994987}, {0.02, 255.03978585214458},
      {0.1, 756.8987354053887},   {0.14, 797.2716169311611},   {0.3, 740.7225831115186},
      {1.0, 557.0187514532355}};
  for (const auto& [kappa, expected] : table) {
    EXPECT_NEAR(tire.pure_longitudinal(kappa, kFz), expected, 1e-9) << "kappa = " << kappa;
    EXPECT_NEAR(tire.forces(kappa, 0.0, kFz).fx_wheel, expected, 1e-9) << "kappa = " << kappa;
  }
}

TEST(MagicFormulaTire, LateralForceMatchesHandTable) {
  const MagicFormulaTire<double> tire(table_params());
  const std::vector<std::pair<double, double>> table = {
      {-0.3, -773.2941849128051}, {-0.02, -299.69266325298594}, {0.01, 154.43439219085636},
      {0.05, 616.4559672845438},  {0.2, 791.8392237919281},     {0.5, 752.0012481523806},
      {1.2, 729.9074837202878}};
  for (const auto& [alpha, expected] : table) {
    EXPECT_NEAR(tire.pure_lateral(alpha, kFz), expected, 1e-9) << "alpha = " << alpha;
    EXPECT_NEAR(tire.forces(0.0, alpha, kFz).fy_wheel, expected, 1e-9) << "alpha = " << alpha;
  }
}

// With E = 0 the curvature term is skipped (one arctangent fewer): the force must be the general
// formula's bit for bit, and its Jet derivative the hand-derived D C B cos(C atan(B x)) / (1 + (B x)^2).
TEST(MagicFormulaTire, ZeroCurvatureFactorGivesTheGeneralFormulasBitsAndItsDerivative) {
  MagicFormulaParams p = table_params();
  p.longitudinal.e = 0.0;
  const MagicFormulaTire<double> tire(p);
  const MagicFormulaTire<ModelJet> jet_tire(p);
  const double b = p.longitudinal.b;
  const double c = p.longitudinal.c;
  const double d = kMu * kFz;
  for (const double kappa : {-0.7, -0.05, 0.0, 1e-7, 0.02, 0.1, 0.3, 2.0}) {
    const double bx = b * kappa;
    const double general = d * std::sin(c * std::atan(bx - p.longitudinal.e * (bx - std::atan(bx))));
    EXPECT_EQ(tire.pure_longitudinal(kappa, kFz), general) << "kappa = " << kappa;
    ModelJet kappa_jet(kappa, 0);
    const ModelJet force = jet_tire.pure_longitudinal(kappa_jet, ModelJet(kFz));
    EXPECT_EQ(force.a, general) << "kappa = " << kappa;
    const double slope = d * c * b * std::cos(c * std::atan(bx)) / (1.0 + bx * bx);
    EXPECT_NEAR(force.v[0], slope, 1e-9 * std::abs(slope) + 1e-9) << "kappa = " << kappa;
  }
}

TEST(MagicFormulaTire, ForcesAreOddInSlip) {
  for (auto method : {CombinedSlipMethod::kNone, CombinedSlipMethod::kEllipseCap, CombinedSlipMethod::kNormalizedSlip}) {
    MagicFormulaParams p = table_params();
    p.combined_slip = method;
    const MagicFormulaTire<double> tire(p);
    for (double kappa : {0.0, 0.01, 0.1, 0.5, 1.7}) {
      for (double alpha : {0.0, 0.02, 0.3, 1.2}) {
        const auto f = tire.forces(kappa, alpha, kFz);
        const auto g = tire.forces(-kappa, -alpha, kFz);
        EXPECT_NEAR(f.fx_wheel, -g.fx_wheel, 1e-9) << to_string(method);
        EXPECT_NEAR(f.fy_wheel, -g.fy_wheel, 1e-9) << to_string(method);
        // Each force flips with its own slip alone too.
        EXPECT_NEAR(tire.forces(-kappa, alpha, kFz).fx_wheel, -f.fx_wheel, 1e-9);
        EXPECT_NEAR(tire.forces(kappa, -alpha, kFz).fy_wheel, -f.fy_wheel, 1e-9);
      }
    }
  }
}

TEST(MagicFormulaTire, SlopeAtTheOriginIsBCD) {
  for (auto method : {CombinedSlipMethod::kNone, CombinedSlipMethod::kNormalizedSlip}) {
    MagicFormulaParams p = table_params();
    p.combined_slip = method;
    const MagicFormulaTire<double> tire(p);
    const double h = 1e-7;
    const double d = kMu * kFz;
    const double slope_x = (tire.forces(h, 0.0, kFz).fx_wheel - tire.forces(-h, 0.0, kFz).fx_wheel) / (2 * h);
    const double slope_y = (tire.forces(0.0, h, kFz).fy_wheel - tire.forces(0.0, -h, kFz).fy_wheel) / (2 * h);
    EXPECT_NEAR(slope_x, 10.0 * 1.65 * d, 1e-4 * 10.0 * 1.65 * d);
    EXPECT_NEAR(slope_y, 15.0 * 1.3 * d, 1e-4 * 15.0 * 1.3 * d);
  }
}

TEST(MagicFormulaTire, SlopeAtExactlyZeroSlipIsBCDForEveryCombinedSlipMethod) {
  // At kappa = alpha = 0 exactly the normalized-slip method takes its s -> 0 limit branch; the Jet
  // derivative there must still be the cornering / driving stiffness B C D of the pure curve.
  for (auto method :
       {CombinedSlipMethod::kNone, CombinedSlipMethod::kEllipseCap, CombinedSlipMethod::kNormalizedSlip}) {
    MagicFormulaParams p = table_params();
    p.combined_slip = method;
    const MagicFormulaTire<ModelJet> tire(p);
    const auto f = tire.forces(ModelJet(0.0, 0), ModelJet(0.0, 1), ModelJet(kFz));
    const double d = kMu * kFz;
    EXPECT_EQ(f.fx_wheel.a, 0.0) << to_string(method);
    EXPECT_EQ(f.fy_wheel.a, 0.0) << to_string(method);
    // Tolerance: one product of three doubles and a division by the peak slip; 1e-12 relative is
    // rounding.
    EXPECT_NEAR(f.fx_wheel.v[0], 10.0 * 1.65 * d, 1e-12 * 10.0 * 1.65 * d) << to_string(method);
    EXPECT_NEAR(f.fy_wheel.v[1], 15.0 * 1.3 * d, 1e-12 * 15.0 * 1.3 * d) << to_string(method);
    EXPECT_EQ(f.fx_wheel.v[1], 0.0) << to_string(method);
    EXPECT_EQ(f.fy_wheel.v[0], 0.0) << to_string(method);
  }
}

TEST(MagicFormulaTire, PeakEqualsDAtTheClosedFormPeakSlip) {
  MagicFormulaParams p;  // E = 0: peak at x = tan(pi / (2C)) / B
  p.combined_slip = CombinedSlipMethod::kNone;
  const MagicFormulaTire<double> tire(p);
  const double kappa_peak = std::tan(kPiTest / (2 * 1.65)) / 10.0;
  const double alpha_peak = std::tan(kPiTest / (2 * 1.3)) / 15.0;
  EXPECT_NEAR(tire.peak_slip_ratio(), kappa_peak, 1e-12);
  EXPECT_NEAR(tire.peak_slip_angle(), alpha_peak, 1e-12);
  // docs/paper.md, assumption 4's default tire peaks at kappa = tan(pi / 3.3) / 10 = 0.14038..., printed
  // there as 0.1404: tolerance half a unit in that last digit.
  EXPECT_NEAR(tire.peak_slip_ratio(), 0.1404, 5e-5);
  const double d = p.mu * kFz;
  EXPECT_NEAR(tire.pure_longitudinal(kappa_peak, kFz), d, 1e-9);
  EXPECT_NEAR(tire.pure_lateral(alpha_peak, kFz), d, 1e-9);
  EXPECT_LT(tire.pure_longitudinal(0.9 * kappa_peak, kFz), d);
  EXPECT_LT(tire.pure_longitudinal(1.1 * kappa_peak, kFz), d);
  // With E != 0 the bisected peak is still where the force equals D.
  const MagicFormulaTire<double> curved(table_params());
  EXPECT_NEAR(curved.pure_longitudinal(curved.peak_slip_ratio(), kFz), d, 1e-9);
  EXPECT_NEAR(curved.pure_lateral(curved.peak_slip_angle(), kFz), d, 1e-9);
}

TEST(MagicFormulaTire, SaturatesTowardsDSinCPiOverTwo) {
  const MagicFormulaTire<double> tire(table_params());
  const double d = kMu * kFz;
  EXPECT_NEAR(tire.pure_longitudinal(1e6, kFz), d * std::sin(1.65 * kPiTest / 2), 1e-3);
  EXPECT_NEAR(tire.pure_lateral(1e6, kFz), d * std::sin(1.3 * kPiTest / 2), 1e-3);
  EXPECT_NEAR(tire.pure_lateral(-1e6, kFz), -d * std::sin(1.3 * kPiTest / 2), 1e-3);
}

TEST(MagicFormulaTire, ForceScalesWithLoadAndVanishesForALiftedWheel) {
  const MagicFormulaTire<double> tire(MagicFormulaParams{});
  EXPECT_NEAR(tire.forces(0.05, 0.05, 2000.0).fx_wheel, 2.0 * tire.forces(0.05, 0.05, 1000.0).fx_wheel, 1e-9);
  const auto lifted = tire.forces(0.05, 0.05, -10.0);
  EXPECT_EQ(lifted.fx_wheel, 0.0);
  EXPECT_EQ(lifted.fy_wheel, 0.0);
}

TEST(MagicFormulaTire, CombinedSlipForcesStayInsideTheFrictionEllipse) {
  for (auto method : {CombinedSlipMethod::kEllipseCap, CombinedSlipMethod::kNormalizedSlip}) {
    MagicFormulaParams p;
    p.combined_slip = method;
    const MagicFormulaTire<double> tire(p);
    const double d = p.mu * kFz;
    for (double kappa = -2.0; kappa <= 2.0; kappa += 0.01) {
      for (double alpha = -1.5; alpha <= 1.5; alpha += 0.01) {
        const auto f = tire.forces(kappa, alpha, kFz);
        const double rho = std::hypot(f.fx_wheel / d, f.fy_wheel / d);
        ASSERT_LE(rho, 1.0 + 1e-12) << to_string(method) << " kappa " << kappa << " alpha " << alpha;
      }
    }
  }
}

TEST(MagicFormulaTire, CombinedSlipReducesLateralForceWhenDriving) {
  MagicFormulaParams p;
  const MagicFormulaTire<double> tire(p);
  const double pure = tire.forces(0.0, 0.05, kFz).fy_wheel;
  const double combined = tire.forces(0.2, 0.05, kFz).fy_wheel;
  EXPECT_GT(pure, 0.0);
  EXPECT_LT(combined, pure);
  EXPECT_GT(combined, 0.0);
}

TEST(WheelSlip, DefinitionsMatchAssumption3AtSpeed) {
  MagicFormulaParams p;
  p.smooth_slip = false;
  // u = 2, V_r = 2.2, v = -0.1: kappa = 0.2 / 2.2, alpha = -atan2(-0.1, 2).
  const auto slip = compute_wheel_slip(p, 2.0, -0.1, 2.2);
  EXPECT_NEAR(slip.slip_ratio, 0.2 / 2.2, 1e-15);
  EXPECT_NEAR(slip.slip_angle, std::atan2(0.1, 2.0), 1e-15);
  EXPECT_NEAR(slip.slip_velocity_x_wheel, 0.2, 1e-15);
  EXPECT_NEAR(slip.slip_velocity_y_wheel, 0.1, 1e-15);
  // The smooth form: denominators sqrt(z^2 + eps^2), the mean of the two speeds for kappa.
  p.smooth_slip = true;
  const auto smooth = compute_wheel_slip(p, 2.0, -0.1, 2.2);
  const double eps_sq = 0.05 * 0.05;
  EXPECT_NEAR(smooth.slip_ratio, 0.2 / (0.5 * (std::sqrt(4.0 + eps_sq) + std::sqrt(2.2 * 2.2 + eps_sq))), 1e-15);
  EXPECT_NEAR(smooth.slip_angle, std::atan(0.1 / std::sqrt(4.0 + eps_sq)), 1e-15);
  EXPECT_NEAR(smooth.slip_angle, slip.slip_angle, 1e-3 * slip.slip_angle);
}

TEST(WheelSlip, PureRollingHasZeroSlip) {
  for (bool smooth : {false, true}) {
    MagicFormulaParams p;
    p.smooth_slip = smooth;
    for (double speed : {-2.0, -0.01, 0.0, 1e-9, 0.03, 1.0}) {
      const auto slip = compute_wheel_slip(p, speed, 0.0, speed);
      EXPECT_EQ(slip.slip_ratio, 0.0);
      EXPECT_EQ(slip.slip_angle, 0.0);
    }
  }
}

TEST(WheelSlip, FiniteAndBoundedOnALowSpeedGridDownToRest) {
  // Wheel at rest, vehicle at rest, wheel spinning on the spot, sliding sideways at creep speed.
  std::vector<double> speeds = {0.0, 1e-12, -1e-12, 1e-6, -1e-6, 1e-3, -1e-3, 0.02, -0.02, 0.05, -0.05, 0.2, -0.2, 1.0, -1.0};
  for (bool smooth : {false, true}) {
    for (auto method : {CombinedSlipMethod::kNone, CombinedSlipMethod::kEllipseCap, CombinedSlipMethod::kNormalizedSlip}) {
      MagicFormulaParams p;
      p.smooth_slip = smooth;
      p.combined_slip = method;
      const MagicFormulaTire<double> tire(p);
      for (double u : speeds) {
        for (double v : speeds) {
          for (double vr : speeds) {
            const auto slip = compute_wheel_slip(p, u, v, vr);
            ASSERT_TRUE(std::isfinite(slip.slip_ratio) && std::isfinite(slip.slip_angle));
            ASSERT_LE(std::abs(slip.slip_ratio), 2.0 + 1e-12);
            ASSERT_LT(std::abs(slip.slip_angle), kPiTest / 2);
            const auto f = tire.forces(slip.slip_ratio, slip.slip_angle, kFz);
            ASSERT_TRUE(std::isfinite(f.fx_wheel) && std::isfinite(f.fy_wheel)) << u << " " << v << " " << vr;
            ASSERT_LE(std::abs(f.fx_wheel), p.mu * kFz * (1 + 1e-12));
            // Exact everywhere on the grid: the sliding velocity is (V_r - u, -v); each force has
            // the sign of its slip, which has the sign of its sliding velocity, so the contact never
            // generates power; and pure rolling (V_r = u, v = 0, incl. standstill) is exactly force-free.
            ASSERT_EQ(slip.slip_velocity_x_wheel, vr - u);
            ASSERT_EQ(slip.slip_velocity_y_wheel, -v);
            ASSERT_GE(slip.slip_ratio * (vr - u), 0.0);
            ASSERT_EQ(slip.slip_ratio == 0.0, vr == u) << u << " " << vr;
            ASSERT_LE(slip.slip_angle * v, 0.0);
            ASSERT_EQ(slip.slip_angle == 0.0, v == 0.0) << v;
            ASSERT_GE(f.fx_wheel * slip.slip_ratio, 0.0) << u << " " << v << " " << vr;
            ASSERT_GE(f.fy_wheel * slip.slip_angle, 0.0) << u << " " << v << " " << vr;
            ASSERT_GE(f.fx_wheel * slip.slip_velocity_x_wheel + f.fy_wheel * slip.slip_velocity_y_wheel, 0.0);
            if (vr == u && v == 0.0) {
              ASSERT_EQ(f.fx_wheel, 0.0) << u;
              ASSERT_EQ(f.fy_wheel, 0.0) << u;
            }
          }
        }
      }
    }
  }
}

TEST(WheelSlip, SmoothFormHasFiniteDerivativesAtRest) {
  MagicFormulaParams p;  // smooth, normalized slip
  const MagicFormulaTire<ModelJet> tire(p);
  for (double u : {0.0, 1e-9, 0.01}) {
    for (double vr : {0.0, 1e-9, 0.5}) {
      ModelJet ju(u, 0);
      ModelJet jv(0.0, 1);
      ModelJet jvr(vr, 2);
      const auto slip = compute_wheel_slip<ModelJet>(p, ju, jv, jvr);
      const auto f = tire.forces(slip.slip_ratio, slip.slip_angle, ModelJet(kFz));
      EXPECT_TRUE(ceres::isfinite(f.fx_wheel) && f.fx_wheel.v.allFinite());
      EXPECT_TRUE(ceres::isfinite(f.fy_wheel) && f.fy_wheel.v.allFinite());
    }
  }
}

TEST(MagicFormulaParams, RejectsEachBadFieldNamingItAndItsValue) {
  auto expect_rejected = [](MagicFormulaParams p, const std::string& expected) {
    try {
      p.validate();
      ADD_FAILURE() << "accepted: " << expected;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  MagicFormulaParams p;
  p.mu = 0.0;
  expect_rejected(p, "MagicFormulaParams.mu = 0");
  p = {};
  p.mu = std::nan("");
  expect_rejected(p, "MagicFormulaParams.mu = nan");
  p = {};
  p.longitudinal.b = -1.0;
  expect_rejected(p, "MagicFormulaParams.longitudinal.B = -1");
  p = {};
  p.lateral.c = 2.5;
  expect_rejected(p, "MagicFormulaParams.lateral.C = 2.5");
  p = {};
  p.lateral.c = 0.0;
  expect_rejected(p, "MagicFormulaParams.lateral.C = 0");
  p = {};
  p.longitudinal.e = 1.5;
  expect_rejected(p, "MagicFormulaParams.longitudinal.E = 1.5");
  p = {};
  p.lateral.e = INFINITY;
  expect_rejected(p, "MagicFormulaParams.lateral.E = inf");
  p = {};
  p.slip_speed_epsilon = 0.0;
  expect_rejected(p, "MagicFormulaParams.slip_speed_epsilon = 0");
  EXPECT_THROW(MagicFormulaTire<double>(MagicFormulaParams{0.0}), ConfigError);
}

// Per-channel friction (Pacejka's mu_x, mu_y): each channel peaks at its own D = mu Fz, pure slip
// scales with it alone, and combined slip stays inside the ellipse with those semi-axes.
MagicFormulaParams per_channel_params(CombinedSlipMethod method) {
  MagicFormulaParams p;
  p.mu = 0.8;
  p.longitudinal.mu = 1.0;
  p.lateral.mu = 0.5;
  p.combined_slip = method;
  return p;
}

TEST(MagicFormulaTire, EachChannelPeaksAtItsOwnMu) {
  const MagicFormulaTire<double> tire(per_channel_params(CombinedSlipMethod::kNone));
  EXPECT_NEAR(tire.pure_longitudinal(tire.peak_slip_ratio(), kFz), 1.0 * kFz, 1e-9);
  EXPECT_NEAR(tire.pure_lateral(tire.peak_slip_angle(), kFz), 0.5 * kFz, 1e-9);
  // Pure slip through forces() is the pure curve of its own channel, for every combined method.
  for (const CombinedSlipMethod method :
       {CombinedSlipMethod::kNone, CombinedSlipMethod::kEllipseCap, CombinedSlipMethod::kNormalizedSlip}) {
    const MagicFormulaTire<double> t(per_channel_params(method));
    EXPECT_NEAR(t.forces(0.05, 0.0, kFz).fx_wheel, t.pure_longitudinal(0.05, kFz), 1e-9) << to_string(method);
    EXPECT_NEAR(t.forces(0.0, 0.05, kFz).fy_wheel, t.pure_lateral(0.05, kFz), 1e-9) << to_string(method);
  }
}

TEST(MagicFormulaTire, PerChannelMuScalesOnlyItsOwnChannel) {
  MagicFormulaParams common;
  common.combined_slip = CombinedSlipMethod::kNone;
  const MagicFormulaTire<double> base(common);
  const MagicFormulaTire<double> split(per_channel_params(CombinedSlipMethod::kNone));
  for (const double slip : {-0.3, -0.02, 0.01, 0.1, 0.5}) {
    EXPECT_NEAR(split.pure_longitudinal(slip, kFz), base.pure_longitudinal(slip, kFz) * 1.0 / 0.8, 1e-9);
    EXPECT_NEAR(split.pure_lateral(slip, kFz), base.pure_lateral(slip, kFz) * 0.5 / 0.8, 1e-9);
  }
}

TEST(MagicFormulaTire, UnsetChannelMuIsTheCommonMuBitForBit) {
  MagicFormulaParams common;
  MagicFormulaParams explicit_channels = common;
  explicit_channels.longitudinal.mu = common.mu;
  explicit_channels.lateral.mu = common.mu;
  for (const CombinedSlipMethod method :
       {CombinedSlipMethod::kNone, CombinedSlipMethod::kEllipseCap, CombinedSlipMethod::kNormalizedSlip}) {
    common.combined_slip = explicit_channels.combined_slip = method;
    const TireForces<double> a = MagicFormulaTire<double>(common).forces(0.2, -0.15, kFz);
    const TireForces<double> b = MagicFormulaTire<double>(explicit_channels).forces(0.2, -0.15, kFz);
    EXPECT_EQ(a.fx_wheel, b.fx_wheel) << to_string(method);
    EXPECT_EQ(a.fy_wheel, b.fy_wheel) << to_string(method);
  }
}

TEST(MagicFormulaTire, CombinedSlipStaysInsideTheEllipseOfTheChannelMus) {
  for (const CombinedSlipMethod method : {CombinedSlipMethod::kEllipseCap, CombinedSlipMethod::kNormalizedSlip}) {
    const MagicFormulaTire<double> tire(per_channel_params(method));
    double largest = 0.0;
    for (const double kappa : {-0.8, -0.2, -0.05, 0.0, 0.03, 0.15, 0.6}) {
      for (const double alpha : {-0.6, -0.1, 0.0, 0.02, 0.2, 0.9}) {
        const TireForces<double> f = tire.forces(kappa, alpha, kFz);
        const double rho = std::hypot(f.fx_wheel / (1.0 * kFz), f.fy_wheel / (0.5 * kFz));
        EXPECT_LE(rho, 1.0 + 1e-9) << to_string(method) << " kappa " << kappa << " alpha " << alpha;
        largest = std::max(largest, rho);
      }
    }
    // The ellipse is reached, not merely respected (a cap far inside it would pass the bound too).
    EXPECT_GT(largest, 0.95) << to_string(method);
  }
}

TEST(MagicFormulaTire, RejectsANonPositiveChannelMuNamingIt) {
  MagicFormulaParams p;
  p.lateral.mu = 0.0;
  try {
    p.validate();
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("MagicFormulaParams.lateral.mu = 0: must be finite and > 0"),
              std::string::npos)
        << error.what();
  }
  p.lateral.mu = std::nan("");
  EXPECT_THROW(p.validate(), ConfigError);
}

}  // namespace
}  // namespace swerve
