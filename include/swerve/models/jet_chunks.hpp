// Forward-mode Jacobians in chunks: a function of stacked inputs (x, u) evaluated with
// swerve::ModelJet (8 directions) once per 8 columns of its Jacobian. Shared by DynamicsJacobian
// (the plant's maps) and SemiImplicitStepJacobian (the prediction's). Needs Ceres' headers on the
// include path, as jet.hpp does.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <limits>

#include "swerve/models/jet.hpp"

namespace swerve {

using ModelJetVector = Eigen::Matrix<ModelJet, Eigen::Dynamic, 1>;

// `evaluate(ModelJet* scalar) -> bool` reads x_jet and u_jet (seeded here) and writes out_jet and
// *scalar. Fills `value` with out's values, a = d out/dx, b = d out/du and, if given, the scalar's
// value and its gradient [d/dx, d/du] (nx + nu entries). On a failed evaluation returns false with
// every output NaN. No allocation.
template <typename Evaluate>
bool jet_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x_value, const Eigen::Ref<const Eigen::VectorXd>& u_value,
                  ModelJetVector& x_jet, ModelJetVector& u_jet, const ModelJetVector& out_jet,
                  Eigen::Ref<Eigen::VectorXd> value, Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b,
                  double* scalar_value, double* scalar_gradient, Evaluate&& evaluate) {
  const auto nx = x_value.size();
  const auto nu = u_value.size();
  const auto rows = out_jet.size();
  ModelJet scalar(0.0);
  for (Eigen::Index start = 0; start < nx + nu; start += kModelJetSize) {
    // Unit directions [start, start + kModelJetSize) of the stacked (x, u).
    for (Eigen::Index k = 0; k < nx + nu; ++k) {
      ModelJet& entry = k < nx ? x_jet[k] : u_jet[k - nx];
      entry = ModelJet(k < nx ? x_value[k] : u_value[k - nx]);
      const Eigen::Index d = k - start;
      if (d >= 0 && d < kModelJetSize) entry.v[d] = 1.0;
    }
    if (!evaluate(&scalar)) {
      constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
      value.setConstant(kNaN);
      a.setConstant(kNaN);
      b.setConstant(kNaN);
      if (scalar_value != nullptr) *scalar_value = kNaN;
      if (scalar_gradient != nullptr) std::fill(scalar_gradient, scalar_gradient + nx + nu, kNaN);
      return false;
    }
    const Eigen::Index end = std::min<Eigen::Index>(start + kModelJetSize, nx + nu);
    for (Eigen::Index column = start; column < end; ++column) {
      const Eigen::Index d = column - start;
      auto target = column < nx ? a.col(column) : b.col(column - nx);
      for (Eigen::Index row = 0; row < rows; ++row) target[row] = out_jet[row].v[d];
      if (scalar_gradient != nullptr) scalar_gradient[column] = scalar.v[d];
    }
  }
  for (Eigen::Index row = 0; row < rows; ++row) value[row] = out_jet[row].a;
  if (scalar_value != nullptr) *scalar_value = scalar.a;
  return true;
}

}  // namespace swerve
