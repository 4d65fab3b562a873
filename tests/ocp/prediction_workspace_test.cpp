// PredictionWorkspace: one PredictionData per thread, of the model it serves, made anew only when
// it is asked for another model.
#include <gtest/gtest.h>

#include "support/config_errors.hpp"
#include "support/linear_models.hpp"
#include "support/model_fixtures.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/ocp/prediction_model.hpp"
#include "swerve/ocp/vehicle_prediction_model.hpp"

namespace swerve {
namespace {

TEST(PredictionWorkspace, GivesEachThreadDataOfItsOwnMadeByTheModel) {
  const VehiclePredictionModel model(testing::make_params(4));
  PredictionWorkspace workspace(model, 3);
  ASSERT_EQ(workspace.threads(), 3);
  EXPECT_NE(&workspace.data(0), &workspace.data(1));
  EXPECT_NE(&workspace.data(1), &workspace.data(2));
  for (int t = 0; t < 3; ++t) EXPECT_NE(dynamic_cast<VehiclePredictionModel::Data*>(&workspace.data(t)), nullptr);
}

TEST(PredictionWorkspace, KeepsItsDataWhenBoundToTheSameModelAndMakesNewDataForAnother) {
  const VehiclePredictionModel model(testing::make_params(4));
  const testing::DoubleIntegratorModel other;
  PredictionWorkspace workspace(model, 2);
  PredictionData* const first = &workspace.data(0);
  ASSERT_TRUE(workspace.bind(model));
  EXPECT_EQ(&workspace.data(0), first);  // no allocation on the real-time path
  ASSERT_TRUE(workspace.bind(other));
  EXPECT_EQ(dynamic_cast<VehiclePredictionModel::Data*>(&workspace.data(0)), nullptr);
  EXPECT_EQ(dynamic_cast<VehiclePredictionModel::Data*>(&workspace.data(1)), nullptr);
  ASSERT_TRUE(workspace.bind(model));
  EXPECT_NE(dynamic_cast<VehiclePredictionModel::Data*>(&workspace.data(1)), nullptr);
}

TEST(PredictionWorkspace, RefusesFewerThanOneThreadNamingTheField) {
  const testing::DoubleIntegratorModel model;
  const std::string message = testing::config_error_of([&] { PredictionWorkspace workspace(model, 0); });
  EXPECT_NE(message.find("PredictionWorkspace.threads"), std::string::npos) << message;
  EXPECT_NE(message.find("0"), std::string::npos) << message;
}

}  // namespace
}  // namespace swerve
