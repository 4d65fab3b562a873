#include "swerve/models/vehicle_params.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <sstream>

#include "load_distribution.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

// The owner every rule of this file names (throw_invalid_field: "<owner>.<field> = <value>: <rule>").
constexpr const char* kOwner = "VehicleParams";

std::string format(const Eigen::Vector2d& v) {
  std::ostringstream out;
  out << "[" << v.x() << ", " << v.y() << "]";
  return out.str();
}

}  // namespace

namespace detail {

Eigen::Matrix2Xd contact_positions(const VehicleParams& params) {
  const int modules = params.layout.size();
  const auto casters = static_cast<int>(params.casters.size());
  Eigen::Matrix2Xd positions(2, modules + casters);
  for (int i = 0; i < modules; ++i) positions.col(i) = params.layout.position_body(i);
  for (int j = 0; j < casters; ++j) {
    positions.col(modules + j) = params.casters[static_cast<std::size_t>(j)].position_body;
  }
  return positions;
}

Eigen::MatrixXd least_norm_load_matrix(const VehicleParams& params) {
  const Eigen::Matrix2Xd positions = contact_positions(params);
  const Eigen::Index contacts = positions.cols();
  Eigen::MatrixXd a(3, contacts);
  for (Eigen::Index i = 0; i < contacts; ++i) {
    a(0, i) = 1.0;
    a(1, i) = positions(0, i) - params.center_of_mass_body.x();
    a(2, i) = positions(1, i) - params.center_of_mass_body.y();
  }
  // Pseudo-inverse through a complete orthogonal decomposition (rank-revealing: 2 contacts, or all
  // contacts on one line, leave one moment equation unsatisfiable).
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> decomposition(a);
  decomposition.setThreshold(1e-9);
  return decomposition.pseudoInverse();
}

}  // namespace detail

const OptionFields<CasterParams>& CasterParams::fields() {
  static const OptionFields<CasterParams> table{
      {"rolling_resistance", &CasterParams::rolling_resistance, Bound::non_negative()},
  };
  return table;
}

const OptionFields<ActuatorParams>& ActuatorParams::fields() {
  static const OptionFields<ActuatorParams> table{
      {"steering_time_constant", &ActuatorParams::steering_time_constant, Bound::positive()},
      {"drive_time_constant", &ActuatorParams::drive_time_constant, Bound::positive()},
  };
  return table;
}

const OptionFields<PlantOptions>& PlantOptions::fields() {
  static const OptionFields<PlantOptions> table{
      {"actuator_lag", &PlantOptions::actuator_lag},
      {"actuator_saturation", &PlantOptions::actuator_saturation},
      {"relaxation_length", &PlantOptions::relaxation_length, Bound::non_negative(), {}, nullptr, "(0 = off)"},
      {"load_transfer", &PlantOptions::load_transfer},
  };
  return table;
}

const OptionFields<VehicleParams>& VehicleParams::fields() {
  static const OptionFields<VehicleParams> table{
      {"mass", &VehicleParams::mass, Bound::positive()},
      {"yaw_inertia", &VehicleParams::yaw_inertia, Bound::positive()},
      {"gravity", &VehicleParams::gravity, Bound::positive()},
      {"cog_height", &VehicleParams::cog_height, Bound::positive()},
  };
  return table;
}

void VehicleParams::validate() const {
  check_fields("VehicleParams", *this, fields());
  if (!center_of_mass_body.allFinite()) {
    throw_invalid_field(kOwner, "center_of_mass", format(center_of_mass_body), "must be finite");
  }
  check_fields("VehicleParams.actuators", actuators, ActuatorParams::fields());
  check_fields("VehicleParams.plant", plant, PlantOptions::fields());
  if (plant.load_transfer && !cog_height) {
    throw_invalid_field(kOwner, "plant.load_transfer", "true", "needs cog_height");
  }
  for (std::size_t j = 0; j < casters.size(); ++j) {
    const std::string field = "casters[" + std::to_string(j) + "]";
    if (!casters[j].position_body.allFinite()) {
      throw_invalid_field(kOwner, field + ".position", format(casters[j].position_body), "must be finite");
    }
    check_fields(("VehicleParams." + field).c_str(), casters[j], CasterParams::fields());
    for (int i = 0; i < layout.size(); ++i) {
      if ((casters[j].position_body - layout.position_body(i)).norm() < 1e-3) {
        throw_invalid_field(kOwner, field + ".position", format(casters[j].position_body),
               "coincides with modules[" + std::to_string(i) + "]");
      }
    }
  }
  tire.validate();
  wear.validate();
  (void)static_normal_loads();  // throws when the weight cannot be carried
}

std::vector<double> VehicleParams::static_normal_loads() const {
  const Eigen::MatrixXd p = detail::least_norm_load_matrix(*this);
  const Eigen::Vector3d b(mass * gravity, 0.0, 0.0);
  const Eigen::VectorXd loads = p * b;
  // Residual of the equilibrium: non-zero when the CoM is off the line of collinear contacts.
  const Eigen::Matrix2Xd positions = detail::contact_positions(*this);
  Eigen::Vector3d residual = -b;
  for (Eigen::Index i = 0; i < loads.size(); ++i) {
    residual(0) += loads(i);
    residual(1) += loads(i) * (positions(0, i) - center_of_mass_body.x());
    residual(2) += loads(i) * (positions(1, i) - center_of_mass_body.y());
  }
  if (residual.norm() > 1e-6 * b(0)) {
    throw_invalid_field(kOwner, "center_of_mass", format(center_of_mass_body),
           "is off the line through all contacts: the weight cannot be carried (add a caster)");
  }
  for (Eigen::Index i = 0; i < loads.size(); ++i) {
    if (loads(i) < 0.0) {
      const int modules = layout.size();
      const std::string contact = i < modules ? "modules[" + std::to_string(i) + "]"
                                              : "casters[" + std::to_string(i - modules) + "]";
      throw_invalid_field(kOwner, "center_of_mass", format(center_of_mass_body),
             "lies outside the support: the static load on " + contact + " would be " +
                 std::to_string(loads(i)) + " N < 0");
    }
  }
  return {loads.data(), loads.data() + loads.size()};
}

std::vector<double> VehicleParams::static_load_shares() const {
  std::vector<double> shares = static_normal_loads();
  shares.resize(static_cast<std::size_t>(layout.size()));
  double total = 0.0;
  for (const double load : shares) total += load;
  for (double& share : shares) share /= total;
  return shares;
}

}  // namespace swerve
