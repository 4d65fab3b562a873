// Jet Jacobians against central finite differences (Crocoddyl-style typed suite over models): of
// the continuous dynamics f, of the RK4 map F and of its stage wear, for every layout, the MPC and
// the plant fidelity, at random states and near zero speed.
#include "swerve/models/dynamics_jacobian.hpp"

#include <gtest/gtest.h>

#include <random>

#include "support/model_fixtures.hpp"
#include "swerve/models/jet.hpp"

namespace swerve {
namespace {

using Vector = Eigen::VectorXd;
using Matrix = Eigen::MatrixXd;

// The models under test, one type each.
template <int Modules, Fidelity Kind, bool Caster = false>
struct ModelCase {
  static VehicleParams params() {
    VehicleParams p = Caster ? testing::make_caster_params() : testing::make_params(Modules);
    if (Kind == Fidelity::kPlant) {
      p.cog_height = 0.1;  // low enough that no random state lifts a wheel (the Fz >= 0 clamp is a kink)
      p.plant.load_transfer = true;
      p.plant.relaxation_length = 0.2;
      p.plant.actuator_saturation = false;  // clamps are kinks; finite differences would straddle them
      // With transient slip the force no longer has the sign of the sliding velocity, so |F v_slip|
      // has a kink at zero sliding speed: the smoothed |.| (what gradient solvers use) removes it.
      p.wear.smoothing = 0.1;
    }
    return p;
  }
  static constexpr Fidelity kFidelity = Kind;
};

template <typename Case>
class DynamicsJacobianTest : public ::testing::Test {
 protected:
  DynamicsJacobianTest()
      : params_(Case::params()),
        model_(params_, Case::kFidelity),
        dynamics_(model_),
        jacobian_(params_, Case::kFidelity) {}

  // Random state with body speeds scaled by `speed` (speed -> 0: near rest).
  void random_point(std::mt19937* rng, double speed, Vector* x, Vector* u) const {
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    *x = Vector::Zero(model_.state_size());
    *u = Vector::Zero(model_.input_size());
    for (int k = 0; k < model_.state_size(); ++k) (*x)(k) = unit(*rng);
    (*x)(StateIndex::kVx) = speed * (1.0 + 0.5 * unit(*rng));
    (*x)(StateIndex::kVy) = speed * 0.3 * unit(*rng);
    (*x)(StateIndex::kYawRate) = speed * 0.5 * unit(*rng);
    const double radius = params_.layout.wheel_radius();
    for (int i = 0; i < model_.modules(); ++i) {
      (*u)(InputIndex::steering_rate(i)) = 0.5 * unit(*rng);
      (*u)(InputIndex::wheel_speed(i)) = speed * (1.0 + 0.2 * unit(*rng)) / radius;
      if (model_.wheel_speed_index(i) >= 0) {
        (*x)(model_.wheel_speed_index(i)) = speed * (1.0 + 0.2 * unit(*rng)) / radius;
      }
      if (model_.transient_slip_ratio_index(i) >= 0) {
        (*x)(model_.transient_slip_ratio_index(i)) = 0.05 * unit(*rng);
        (*x)(model_.transient_slip_angle_index(i)) = 0.05 * unit(*rng);
      }
    }
  }

  // Central differences of g: R^(nx+nu) -> R^m (m rows) at (x, u).
  template <typename G>
  Matrix central_differences(const Vector& x, const Vector& u, int rows, G g) const {
    const int nx = model_.state_size();
    const int nu = model_.input_size();
    Matrix jac(rows, nx + nu);
    Vector plus(rows);
    Vector minus(rows);
    for (int k = 0; k < nx + nu; ++k) {
      Vector xp = x;
      Vector up = u;
      Vector xm = x;
      Vector um = u;
      double& vp = k < nx ? xp(k) : up(k - nx);
      double& vm = k < nx ? xm(k) : um(k - nx);
      const double h = 1e-6 * std::max(1.0, std::abs(vp));
      vp += h;
      vm -= h;
      g(xp, up, &plus);
      g(xm, um, &minus);
      jac.col(k) = (plus - minus) / (2 * h);
    }
    return jac;
  }

  static void expect_close(const Matrix& exact, const Matrix& numeric, const char* what) {
    const double scale = std::max(1.0, numeric.cwiseAbs().maxCoeff());
    const double error = (exact - numeric).cwiseAbs().maxCoeff();
    EXPECT_LT(error, 2e-6 * scale) << what << ": max error " << error << " of scale " << scale;
  }

  // dt and substeps: RK4 inside its stability region (at rest the slip dynamics are very stiff).
  void check_at(const Vector& x, const Vector& u, double contact_speed) {
    const int nx = model_.state_size();
    const int nu = model_.input_size();
    // Continuous dynamics and wear rate.
    Vector f(nx);
    Matrix a(nx, nx);
    Matrix b(nx, nu);
    double rate = 0.0;
    Vector rate_gradient(nx + nu);
    ASSERT_EQ(jacobian_.continuous(x, u, f, a, b, &rate, rate_gradient.data()), ModelStatus::kOk);
    Vector f_double(nx);
    double rate_double = 0.0;
    ASSERT_EQ(model_.derivative(x, u, f_double, nullptr, &rate_double), ModelStatus::kOk);
    EXPECT_NEAR((f - f_double).norm(), 0.0, 1e-12 * (1.0 + f.norm()));
    EXPECT_NEAR(rate, rate_double, 1e-12 * (1.0 + rate));
    Matrix fd = central_differences(x, u, nx + 1, [&](const Vector& xx, const Vector& uu, Vector* out) {
      Vector xd(nx);
      double w = 0.0;
      ASSERT_EQ(model_.derivative(xx, uu, xd, nullptr, &w), ModelStatus::kOk);
      out->head(nx) = xd;
      (*out)(nx) = w;
    });
    Matrix exact(nx + 1, nx + nu);
    exact.topLeftCorner(nx, nx) = a;
    exact.topRightCorner(nx, nu) = b;
    exact.row(nx) = rate_gradient.transpose();
    expect_close(exact, fd, "df/d(x, u) and d(wear rate)/d(x, u)");

    // Discrete RK4 map and its stage wear.
    const double dt = 0.02;
    const int substeps = model_.recommended_substeps(dt, contact_speed);
    Vector next(nx);
    double wear = 0.0;
    Vector wear_gradient(nx + nu);
    ASSERT_EQ(jacobian_.discrete(x, u, dt, substeps, next, a, b, &wear, wear_gradient.data()), ModelStatus::kOk);
    Vector next_double(nx);
    double wear_double = 0.0;
    ASSERT_EQ(dynamics_.step(x, u, dt, substeps, next_double, &wear_double), ModelStatus::kOk);
    EXPECT_NEAR((next - next_double).norm(), 0.0, 1e-12 * (1.0 + next.norm()));
    EXPECT_NEAR(wear, wear_double, 1e-12 * (1.0 + wear));
    fd = central_differences(x, u, nx + 1, [&](const Vector& xx, const Vector& uu, Vector* out) {
      Vector xn(nx);
      double w = 0.0;
      ASSERT_EQ(dynamics_.step(xx, uu, dt, substeps, xn, &w), ModelStatus::kOk);
      out->head(nx) = xn;
      (*out)(nx) = w;
    });
    exact.topLeftCorner(nx, nx) = a;
    exact.topRightCorner(nx, nu) = b;
    exact.row(nx) = wear_gradient.transpose();
    expect_close(exact, fd, "dF/d(x, u) and d(stage wear)/d(x, u)");
  }

  VehicleParams params_;
  VehicleModel<double> model_;
  DiscreteDynamics<double> dynamics_;
  DynamicsJacobian jacobian_;
};

using ModelCases =
    ::testing::Types<ModelCase<2, Fidelity::kIdeal>, ModelCase<3, Fidelity::kIdeal>, ModelCase<4, Fidelity::kIdeal>,
                     ModelCase<6, Fidelity::kIdeal>, ModelCase<8, Fidelity::kIdeal>, ModelCase<16, Fidelity::kIdeal>,
                     ModelCase<2, Fidelity::kIdeal, true>, ModelCase<4, Fidelity::kPlant>,
                     ModelCase<2, Fidelity::kPlant, true>>;
TYPED_TEST_SUITE(DynamicsJacobianTest, ModelCases);

TYPED_TEST(DynamicsJacobianTest, MatchesCentralDifferencesAtRandomStates) {
  std::mt19937 rng(42);
  for (int trial = 0; trial < 3; ++trial) {
    Vector x;
    Vector u;
    this->random_point(&rng, 1.0, &x, &u);
    SCOPED_TRACE(trial);
    this->check_at(x, u, 0.2);
  }
}

TYPED_TEST(DynamicsJacobianTest, MatchesCentralDifferencesNearZeroSpeed) {
  std::mt19937 rng(7);
  for (double speed : {1e-3, 1e-6, 0.0}) {
    Vector x;
    Vector u;
    this->random_point(&rng, speed, &x, &u);
    SCOPED_TRACE(speed);
    this->check_at(x, u, speed);
  }
}

TEST(DynamicsJacobian, JetDerivativeOfTheModelMatchesTheDoubleValue) {
  // The Jet-valued VehicleModel itself (what DynamicsJacobian chunks over) evaluated directly.
  const VehicleParams params = testing::make_params(4);
  const VehicleModel<ModelJet> model(params, Fidelity::kIdeal);
  const VehicleModel<double> model_double(params, Fidelity::kIdeal);
  VehicleModel<ModelJet>::Vector x(model.state_size());
  VehicleModel<ModelJet>::Vector u(model.input_size());
  Vector xd = Vector::Constant(model.state_size(), 0.3);
  Vector ud = Vector::Constant(model.input_size(), 4.0);
  for (int k = 0; k < model.state_size(); ++k) x(k) = ModelJet(xd(k), k % kModelJetSize);
  for (int k = 0; k < model.input_size(); ++k) u(k) = ModelJet(ud(k));
  VehicleModel<ModelJet>::Vector x_dot(model.state_size());
  Vector x_dot_double(model.state_size());
  ASSERT_EQ(model.derivative(x, u, x_dot), ModelStatus::kOk);
  ASSERT_EQ(model_double.derivative(xd, ud, x_dot_double), ModelStatus::kOk);
  for (int k = 0; k < model.state_size(); ++k) EXPECT_NEAR(x_dot(k).a, x_dot_double(k), 1e-12);
}

TEST(DynamicsJacobian, WrongSizesAndNonFiniteInputsReturnAStatus) {
  DynamicsJacobian jacobian(testing::make_params(4), Fidelity::kIdeal);
  const int nx = jacobian.state_size();
  const int nu = jacobian.input_size();
  Vector x = Vector::Zero(nx);
  Vector u = Vector::Zero(nu);
  Vector next(nx);
  Matrix a(nx, nx);
  Matrix b(nx, nu);
  Matrix wrong(nx, nx + 1);
  EXPECT_EQ(jacobian.discrete(x, u, 0.05, 1, next, a, wrong), ModelStatus::kInvalidArgument);
  u(1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(jacobian.discrete(x, u, 0.05, 1, next, a, b), ModelStatus::kNonFiniteInput);
  EXPECT_TRUE(a.array().isNaN().all());
}

}  // namespace
}  // namespace swerve
