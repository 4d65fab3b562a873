// The sweep's shards: each shard's record, and the merge of shards 0..N-1 back into the sweep one
// unsharded run gives (app/shard.hpp says why).
#include <filesystem>
#include <stdexcept>

#include "shard_records.hpp"
#include "swerve/app/sweep.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

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

void write_sweep_shard(const SweepIdentity& identity, const SweepResult& result, const Shard& shard,
                       const std::string& path) {
  Json points = Json::array();
  for (const SweepRun& p : result.points) {
    points.push_back({{"index", p.index}, {"point", point_record(p.point)}, {"run", run_record(p.run)}});
  }
  Json all_points = Json::array();
  for (const SweepPoint& point : identity.points) all_points.push_back(point_record(point));
  const Json run = {{"scenario", identity.scenario},
                    {"points", static_cast<int>(identity.points.size())},
                    {"point_list", all_points},
                    {"overrides", identity.overrides},
                    {"work_clock", lossless::number(identity.clock.per_read_s)},
                    {"work_clock_evaluation", lossless::number(identity.clock.per_module_evaluation_s)}};
  Json j = lossless::shard_record("sweep", shard, run);
  j["baseline"] = run_record(result.baseline);
  j["points"] = points;
  if (result.practical) j["practical_baseline"] = run_record(*result.practical);
  lossless::write_json_file(j, path);
}

MergedSweep merge_sweep_shards(const std::vector<std::string>& shard_sweep_dirs, const std::string& out_sweep_dir) {
  const std::vector<lossless::ShardFile> shards = lossless::read_shard_set(shard_sweep_dirs, "sweep");
  const lossless::ShardFile& first = shards.front();
  const int count = first.shard.count;
  MergedSweep merged;
  const int point_count = lossless::with_json_errors(first.path, [&] {
    merged.scenario_name = lossless::member(first.json.at("run"), "scenario", first.path).get<std::string>();
    merged.baseline = read_run(lossless::member(first.json, "baseline", first.path), first.path + ": baseline");
    if (first.json.contains("practical_baseline")) {
      merged.practical = read_run(first.json.at("practical_baseline"), first.path + ": practical_baseline");
    }
    return lossless::member(first.json.at("run"), "points", first.path).get<int>();
  });
  // On a work clock every shard's baseline run is the same, bit for bit: one that is not ran
  // something else (another scenario file under the same name, another build).
  const bool work_clock = lossless::read_number(first.json.at("run").at("work_clock"), first.path) > 0.0;
  for (const lossless::ShardFile& shard : shards) {
    if (work_clock && shard.json.at("baseline") != first.json.at("baseline")) {
      throw ConfigError("merge: " + shard.dir + "'s baseline run differs from " + first.dir +
                        "'s: the shards did not run the same sweep");
    }
  }
  if (point_count < 1 || point_count > 100000) {
    throw ConfigError(first.path + ": run.points = " + std::to_string(point_count) + ": must be in [1, 100000]");
  }
  merged.points.resize(static_cast<std::size_t>(point_count));
  std::vector<bool> seen(merged.points.size(), false);
  for (const lossless::ShardFile& shard : shards) lossless::with_json_errors(shard.path, [&] {
    const int index = shard.shard.index;
    const std::string& path = shard.path;
    for (const Json& p : lossless::member(shard.json, "points", path)) {
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
  });
  for (std::size_t i = 0; i < seen.size(); ++i) {
    if (!seen[i]) throw ConfigError("merge: no shard has point " + std::to_string(i) + ": did every shard finish?");
  }
  // The baselines' logs and summary, as shard 0 wrote them (every shard ran the same baseline).
  std::error_code error;
  fs::create_directories(out_sweep_dir, error);
  for (const fs::directory_entry& file : fs::directory_iterator(first.dir)) {
    const std::string name = file.path().filename().string();
    if (!file.is_regular_file() || name == kShardFileName || name == "sweep.json") continue;
    fs::copy_file(file.path(), fs::path(out_sweep_dir) / name, fs::copy_options::overwrite_existing, error);
    if (error) throw std::runtime_error(out_sweep_dir + "/" + name + ": cannot copy (" + error.message() + ")");
  }
  return merged;
}

}  // namespace swerve
