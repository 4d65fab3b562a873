// Internal: the least-norm static load distribution of a vehicle's contacts (modules then casters).
#pragma once

#include <Eigen/Core>

#include "swerve/models/vehicle_params.hpp"

namespace swerve::detail {

// P (contacts x 3) with Fz = P [sum Fz; sum (x_i - x_c) Fz_i; sum (y_i - y_c) Fz_i] the least-norm
// (pseudo-inverse) solution of the three planar equilibrium equations.
Eigen::MatrixXd least_norm_load_matrix(const VehicleParams& params);

// The contact positions (body frame): modules in layout order, then casters.
Eigen::Matrix2Xd contact_positions(const VehicleParams& params);

}  // namespace swerve::detail
