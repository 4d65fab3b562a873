#include "swerve/ocp/prediction_model.hpp"

#include <new>
#include <string>

#include "swerve/core/config_error.hpp"

namespace swerve {

PredictionWorkspace::PredictionWorkspace(const PredictionModel& model, int threads) : model_(&model) {
  if (threads < 1) throw ConfigError("PredictionWorkspace.threads: must be >= 1, got " + std::to_string(threads));
  data_.reserve(static_cast<std::size_t>(threads));
  for (int t = 0; t < threads; ++t) data_.push_back(model.create_data());
}

bool PredictionWorkspace::bind(const PredictionModel& model) noexcept {
  if (&model == model_) return true;
  model_ = nullptr;
  try {
    for (std::unique_ptr<PredictionData>& data : data_) data = model.create_data();
  } catch (...) {  // out of memory: the caller reports a failed solve
    return false;
  }
  model_ = &model;
  return true;
}

}  // namespace swerve
