// write_tuned_controller: the tuner's chosen candidate written over the controller file it tuned.
#include <yaml-cpp/yaml.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>

#include "swerve/app/controller_config.hpp"
#include "swerve/app/tuning.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

// The shortest text that reads back as `value`: 0.05, not the 17 digits yaml-cpp writes for a
// double (0.050000000000000003), which a user then reads in the tuned file.
YAML::Node shortest_number(double value) {
  char text[32];
  const char* end = std::to_chars(text, text + sizeof text, value).ptr;
  return YAML::Node(std::string(static_cast<const char*>(text), end));
}

}  // namespace

void write_tuned_controller(const std::string& base_file, const TuningCandidate& candidate, const TargetConfig& target,
                            const std::string& header, const std::string& path) {
  YAML::Node document;
  try {
    document = YAML::LoadFile(base_file);
  } catch (const YAML::Exception& error) {
    throw ConfigError(base_file + ": cannot read the controller to tune: " + error.what());
  }
  YAML::Node controller = document["controller"];
  if (!controller.IsMap()) throw ConfigError(base_file + ": no controller: map to tune");
  const double period = candidate.period_at(target.control_period);
  const std::optional<double> budget = target.budget_at(period);
  if (!budget) {
    throw ConfigError(path + ": the candidate's control period " + std::to_string(period) + " s is not one target " +
                      target.name + " allows (" + target.periods_text() + " s)");
  }
  controller["horizon"] = candidate.horizon;
  const double dt = candidate.step_at(target.control_period);
  controller["dt"] = shortest_number(dt);
  if (std::abs(dt - period) < 1e-9) {
    controller.remove("control_period");
  } else {
    controller["control_period"] = shortest_number(period);
  }
  controller["solve_budget"] = shortest_number(*budget);
  controller["solver"]["backend"] = candidate.backend;
  if (candidate.backend == "sa") controller["solver"]["sa"]["knots"] = candidate.knots;
  controller["deadline_margin"] = shortest_number(candidate.deadline_margin);
  // The tuner ran the candidates here on solve_budget / cpu_slowdown at the base file's work rates;
  // on the target the same work costs cpu_slowdown times as much.
  const WorkBudgetOptions work = load_controller_config_file(base_file).mpc.work_budget;
  if (work.enabled) {
    controller["work_budget"]["seconds_per_read"] = shortest_number(work.seconds_per_read * target.cpu_slowdown);
    controller["work_budget"]["seconds_per_module_evaluation"] =
        shortest_number(work.seconds_per_module_evaluation * target.cpu_slowdown);
  }
  controller["description"] = "wear-aware MPC tuned for " + target.name + " (swerve-mpc tune)";
  YAML::Emitter emitter;
  emitter << document;
  {
    std::ofstream out(path);
    if (!out) throw std::runtime_error(path + ": cannot write the tuned controller");
    out << header << emitter.c_str() << "\n";
    if (!out) throw std::runtime_error(path + ": cannot write the tuned controller");
  }
  (void)load_controller_config_file(path);  // what was written loads as a controller
}

}  // namespace swerve
