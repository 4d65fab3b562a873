// The envelope's shards: each shard's record, and the merge of the records of shards 0..N-1 back
// into the result one unsharded run gives (app/shard.hpp says why).
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "shard_records.hpp"
#include "swerve/app/envelope.hpp"
#include "swerve/app/run_report.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

Json run_record(const EnvelopeRun& run) {
  return {{"ran", run.ran},
          {"completed", run.completed},
          {"failure", run.failure},
          {"safe_stops", run.safe_stops},
          {"metrics", lossless::metrics(run.metrics)}};
}

EnvelopeRun read_run(const Json& j, const std::string& where) {
  EnvelopeRun run;
  run.ran = lossless::member(j, "ran", where).get<bool>();
  run.completed = lossless::member(j, "completed", where).get<bool>();
  run.failure = lossless::member(j, "failure", where).get<std::string>();
  run.safe_stops = lossless::member(j, "safe_stops", where).get<int>();
  run.metrics = lossless::read_metrics(lossless::member(j, "metrics", where), where + ".metrics");
  return run;
}

// What must agree between the shards of one run (everything in the options but jobs and out_dir).
Json run_identity(const EnvelopeOptions& o) {
  return {{"seed", o.seed},
          {"draws", o.draws},
          {"families", o.families},
          {"controller_file", o.controller_file},
          {"baseline_file", o.baseline_file},
          {"work_clock", lossless::number(o.work_clock)},
          {"work_clock_evaluation", lossless::number(o.work_clock_evaluation)}};
}

// `text` with `from` (a shard's draw folder prefix) replaced by `to` where a path starts: at the
// start of the text or after a space, quote or parenthesis (not inside a longer path).
std::string moved(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos;) {
    const bool starts = at == 0 || std::string(" '\"(").find(text[at - 1]) != std::string::npos;
    if (!starts) {
      at = text.find(from, at + 1);
      continue;
    }
    text.replace(at, from.size(), to);
    at = text.find(from, at + to.size());
  }
  return text;
}

std::string draws_prefix(const std::string& out_dir) { return (fs::path(out_dir) / "draws").string() + "/"; }

EnvelopeOptions read_options(const Json& j, const std::string& where) {
  EnvelopeOptions o;
  const Json& identity = lossless::member(j, "run", where);
  o.seed = lossless::member(identity, "seed", where).get<std::uint64_t>();
  o.draws = lossless::member(identity, "draws", where).get<int>();
  o.families = lossless::member(identity, "families", where).get<std::vector<std::string>>();
  o.controller_file = lossless::member(identity, "controller_file", where).get<std::string>();
  o.baseline_file = lossless::member(identity, "baseline_file", where).get<std::string>();
  o.work_clock = lossless::read_number(lossless::member(identity, "work_clock", where), where + ".work_clock");
  o.work_clock_evaluation = lossless::read_number(lossless::member(identity, "work_clock_evaluation", where),
                                                  where + ".work_clock_evaluation");
  o.jobs = lossless::member(j, "jobs", where).get<int>();
  o.out_dir = lossless::member(j, "out_dir", where).get<std::string>();
  return o;
}

void copy_draw_folder(const std::string& from, const std::string& to) {
  std::error_code error;
  fs::remove_all(to, error);
  fs::create_directories(fs::path(to).parent_path(), error);
  fs::copy(from, to, fs::copy_options::recursive, error);
  if (error) throw std::runtime_error(to + ": cannot copy the draw from " + from + " (" + error.message() + ")");
}

}  // namespace

void write_envelope_shard(const EnvelopeResult& result, const std::string& path) {
  const EnvelopeOptions& o = result.options;
  Json draws = Json::array();
  for (const DrawResult& r : result.draws) {
    draws.push_back({{"index", r.draw.index},
                     {"drawn", r.error.rfind("drawing failed: ", 0) != 0},
                     {"scenario_file", r.scenario_file},
                     {"error", r.error},
                     {"wear_mpc", run_record(r.wear_mpc)},
                     {"kinematic_baseline", run_record(r.baseline)}});
  }
  Json j = lossless::shard_record("envelope", o.shard, run_identity(o));
  j["jobs"] = o.jobs;
  j["out_dir"] = o.out_dir;
  j["draws"] = draws;
  lossless::write_json_file(j, path);
}

EnvelopeResult merge_envelope_shards(const std::vector<std::string>& shard_dirs, const std::string& out_dir) {
  for (const std::string& dir : shard_dirs) {
    std::error_code error;
    if (fs::exists(out_dir, error) && fs::equivalent(dir, out_dir, error)) {
      throw ConfigError("merge: " + dir + " is the output folder itself; merge into another folder");
    }
  }
  const std::vector<lossless::ShardFile> shards = lossless::read_shard_set(shard_dirs, "envelope");
  const lossless::ShardFile& first = shards.front();

  EnvelopeResult result;
  result.options = lossless::with_json_errors(first.path, [&] { return read_options(first.json, first.path); });
  result.options.out_dir = out_dir;
  result.options.shard = Shard{};
  result.options.validate();
  if (result.options.draws > 1000000) {  // the CLI's limit: a record claiming more is not one of its runs
    throw ConfigError(first.path + ": run.draws = " + std::to_string(result.options.draws) + ": must be <= 1000000");
  }
  const std::vector<ReferenceFamily> families = result.options.family_list();
  result.draws.resize(static_cast<std::size_t>(result.options.draws));
  std::vector<bool> seen(result.draws.size(), false);
  prepare_output_directory(out_dir);
  for (const lossless::ShardFile& shard_file : shards) lossless::with_json_errors(shard_file.path, [&] {
    const lossless::ShardFile* record = &shard_file;
    const std::string& where = record->path;
    const std::string from = draws_prefix(lossless::member(record->json, "out_dir", where).get<std::string>());
    const std::string to = draws_prefix(out_dir);
    for (const Json& d : lossless::member(record->json, "draws", where)) {
      const int index = lossless::member(d, "index", where).get<int>();
      if (index < 0 || index >= result.options.draws || !record->shard.owns(index) ||
          seen[static_cast<std::size_t>(index)]) {
        throw ConfigError(where + ": draw " + std::to_string(index) + " does not belong to shard " +
                          record->shard.text() + " of " + std::to_string(result.options.draws) + " draws");
      }
      seen[static_cast<std::size_t>(index)] = true;
      const std::string draw_where = where + ": draw " + std::to_string(index);
      const std::string dir = (fs::path(out_dir) / "draws" / std::to_string(index)).string();
      const std::string error = moved(lossless::member(d, "error", draw_where).get<std::string>(), from, to);
      DrawResult& r = result.draws[static_cast<std::size_t>(index)];
      if (!lossless::member(d, "drawn", draw_where).get<bool>()) {
        r = undrawn_result(result.options.seed, index, families, dir, error.substr(std::string("drawing failed: ").size()));
      } else {
        r.draw = draw_case(result.options.seed, index, families);
        r.scenario_file = moved(lossless::member(d, "scenario_file", draw_where).get<std::string>(), from, to);
        r.error = error;
        r.wear_mpc = read_run(lossless::member(d, "wear_mpc", draw_where), draw_where + ".wear_mpc");
        r.baseline = read_run(lossless::member(d, "kinematic_baseline", draw_where), draw_where + ".kinematic_baseline");
        r.wear_mpc.failure = moved(r.wear_mpc.failure, from, to);
        r.baseline.failure = moved(r.baseline.failure, from, to);
        r.goals = evaluate_goals(r.wear_mpc, r.baseline);
      }
      const fs::path shard_draw = fs::path(record->dir) / "draws" / std::to_string(index);
      std::error_code exists_error;
      if (fs::exists(shard_draw, exists_error)) {
        copy_draw_folder(shard_draw.string(), dir);
      } else if (r.error.empty()) {  // a draw that ran wrote its folder: the shard's folder is incomplete
        throw ConfigError(where + ": draw " + std::to_string(index) + " ran, but " + shard_draw.string() +
                          " is missing");
      }
    }
  });
  for (std::size_t i = 0; i < seen.size(); ++i) {
    if (!seen[i]) {
      const lossless::ShardFile& owner = shards[i % shards.size()];
      throw ConfigError("merge: " + owner.dir + " (shard " + owner.shard.text() + ") has no draw " + std::to_string(i) +
                        ": did it finish?");
    }
  }
  count_goals(&result);
  return result;
}

}  // namespace swerve
