// The ideal vehicle model linearised at one point in what its forces depend on (body twist, each
// steering angle and wheel speed), for the prediction step's Jacobian (semi_implicit_step.hpp) to
// chain through its Jet chunks. Needs Ceres' headers, as jet.hpp.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "swerve/models/jet.hpp"
#include "swerve/models/vehicle_model.hpp"

namespace swerve {

// Module i's forces and wear depend on (v, delta_i, omega_i) alone (zero scrub radius, no load
// transfer in the ideal model). So one evaluation in ModuleJet, with v in directions 0-2, every
// steering angle in direction 3 and every wheel speed in direction 4, gives each module's own
// partials exactly (the same colouring of the Jacobian's columns as Curtis, Powell & Reid, 1974).
// The body's acceleration sums the modules linearly (VehicleModel::acceleration_per_module_force),
// so its partials in delta_i and omega_i follow from module i's forces.
class ModelLinearisation {
 public:
  // Directions of a module's own partials: (vx, vy, r, delta_i, omega_i).
  static constexpr int kTwist = 0;
  static constexpr int kSteering = 3;
  static constexpr int kWheelSpeed = 4;

  // The linearisation at one point; sized for the model by make_point() (allocates).
  struct Point {
    Eigen::Vector3d acceleration;                   // d[vx, vy, r]/dt
    Eigen::Matrix3d acceleration_per_twist;         // d acceleration / d v
    Eigen::Matrix3Xd acceleration_per_steering;     // column i: d acceleration / d delta_i
    Eigen::Matrix3Xd acceleration_per_wheel_speed;  // column i: d acceleration / d omega_i
    double wear_rate = 0.0;                         // all modules
    Eigen::Vector3d wear_rate_per_twist;
    Eigen::VectorXd wear_rate_per_steering;  // entry i: d wear rate / d delta_i
    Eigen::VectorXd wear_rate_per_wheel_speed;
    Eigen::VectorXd module_wear_rate;            // entry i: module i's share of wear_rate
    Eigen::Matrix3Xd module_wear_rate_per_twist;  // column i: d module_wear_rate[i] / d v
    Eigen::VectorXd drive_force;                                    // each module's wheel-frame Fx (N)
    Eigen::Matrix<double, Eigen::Dynamic, 5> drive_force_partials;  // row i: over module i's directions
  };

  // The caller's scratch (one per thread), for the linearisation it was made from.
  struct Data {
    explicit Data(const ModelLinearisation& linearisation);  // allocates; nothing after
    Eigen::Matrix<ModuleJet, Eigen::Dynamic, 1> state, inputs, state_dot;
    std::vector<ModuleDiagnostics<ModuleJet>> diagnostics;
  };

  explicit ModelLinearisation(const VehicleParams& params);  // the ideal model; throws ConfigError

  Point make_point() const;
  // At the model state `state` (the ideal model's: pose, twist, steering angles) and module inputs
  // `inputs` (steering rate, wheel speed per module). False (the point unspecified) for wrong sizes,
  // a non-finite input or result. No allocation.
  bool linearise(Data& data, const Eigen::Ref<const Eigen::VectorXd>& state,
                 const Eigen::Ref<const Eigen::VectorXd>& inputs, Point* point) const noexcept;

  const VehicleModel<ModuleJet>& model() const noexcept { return model_; }
  // VehicleModel::observe_friction_scales for the model it linearises.
  void observe_friction_scales(const double* scales) noexcept { model_.observe_friction_scales(scales); }
  void observe_module_faults(const ModuleFaults* faults) noexcept { model_.observe_module_faults(faults); }

 private:
  VehicleModel<ModuleJet> model_;
  Eigen::Matrix<double, 3, Eigen::Dynamic> per_force_x_, per_force_y_;  // acceleration per module force
};

}  // namespace swerve
