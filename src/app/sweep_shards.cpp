// The sweep's shards: each shard's record, and the merge of shards 0..N-1 back into the sweep one
// unsharded run gives (app/shard.hpp says why).
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>

#include "lossless_json.hpp"
#include "swerve/app/sweep.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/core/text_file.hpp"

namespace swerve {
namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

constexpr int kShardFormat = 1;

Json point_record(const SweepPoint& point) {
  if (point.tolerance) {
    return {{"tolerance_position", lossless::number(point.tolerance->position)},
            {"tolerance_heading", lossless::number(point.tolerance->heading)}};
  }
  return {{"wear_weight", lossless::number(*point.wear_weight)}};
}

SweepPoint read_point(const Json& j, const std::string& where) {
  SweepPoint point;
  if (j.contains("wear_weight")) {
    point.wear_weight = lossless::read_number(j.at("wear_weight"), where + ".wear_weight");
  } else {
    TrackingTolerance t;
    t.position = lossless::read_number(lossless::member(j, "tolerance_position", where), where + ".tolerance_position");
    t.heading = lossless::read_number(lossless::member(j, "tolerance_heading", where), where + ".tolerance_heading");
    point.tolerance = t;
  }
  return point;
}

Json run_record(const ControllerRun& run) {
  return {{"name", run.name},
          {"backend", run.backend},
          {"wear_weight", lossless::number(run.wear_weight)},
          {"effective_wear_weight", lossless::number(run.effective_wear_weight)},
          {"solve_budget", lossless::number(run.solve_budget)},
          {"completed", run.completed},
          {"failure", run.failure},
          {"metrics", lossless::metrics(run.metrics)}};
}

ControllerRun read_run(const Json& j, const std::string& where) {
  ControllerRun run;
  run.name = lossless::member(j, "name", where).get<std::string>();
  run.backend = lossless::member(j, "backend", where).get<std::string>();
  run.wear_weight = lossless::read_number(lossless::member(j, "wear_weight", where), where + ".wear_weight");
  run.effective_wear_weight =
      lossless::read_number(lossless::member(j, "effective_wear_weight", where), where + ".effective_wear_weight");
  run.solve_budget = lossless::read_number(lossless::member(j, "solve_budget", where), where + ".solve_budget");
  run.completed = lossless::member(j, "completed", where).get<bool>();
  run.failure = lossless::member(j, "failure", where).get<std::string>();
  run.metrics = lossless::read_metrics(lossless::member(j, "metrics", where), where + ".metrics");
  return run;
}

}  // namespace

void write_sweep_shard(const std::string& scenario_name, const SweepResult& result, const Shard& shard,
                       int point_count, const std::string& path) {
  Json points = Json::array();
  for (const SweepRun& p : result.points) {
    points.push_back({{"index", p.index}, {"point", point_record(p.point)}, {"run", run_record(p.run)}});
  }
  Json j = {{"command", "sweep"},
            {"format", kShardFormat},
            {"shard_index", shard.index},
            {"shard_count", shard.count},
            {"run", {{"scenario", scenario_name}, {"points", point_count}}},
            {"baseline", run_record(result.baseline)},
            {"points", points}};
  if (result.practical) j["practical_baseline"] = run_record(*result.practical);
  std::ofstream out(path);
  if (!out || !(out << j.dump(1) << "\n") || !out.flush()) throw std::runtime_error(path + ": cannot write");
}

MergedSweep merge_sweep_shards(const std::vector<std::string>& shard_sweep_dirs, const std::string& out_sweep_dir) {
  if (shard_sweep_dirs.empty()) throw ConfigError("merge: give the output folders of the shards");
  std::map<int, std::pair<std::string, Json>> by_index;
  int count = 0;
  Json identity;
  for (const std::string& dir : shard_sweep_dirs) {
    const std::string path = (fs::path(dir) / kShardFileName).string();
    Json j;
    try {
      j = Json::parse(config::read_text_file(path, {std::size_t{256} << 20, "shard records", "JSON"}));
    } catch (const Json::exception& error) {
      throw ConfigError(path + ": not valid JSON: " + error.what());
    }
    if (!j.is_object() || j.value("command", "") != "sweep" || j.value("format", 0) != kShardFormat) {
      throw ConfigError(path + ": not the record of a sweep shard (\"command\": \"sweep\", format " +
                        std::to_string(kShardFormat) + ")");
    }
    Shard shard{lossless::member(j, "shard_index", path).get<int>(), lossless::member(j, "shard_count", path).get<int>()};
    shard.validate();
    if (by_index.empty()) {
      count = shard.count;
      identity = j.at("run");
    } else if (shard.count != count || j.at("run") != identity) {
      throw ConfigError("merge: " + dir + " is shard " + shard.text() + " of " + j.at("run").dump() + ", not of the " +
                        std::to_string(count) + " shards of " + identity.dump());
    }
    if (!by_index.emplace(shard.index, std::make_pair(dir, std::move(j))).second) {
      throw ConfigError("merge: shard " + shard.text() + " given twice (" + by_index.at(shard.index).first + " and " +
                        dir + ")");
    }
  }
  for (int i = 0; i < count; ++i) {
    if (!by_index.count(i)) throw ConfigError("merge: shard " + std::to_string(i) + "/" + std::to_string(count) + " is missing");
  }
  MergedSweep merged;
  merged.scenario_name = identity.at("scenario").get<std::string>();
  const int point_count = identity.at("points").get<int>();
  const auto& [first_dir, first] = by_index.at(0);
  const std::string first_path = (fs::path(first_dir) / kShardFileName).string();
  merged.baseline = read_run(lossless::member(first, "baseline", first_path), first_path + ": baseline");
  if (first.contains("practical_baseline")) {
    merged.practical = read_run(first.at("practical_baseline"), first_path + ": practical_baseline");
  }
  merged.points.resize(static_cast<std::size_t>(point_count));
  std::vector<bool> seen(merged.points.size(), false);
  for (const auto& [index, record] : by_index) {
    const std::string path = (fs::path(record.first) / kShardFileName).string();
    for (const Json& p : lossless::member(record.second, "points", path)) {
      const int i = lossless::member(p, "index", path).get<int>();
      if (i < 0 || i >= point_count || i % count != index || seen[static_cast<std::size_t>(i)]) {
        throw ConfigError(path + ": point " + std::to_string(i) + " does not belong to shard " + std::to_string(index) +
                          "/" + std::to_string(count));
      }
      seen[static_cast<std::size_t>(i)] = true;
      const std::string where = path + ": point " + std::to_string(i);
      SweepRun& run = merged.points[static_cast<std::size_t>(i)];
      run.index = i;
      run.point = read_point(lossless::member(p, "point", where), where);
      run.run = read_run(lossless::member(p, "run", where), where);
    }
  }
  for (std::size_t i = 0; i < seen.size(); ++i) {
    if (!seen[i]) throw ConfigError("merge: no shard has point " + std::to_string(i) + ": did every shard finish?");
  }
  // The baselines' logs and summary, as shard 0 wrote them (every shard ran the same baseline).
  std::error_code error;
  fs::create_directories(out_sweep_dir, error);
  for (const fs::directory_entry& file : fs::directory_iterator(first_dir)) {
    const std::string name = file.path().filename().string();
    if (!file.is_regular_file() || name == kShardFileName || name == "sweep.json") continue;
    fs::copy_file(file.path(), fs::path(out_sweep_dir) / name, fs::copy_options::overwrite_existing, error);
    if (error) throw std::runtime_error(out_sweep_dir + "/" + name + ": cannot copy (" + error.message() + ")");
  }
  return merged;
}

}  // namespace swerve
