// The records shards hand to `swerve-mpc merge` (app/shard.hpp): lossless JSON, every double
// written so that it reads back bit for bit (nlohmann writes the shortest text that round-trips;
// NaN and infinities, which JSON lacks, as the strings "nan", "inf" and "-inf") and the run metrics
// whole; the record files themselves; and the check that a set of them is one run's shards.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "swerve/app/shard.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/sim/metrics.hpp"

namespace swerve::lossless {

nlohmann::json number(double value);
// Reads what number() wrote; ConfigError naming `where` otherwise.
double read_number(const nlohmann::json& value, const std::string& where);

nlohmann::json metrics(const RunMetrics& m);
RunMetrics read_metrics(const nlohmann::json& j, const std::string& where);

// j[key] or a ConfigError "<where>: missing 'key'".
const nlohmann::json& member(const nlohmann::json& j, const char* key, const std::string& where);

// Runs `read` and turns a JSON error it meets (a member of the wrong type, a number out of range)
// into a ConfigError naming `path`.
template <typename Read>
auto with_json_errors(const std::string& path, Read&& read) -> decltype(read()) {
  try {
    return read();
  } catch (const nlohmann::json::exception& error) {
    throw ConfigError(path + ": " + error.what());
  }
}

// <path> written through a temporary file and a rename; std::runtime_error naming it on failure.
void write_json_file(const nlohmann::json& j, const std::string& path);

// A shard record as written: "command", "format", "shard_index", "shard_count", "run" (what every
// shard of one run has the same), then the command's own members.
nlohmann::json shard_record(const char* command, const Shard& shard, const nlohmann::json& run_identity);

struct ShardFile {
  std::string dir;   // as given to merge
  std::string path;  // <dir>/shard.json
  Shard shard;
  nlohmann::json json;
};
// Reads <dir>/shard.json of each folder and checks that together they are shards 0..N-1 of one
// `command` run (same count, same "run"), each once; returns them by shard index. ConfigError
// naming the folder otherwise.
std::vector<ShardFile> read_shard_set(const std::vector<std::string>& dirs, const char* command);

}  // namespace swerve::lossless
