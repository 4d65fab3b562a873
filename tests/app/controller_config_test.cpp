// The controller YAML's stale_measurement block: read into ControllerOptions, and bad values named
// with the key path. (In sim_tests: the controller loader lives in the scenarios library.)
#include "swerve/app/controller_config.hpp"

#include <gtest/gtest.h>

#include <string>
#include <variant>
#include <vector>

#include "support/bound_edges.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/app/config_node.hpp"
#include "swerve/app/vehicle_config.hpp"
#include "swerve/control/reference.hpp"

namespace swerve {
namespace {

ControllerConfig load(const std::string& stale_block) {
  const std::string yaml = "controller:\n  name: c\n  type: wear_mpc\n" + stale_block;
  const config::ConfigNode root = config::ConfigNode::parse(yaml, "c.yaml");
  ControllerConfig config = load_controller_config(root.child("controller"));
  root.expect_all_read();  // as the file loaders do: an unknown key is an error
  return config;
}

// A block that must be rejected with an error naming the file and the key path.
void expect_rejected(const char* block, const char* key) {
  SCOPED_TRACE(block);
  try {
    load(block);
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("c.yaml"), std::string::npos) << message;
    EXPECT_NE(message.find(key), std::string::npos) << message;
  }
}

TEST(ControllerConfig, ReadsTheStaleMeasurementLimits) {
  const ControllerConfig c = load("  stale_measurement: {max_age: 0.25, frozen_cycles: 5, moving_speed: 0.02}\n");
  EXPECT_DOUBLE_EQ(c.mpc.stale_measurement.max_age, 0.25);
  EXPECT_EQ(c.mpc.stale_measurement.frozen_cycles, 5);
  EXPECT_DOUBLE_EQ(c.mpc.stale_measurement.moving_speed, 0.02);
  const ControllerConfig defaults = load("");
  EXPECT_DOUBLE_EQ(defaults.mpc.stale_measurement.max_age, StalenessOptions{}.max_age);
  EXPECT_EQ(defaults.mpc.stale_measurement.frozen_cycles, StalenessOptions{}.frozen_cycles);
}

TEST(ControllerConfig, RejectsBadStaleMeasurementLimitsNamingTheKeyPath) {
  const struct {
    const char* block;
    const char* key;
  } cases[] = {{"  stale_measurement: {max_age: -0.1}\n", "controller.stale_measurement.max_age"},
               {"  stale_measurement: {max_age: .nan}\n", "controller.stale_measurement.max_age"},
               {"  stale_measurement: {frozen_cycles: 1}\n", "controller.stale_measurement.frozen_cycles"},
               {"  stale_measurement: {moving_speed: -1}\n", "controller.stale_measurement.moving_speed"},
               {"  stale_measurement: {max_agee: 1}\n", "controller.stale_measurement.max_agee"}};
  for (const auto& c : cases) expect_rejected(c.block, c.key);
}

TEST(StalenessOptions, ValidateNamesTheField) {
  StalenessOptions o;
  o.frozen_cycles = 1;
  try {
    o.validate();
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("frozen_cycles"), std::string::npos) << e.what();
  }
}

TEST(ControllerConfig, ReadsTheTrackingToleranceAndTheGeometryHeadingWeight) {
  const ControllerConfig c =
      load("  tracking_tolerance: {position: 0.05, heading: 0.02}\n  weights: {heading_from_geometry: true}\n");
  EXPECT_DOUBLE_EQ(c.mpc.tracking_tolerance.position, 0.05);
  EXPECT_DOUBLE_EQ(c.mpc.tracking_tolerance.heading, 0.02);
  EXPECT_DOUBLE_EQ(c.mpc.tracking_tolerance.penalty, TrackingTolerance{}.penalty);
  EXPECT_TRUE(c.mpc.tracking_tolerance.enabled());
  EXPECT_TRUE(c.mpc.heading_weight_from_geometry);
  EXPECT_FALSE(load("").mpc.tracking_tolerance.enabled());
}

TEST(ControllerConfig, ReadsTheDriveAndSteeringLagSwitchesOfThePrediction) {
  EXPECT_TRUE(load("  prediction: {drive_lag: true}\n").mpc.prediction.drive_lag);
  EXPECT_FALSE(load("").mpc.prediction.drive_lag);
  expect_rejected("  prediction: {drive_lag: sometimes}\n", "controller.prediction.drive_lag");
  EXPECT_TRUE(load("  prediction: {steering_lag: true}\n").mpc.prediction.steering_lag);
  EXPECT_FALSE(load("").mpc.prediction.steering_lag);
  expect_rejected("  prediction: {steering_lag: 2}\n", "controller.prediction.steering_lag");
}

TEST(ControllerConfig, ReadsIpoptsHessianChoiceAndRejectsAnUnknownOne) {
  EXPECT_EQ(load("").solver.ipopt.hessian, "exact");
  EXPECT_EQ(load("  solver: {ipopt: {hessian: limited-memory}}\n").solver.ipopt.hessian, "limited-memory");
  for (const char* block : {"  solver: {ipopt: {hessian: gauss-newton}}\n", "  solver: {ipopt: {hessian: 1}}\n"}) {
    expect_rejected(block, "controller.solver.ipopt.hessian");
  }
}

TEST(ControllerConfig, ReadsTheKnotPolishAndThreadsOfSimulatedAnnealingAndRejectsBadOnes) {
  EXPECT_FALSE(load("").solver.sa.knot_polish);
  EXPECT_TRUE(load("  solver: {sa: {knot_polish: true}}\n").solver.sa.knot_polish);
  expect_rejected("  solver: {sa: {knot_polish: maybe}}\n", "controller.solver.sa.knot_polish");
  EXPECT_EQ(load("").solver.sa.threads, 1);
  EXPECT_EQ(load("  solver: {sa: {threads: 2}}\n").solver.sa.threads, 2);
  for (const char* block : {"  solver: {sa: {threads: 0}}\n", "  solver: {sa: {threads: 17}}\n",
                            "  solver: {sa: {threads: two}}\n"}) {
    expect_rejected(block, "controller.solver.sa.threads");
  }
}

TEST(ControllerConfig, ReadsTheWearReferenceMassAndRejectsABadOne) {
  EXPECT_DOUBLE_EQ(load("  weights: {wear: 0.3, wear_reference_mass: 800}\n").mpc.wear_reference_mass, 800.0);
  EXPECT_DOUBLE_EQ(load("").mpc.wear_reference_mass, 0.0);
  for (const char* block : {"  weights: {wear_reference_mass: -800}\n", "  weights: {wear_reference_mass: .nan}\n",
                            "  weights: {wear_reference_mass: heavy}\n"}) {
    expect_rejected(block, "controller.weights.wear_reference_mass");
  }
}

TEST(ControllerConfig, ReadsTheWearMassExponentAndRejectsABadOne) {
  EXPECT_DOUBLE_EQ(load("  weights: {wear_reference_mass: 800, wear_mass_exponent: 1.75}\n").mpc.wear_mass_exponent, 1.75);
  EXPECT_DOUBLE_EQ(load("").mpc.wear_mass_exponent, 1.0);
  for (const char* block : {"  weights: {wear_mass_exponent: 0}\n", "  weights: {wear_mass_exponent: -1}\n",
                            "  weights: {wear_mass_exponent: .nan}\n", "  weights: {wear_mass_exponent: steep}\n",
                            "  weights: {wear_mass_exponent: 1.5}\n"}) {
    expect_rejected(block, "controller.weights.wear_mass_exponent");
  }
}

TEST(ControllerConfig, ReadsThePoseHuberWidthAndRejectsABadOne) {
  EXPECT_DOUBLE_EQ(load("  weights: {pose_huber_width: 0.08}\n").mpc.pose_huber_width, 0.08);
  EXPECT_DOUBLE_EQ(load("").mpc.pose_huber_width, 0.0);
  for (const char* block : {"  weights: {pose_huber_width: -0.08}\n", "  weights: {pose_huber_width: .nan}\n",
                            "  weights: {pose_huber_width: wide}\n"}) {
    expect_rejected(block, "controller.weights.pose_huber_width");
  }
}

TEST(ControllerConfig, ReadsAControlPeriodShorterThanTheStepAndRejectsOneLongerOrABudgetPastIt) {
  const ControllerConfig c = load("  dt: 0.1\n  control_period: 0.05\n  solve_budget: 0.02\n");
  EXPECT_DOUBLE_EQ(c.mpc.dt, 0.1);
  EXPECT_DOUBLE_EQ(c.period(), 0.05);  // the scenario steps it, and its plant, every 50 ms
  EXPECT_DOUBLE_EQ(load("  dt: 0.1\n").period(), 0.1);  // without one: dt
  expect_rejected("  dt: 0.05\n  control_period: 0.1\n", "controller.control_period");
  expect_rejected("  dt: 0.1\n  control_period: -0.05\n", "controller.control_period");
  // The budget is a share of the period, not of the longer step.
  expect_rejected("  dt: 0.1\n  control_period: 0.05\n  solve_budget: 0.08\n", "controller.solve_budget");
}

TEST(ControllerConfig, ReadsTheStepTheWeightsAreSetForAndRejectsABadOne) {
  EXPECT_DOUBLE_EQ(load("  weights: {step: 0.05}\n").mpc.weights_step, 0.05);
  EXPECT_DOUBLE_EQ(load("").mpc.weights_step, 0.0);
  for (const char* block : {"  weights: {step: -0.05}\n", "  weights: {step: .nan}\n", "  weights: {step: fast}\n"}) {
    expect_rejected(block, "controller.weights.step");
  }
}

TEST(ControllerConfig, ReadsTheHeadingLever) {
  EXPECT_DOUBLE_EQ(load("  weights: {heading_from_geometry: true, heading_lever: 2.5}\n").mpc.heading_lever, 2.5);
  EXPECT_DOUBLE_EQ(load("").mpc.heading_lever, 1.0);
}

TEST(ControllerConfig, RejectsABadHeadingLeverOrOneWithoutTheGeometryHeadingWeight) {
  for (const char* block : {"  weights: {heading_from_geometry: true, heading_lever: 0}\n",
                            "  weights: {heading_from_geometry: true, heading_lever: -2}\n",
                            "  weights: {heading_from_geometry: true, heading_lever: .nan}\n",
                            "  weights: {heading_from_geometry: true, heading_lever: two}\n",
                            "  weights: {heading_lever: 2}\n",
                            "  weights: {heading_from_geometry: false, heading_lever: 2}\n"}) {
    expect_rejected(block, "controller.weights.heading_lever");
  }
}

TEST(ControllerConfig, RejectsABadTrackingToleranceNamingTheFileKeyPathAndValue) {
  const struct {
    const char* block;
    const char* key;
  } cases[] = {{"  tracking_tolerance: {position: 0, heading: 0.02}\n", "controller.tracking_tolerance.position"},
               {"  tracking_tolerance: {position: -0.05, heading: 0.02}\n", "controller.tracking_tolerance.position"},
               {"  tracking_tolerance: {position: .nan, heading: 0.02}\n", "controller.tracking_tolerance.position"},
               {"  tracking_tolerance: {position: 0.05, heading: abc}\n", "controller.tracking_tolerance.heading"},
               {"  tracking_tolerance: {position: 0.05}\n", "controller.tracking_tolerance.heading"},
               {"  tracking_tolerance: {position: 0.05, heading: 0.02, penalty: 0}\n",
                "controller.tracking_tolerance.penalty"},
               {"  tracking_tolerance: {position: 0.05, heading: 0.02, width: 1}\n",
                "controller.tracking_tolerance.width"}};
  for (const auto& c : cases) expect_rejected(c.block, c.key);
}

TEST(ControllerConfig, RejectsATrackingToleranceOnTheKinematicBaselineWhichCannotUseIt) {
  const std::string yaml =
      "controller:\n  name: b\n  type: kinematic_baseline\n  tracking_tolerance: {position: 0.05, heading: 0.02}\n";
  const config::ConfigNode root = config::ConfigNode::parse(yaml, "b.yaml");
  try {
    load_controller_config(root.child("controller"));
    root.expect_all_read();
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("b.yaml"), std::string::npos) << message;
    EXPECT_NE(message.find("controller.tracking_tolerance"), std::string::npos) << message;
  }
}

TEST(TrackingTolerance, ValidateNamesTheFieldAndAllowsOffOnly) {
  EXPECT_NO_THROW(TrackingTolerance{}.validate());  // both 0: off
  TrackingTolerance half;
  half.position = 0.05;  // one bound without the other is not a tube
  try {
    half.validate();
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("heading"), std::string::npos) << e.what();
  }
}

// Every numeric rule of a table, just outside its bound: the loader (the table's key under `path`)
// and validate() both reject it. One table serves both, so they cannot disagree.
template <typename Options, typename Validate>
void expect_loader_and_validate_reject_the_same(const OptionFields<Options>& fields, const std::string& path,
                                                const Validate& validate) {
  // `path`: the YAML lines opening the block, e.g. "  solver:\n    sa:\n" (empty: the controller's
  // own keys); the keys go one level below its last line.
  std::size_t indent = 2;
  if (!path.empty()) {
    const std::size_t line = path.find_last_of('\n', path.size() - 2) + 1;  // npos + 1 = 0
    indent = path.find_first_not_of(' ', line) - line + 2;
  }
  for (const OptionField<Options>& field : fields) {
    const bool real = std::holds_alternative<double Options::*>(field.member);
    const bool whole = std::holds_alternative<int Options::*>(field.member);
    if (!real && !whole) continue;
    for (const double value : testing::values_just_outside(field.bound)) {
      SCOPED_TRACE(std::string(field.name) + " = " + Bound::number(value));
      Options options;
      if (real) options.*std::get<double Options::*>(field.member) = value;
      if (whole) options.*std::get<int Options::*>(field.member) = static_cast<int>(value);
      try {
        validate(options);
        ADD_FAILURE() << "validate() accepted it";
      } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find(std::string(field.name) + " = "), std::string::npos) << e.what();
      }
      const std::string block = path + std::string(indent, ' ') + field.yaml_key() + ": " + Bound::number(value) + "\n";
      try {
        load(block);
        ADD_FAILURE() << "the loader accepted it";
      } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find(field.yaml_key()), std::string::npos) << e.what();
      }
    }
  }
}

TEST(ControllerConfig, TheLoaderAndValidateRejectTheSameValuesOfEveryOptionsTable) {
  expect_loader_and_validate_reject_the_same(SaOptions::fields(), "  solver:\n    sa:\n",
                                             [](const SaOptions& o) { o.validate(); });
  expect_loader_and_validate_reject_the_same(IpoptOptions::fields(), "  solver:\n    ipopt:\n",
                                             [](const IpoptOptions& o) { o.validate(); });
  expect_loader_and_validate_reject_the_same(NloptOptions::fields(), "  solver:\n    nlopt:\n",
                                             [](const NloptOptions& o) { o.validate(); });
  expect_loader_and_validate_reject_the_same(CeresOptions::fields(), "  solver:\n    ceres:\n",
                                             [](const CeresOptions& o) { o.validate(); });
  expect_loader_and_validate_reject_the_same(BaselineOptions::fields(), "  baseline:\n",
                                             [](const BaselineOptions& o) { o.validate(); });
  expect_loader_and_validate_reject_the_same(PredictionOptions::fields(), "  prediction:\n",
                                             [](const PredictionOptions& o) { o.validate(); });
  expect_loader_and_validate_reject_the_same(StalenessOptions::fields(), "  stale_measurement:\n",
                                             [](const StalenessOptions& o) { o.validate(); });
  expect_loader_and_validate_reject_the_same(MeasurementFilterOptions::fields(), "  measurement_filter:\n",
                                             [](const MeasurementFilterOptions& o) { o.validate(); });
  expect_loader_and_validate_reject_the_same(ControllerOptions::sampling_fields(), "",
                                             [](const ControllerOptions& o) { o.validate(); });
  expect_loader_and_validate_reject_the_same(ControllerOptions::timing_fields(), "",
                                             [](const ControllerOptions& o) { o.validate(); });
  expect_loader_and_validate_reject_the_same(ControllerOptions::weight_fields(), "  weights:\n",
                                             [](const ControllerOptions& o) { o.validate(); });
}

// Two rules the loader and validate() each wrote their own way, before the tables.
TEST(ControllerConfig, AcceptsAZeroCeresToleranceAsCeresAndValidateDo) {
  const ControllerConfig c = load("  solver:\n    ceres: {function_tolerance: 0, gradient_tolerance: 0}\n");
  EXPECT_EQ(c.solver.ceres.function_tolerance, 0.0);
  EXPECT_EQ(c.solver.ceres.gradient_tolerance, 0.0);
}

// The baseline's horizon and dt come from the controller's keys; its validate() keeps the same
// rule (it wrote its own before).
TEST(BaselineOptions, ValidateRejectsTheHorizonsAndStepsTheControllerRejects) {
  for (const OptionField<ControllerOptions>& field : ControllerOptions::sampling_fields()) {
    for (const double value : testing::values_just_outside(field.bound)) {
      SCOPED_TRACE(std::string(field.name) + " = " + Bound::number(value));
      BaselineOptions o;
      if (std::string(field.name) == "horizon") o.horizon = static_cast<int>(value);
      if (std::string(field.name) == "dt") o.dt = value;
      try {
        o.validate();
        ADD_FAILURE() << "accepted";
      } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find("BaselineOptions." + std::string(field.name) + " = "), std::string::npos)
            << e.what();
      }
    }
  }
}

TEST(BaselineOptions, ValidateRejectsMoreGaussNewtonIterationsThanTheLoaderAllows) {
  BaselineOptions o;
  o.gauss_newton_iterations = 101;
  EXPECT_THROW(o.validate(), ConfigError);
  expect_rejected("  baseline: {gauss_newton_iterations: 101}\n", "controller.baseline.gauss_newton_iterations");
}

TEST(BaselineOptions, ReadsTheStepItsWeightsAreSetForAndTheShippedBaselineSetsItsOwn) {
  EXPECT_DOUBLE_EQ(load("  baseline: {weights_step: 0.05}\n").baseline.weights_step, 0.05);
  EXPECT_DOUBLE_EQ(load("").baseline.weights_step, 0.0);
  expect_rejected("  baseline: {weights_step: -0.05}\n", "controller.baseline.weights_step");
  // The shipped baseline's weights were tuned at its 50 ms step; a target's shorter period must
  // rescale them rather than run them as written (docs/benchmarks.md, "Tuned controller configs per target").
  const ControllerConfig shipped =
      load_controller_config_file(std::string(SWERVE_SOURCE_DIR) + "/configs/controllers/kinematic_baseline.yaml");
  EXPECT_DOUBLE_EQ(shipped.baseline.weights_step, shipped.baseline.dt);
}

}  // namespace
}  // namespace swerve

namespace swerve {
namespace {

// One call from the shipped files: a ready controller whose backend the file chose, stepping a
// vehicle at rest on a planner-fed trajectory; a missing file is a ConfigError naming it.
TEST(MakeController, BuildsAReadyControllerFromAVehicleFileAndAControllerFile) {
  const std::string configs = std::string(SWERVE_SOURCE_DIR) + "/configs/";
  const auto trajectory = std::make_shared<TrajectoryReference>(16);
  Eigen::MatrixXd samples(2, 4);
  samples << 0.0, 0.0, 0.0, 0.0,  //
      10.0, 5.0, 0.0, 0.0;
  ASSERT_TRUE(trajectory->publish(samples).accepted());
  const auto mpc = make_controller(configs + "vehicles/agv_4wheel.yaml", configs + "controllers/default.yaml", trajectory);
  ASSERT_NE(mpc, nullptr);
  EXPECT_STREQ(mpc->name(), "wear_mpc");
  const auto baseline =
      make_controller(configs + "vehicles/agv_4wheel.yaml", configs + "controllers/kinematic_baseline.yaml", trajectory);
  EXPECT_STREQ(baseline->name(), "kinematic_baseline");
  const Eigen::VectorXd at_rest = Eigen::VectorXd::Zero(6 + 4);
  const ControlOutput& out = baseline->step(at_rest, 0.0);
  EXPECT_NE(out.source, CommandSource::kSafeStop) << (out.reason != nullptr ? out.reason : "");
  EXPECT_GT(out.modules[0].wheel_speed, 0.0);
  try {
    make_controller(configs + "vehicles/no_such_vehicle.yaml", configs + "controllers/default.yaml", trajectory);
    ADD_FAILURE() << "accepted a missing vehicle file";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_vehicle.yaml"), std::string::npos) << e.what();
  }
}

TEST(ControllerConfig, SetSamplingMovesTheBaselinePlannerWithTheController) {
  ControllerConfig config;
  config.set_sampling(40, 0.02);
  EXPECT_EQ(config.mpc.horizon, 40);
  EXPECT_EQ(config.baseline.horizon, 40);
  EXPECT_DOUBLE_EQ(config.mpc.dt, 0.02);
  EXPECT_DOUBLE_EQ(config.baseline.dt, 0.02);
}

// The factory of the package component `controllers` builds the two dependency-free backends and
// refuses the others, saying what to link; the full factory builds those too.
TEST(ControllerFactory, CoreFactoryBuildsSaAndRtiAndRefusesTheOthersNamingWhatToLink) {
  const std::string configs = std::string(SWERVE_SOURCE_DIR) + "/configs/";
  const VehicleParams vehicle = load_vehicle_config_file(configs + "vehicles/agv_4wheel.yaml");
  auto reference = std::make_shared<TrajectoryReference>(16);
  ControllerConfig config = load_controller_config_file(configs + "controllers/default.yaml");
  for (const char* backend : {"sa", "rti"}) {
    config.solver.backend = backend;
    EXPECT_NE(make_controller(config, vehicle, reference, make_core_solver), nullptr) << backend;
  }
  config.solver.backend = "nlopt";
  try {
    make_controller(config, vehicle, reference, make_core_solver);
    FAIL() << "the core factory built nlopt";
  } catch (const ConfigError& error) {
    EXPECT_EQ(std::string(error.what()),
              "controller.solver.backend: 'nlopt' is built but not in this factory, which has sa and rti: link "
              "SwerveMPC::solvers and build controllers with swerve::make_solver");
  }
  EXPECT_NE(make_controller(config, vehicle, reference), nullptr);  // every built backend
  EXPECT_THROW(make_controller(config, vehicle, reference, BackendFactory{}), ConfigError);  // not bad_function_call
  config.solver.nlopt.algorithm = "GN_DIRECT";  // checked without NLopt: the rules are in the header
  EXPECT_THROW(config.solver.validate(), ConfigError);
}

}  // namespace
}  // namespace swerve
