#include "shard_records.hpp"

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <stdexcept>

#include "swerve/core/config_error.hpp"
#include "swerve/core/text_file.hpp"

namespace swerve::lossless {

nlohmann::json number(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0.0 ? "inf" : "-inf";
  return value;
}

double read_number(const nlohmann::json& value, const std::string& where) {
  if (value.is_number()) return value.get<double>();
  if (value.is_string()) {
    const std::string text = value.get<std::string>();
    if (text == "nan") return std::numeric_limits<double>::quiet_NaN();
    if (text == "inf") return std::numeric_limits<double>::infinity();
    if (text == "-inf") return -std::numeric_limits<double>::infinity();
  }
  throw ConfigError(where + ": expected a number, got " + value.dump());
}

const nlohmann::json& member(const nlohmann::json& j, const char* key, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw ConfigError(where + ": missing '" + key + "'");
  return j.at(key);
}

namespace {

// Every field of RunMetrics, once: the writer and the reader walk the same table.
struct DoubleField {
  const char* name;
  double RunMetrics::*field;
};
struct IntField {
  const char* name;
  int RunMetrics::*field;
};
constexpr DoubleField kDoubles[] = {
    {"tracking_rmse_m", &RunMetrics::tracking_rmse_m},
    {"tracking_max_m", &RunMetrics::tracking_max_m},
    {"heading_rmse_rad", &RunMetrics::heading_rmse_rad},
    {"heading_max_rad", &RunMetrics::heading_max_rad},
    {"wear_total", &RunMetrics::wear_total},
    {"wear_imbalance", &RunMetrics::wear_imbalance},
    {"lifetime_wear_imbalance", &RunMetrics::lifetime_wear_imbalance},
    {"frictional_energy_J", &RunMetrics::frictional_energy_J},
    {"steering_effort", &RunMetrics::steering_effort},
    {"steering_command_jerk", &RunMetrics::steering_command_jerk},
    {"solve_time_mean_ms", &RunMetrics::solve_time_mean_ms},
    {"solve_time_p50_ms", &RunMetrics::solve_time_p50_ms},
    {"solve_time_p99_ms", &RunMetrics::solve_time_p99_ms},
    {"solve_time_max_ms", &RunMetrics::solve_time_max_ms},
    {"step_time_p99_ms", &RunMetrics::step_time_p99_ms},
    {"step_time_max_ms", &RunMetrics::step_time_max_ms},
    {"reference_delay_s", &RunMetrics::reference_delay_s},
    {"solve_iterations_mean", &RunMetrics::solve_iterations_mean},
};
constexpr IntField kInts[] = {
    {"steps", &RunMetrics::steps},
    {"deadline_misses", &RunMetrics::deadline_misses},
    {"late_solves", &RunMetrics::late_solves},
    {"work_budget_cuts", &RunMetrics::work_budget_cuts},
    {"fallbacks", &RunMetrics::fallbacks},
    {"tracking_first_steps", &RunMetrics::tracking_first_steps},
};

}  // namespace

nlohmann::json metrics(const RunMetrics& m) {
  nlohmann::json j = nlohmann::json::object();
  for (const DoubleField& f : kDoubles) j[f.name] = number(m.*(f.field));
  for (const IntField& f : kInts) j[f.name] = m.*(f.field);
  nlohmann::json wear = nlohmann::json::array();
  for (const double w : m.wear_per_module) wear.push_back(number(w));
  j["wear_per_module"] = wear;
  return j;
}

RunMetrics read_metrics(const nlohmann::json& j, const std::string& where) {
  RunMetrics m;
  for (const DoubleField& f : kDoubles) m.*(f.field) = read_number(member(j, f.name, where), where + "." + f.name);
  for (const IntField& f : kInts) {
    const nlohmann::json& value = member(j, f.name, where);
    if (!value.is_number_integer()) throw ConfigError(where + "." + f.name + ": expected an integer, got " + value.dump());
    m.*(f.field) = value.get<int>();
  }
  const nlohmann::json& wear = member(j, "wear_per_module", where);
  if (!wear.is_array()) throw ConfigError(where + ".wear_per_module: expected an array");
  for (std::size_t i = 0; i < wear.size(); ++i) {
    m.wear_per_module.push_back(read_number(wear[i], where + ".wear_per_module[" + std::to_string(i) + "]"));
  }
  return m;
}

void write_json_file(const nlohmann::json& j, const std::string& path) {
  // Replacing invalid UTF-8 as envelope.json and sweep.json do, so a path that is not UTF-8 does
  // not lose a whole shard's work at its end.
  config::write_text_file_atomically(path, j.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

namespace {
constexpr int kShardFormat = 1;
}  // namespace

nlohmann::json shard_record(const char* command, const Shard& shard, const nlohmann::json& run_identity) {
  return {{"command", command},
          {"format", kShardFormat},
          {"shard_index", shard.index},
          {"shard_count", shard.count},
          {"run", run_identity}};
}

std::vector<ShardFile> read_shard_set(const std::vector<std::string>& dirs, const char* command) {
  if (dirs.empty()) throw ConfigError("merge: give the output folders of the shards");
  std::map<int, ShardFile> by_index;
  const ShardFile* first = nullptr;
  for (const std::string& dir : dirs) {
    ShardFile file;
    file.dir = dir;
    file.path = (std::filesystem::path(dir) / kShardFileName).string();
    try {
      file.json = nlohmann::json::parse(config::read_text_file(file.path, {std::size_t{256} << 20, "shard records", "JSON"}));
    } catch (const nlohmann::json::exception& error) {
      throw ConfigError(file.path + ": not valid JSON: " + error.what());
    }
    const nlohmann::json& j = file.json;
    const auto is = [&j](const char* key, const nlohmann::json& value) {
      return j.is_object() && j.contains(key) && j.at(key) == value;
    };
    if (!is("command", command) || !is("format", kShardFormat)) {
      throw ConfigError(file.path + ": not the record of " + (std::string(command) == "envelope" ? "an " : "a ") +
                        command + " shard (\"command\": \"" + command + "\", format " + std::to_string(kShardFormat) + ")");
    }
    with_json_errors(file.path, [&] {
      file.shard.index = member(j, "shard_index", file.path).get<int>();
      file.shard.count = member(j, "shard_count", file.path).get<int>();
    });
    try {
      file.shard.validate();
    } catch (const ConfigError& error) {
      throw ConfigError(file.path + ": " + error.what());
    }
    if (first != nullptr && file.shard.count != first->shard.count) {
      throw ConfigError("merge: " + dir + " is shard " + file.shard.text() + ", but " + first->dir + " is of " +
                        std::to_string(first->shard.count) + " shards");
    }
    const nlohmann::json& run = member(j, "run", file.path);
    if (first != nullptr && run != first->json.at("run")) {
      throw ConfigError("merge: " + dir + " is a shard of another " + command + " run than " + first->dir + " (" +
                        j.at("run").dump() + " against " + first->json.at("run").dump() + ")");
    }
    const int index = file.shard.index;
    const auto [at, inserted] = by_index.emplace(index, std::move(file));
    if (!inserted) {
      throw ConfigError("merge: shard " + at->second.shard.text() + " given twice (" + at->second.dir + " and " + dir + ")");
    }
    if (first == nullptr) first = &at->second;
  }
  const int count = first->shard.count;
  std::vector<ShardFile> files;
  for (int i = 0; i < count; ++i) {
    const auto found = by_index.find(i);
    if (found == by_index.end()) {
      throw ConfigError("merge: shard " + std::to_string(i) + "/" + std::to_string(count) + " is missing");
    }
    files.push_back(std::move(found->second));
  }
  return files;
}

}  // namespace swerve::lossless
