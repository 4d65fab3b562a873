// `swerve-mpc merge DIR... -o OUT`: the shards of one sharded run (`--shard I/N`, app/shard.hpp)
// combined into what the unsharded run writes, and its report printed as that run prints it.
#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "command_registry.hpp"
#include "swerve/app/envelope.hpp"
#include "swerve/app/shard.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve::cli {
namespace {

struct MergeArguments {
  std::vector<std::string> shard_dirs;
  std::string out_dir;
};

int merge(const MergeArguments& a) {
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
          "Combine the output folders of the shards of one `envelope --shard I/N` run into the unsharded output",
          [](CLI::App& app) -> std::function<int()> {
            auto a = std::make_shared<MergeArguments>();
            app.add_option("shards", a->shard_dirs, "The shards' output folders (each with shard.json)")
                ->required();
            app.add_option("-o,--out", a->out_dir, "Output directory of the merged run")->required();
            return [a]() { return merge(*a); };
          }};
}

}  // namespace swerve::cli
