// `swerve-mpc merge DIR... -o OUT`: the shards of one sharded envelope or sweep (`--shard I/N`,
// app/shard.hpp) combined into what the unsharded run writes, and its report printed as that run
// prints it.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "command_registry.hpp"
#include "swerve/app/envelope.hpp"
#include "swerve/app/shard.hpp"
#include "swerve/app/sweep.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve::cli {
namespace {

struct MergeArguments {
  std::vector<std::string> shard_dirs;
  std::string out_dir;
};

// A sweep's shard keeps its record in <out>/sweep/, an envelope's in <out>/.
bool is_sweep_shard(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code error;
  return !fs::exists(fs::path(dir) / kShardFileName, error) && fs::exists(fs::path(dir) / "sweep" / kShardFileName, error);
}

int merge_sweep(const MergeArguments& a) {
  std::vector<std::string> sweep_dirs;
  for (const std::string& dir : a.shard_dirs) sweep_dirs.push_back(dir + "/sweep");
  const std::string out_dir = a.out_dir + "/sweep";
  for (const std::string& dir : a.shard_dirs) {
    std::error_code error;
    if (std::filesystem::exists(a.out_dir, error) && std::filesystem::equivalent(dir, a.out_dir, error)) {
      throw UsageError("merge: " + dir + " is the output folder itself; merge into another folder");
    }
  }
  MergedSweep merged;
  try {
    merged = merge_sweep_shards(sweep_dirs, out_dir);
  } catch (const ConfigError& error) {
    throw UsageError(error.what());
  }
  std::cout << sweep_table_header() << sweep_table_row(nullptr, merged.baseline, merged.baseline.metrics);
  for (const SweepRun& point : merged.points) std::cout << sweep_table_row(&point.point, point.run, merged.baseline.metrics);
  if (merged.practical) std::cout << sweep_practical_row(*merged.practical, merged.baseline.metrics);
  write_sweep_json(out_dir, merged.scenario_name, merged.baseline, merged.points, merged.practical);
  std::cout << "written: " << out_dir << "/sweep.json\n";
  return kExitOk;
}

int merge(const MergeArguments& a) {
  if (!a.shard_dirs.empty() && is_sweep_shard(a.shard_dirs.front())) return merge_sweep(a);
  EnvelopeResult result;
  try {
    result = merge_envelope_shards(a.shard_dirs, a.out_dir);
  } catch (const ConfigError& error) {
    throw UsageError(error.what());
  }
  const std::string json_path = a.out_dir + "/envelope.json";
  write_envelope_json(result, json_path);
  std::cout << envelope_report(result);
  std::cout << "written: " << json_path << " and " << result.draws.size() << " scenarios in " << a.out_dir
            << "/draws/\n";
  return kExitOk;
}

}  // namespace

Command make_merge_command() {
  return {"merge",
          "Combine the output folders of the shards of one `envelope` or `sweep --shard I/N` run into the "
          "unsharded output",
          [](CLI::App& app) -> std::function<int()> {
            auto a = std::make_shared<MergeArguments>();
            app.add_option("shards", a->shard_dirs, "The shards' output folders (each with shard.json)")
                ->required();
            app.add_option("-o,--out", a->out_dir, "Output directory of the merged run")->required();
            return [a]() { return merge(*a); };
          }};
}

}  // namespace swerve::cli
