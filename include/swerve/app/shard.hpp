// Splitting a long command (`swerve-mpc envelope`, `sweep`) over the machines of a cluster: shard
// I of N runs the items whose index is I modulo N and writes what it ran, losslessly, to
// <out>/shard.json; `swerve-mpc merge` reads the shards' folders back and writes exactly what one
// unsharded run writes (docs/cli.md shows a Slurm job array and a Kubernetes Indexed Job).
#pragma once

#include <string>

namespace swerve {

struct Shard {
  int index = 0;  // I, in [0, count)
  int count = 1;  // N >= 1; 1: the whole run
  bool whole() const noexcept { return count == 1; }
  bool owns(int item) const noexcept { return item % count == index; }
  std::string text() const { return std::to_string(index) + "/" + std::to_string(count); }
  void validate() const;  // ConfigError "Shard.count = 0: must be >= 1", "Shard.index = 4: ..."
};

// "I/N" (two integers, 0 <= I < N): throws ConfigError naming the text and the rule.
Shard parse_shard(const std::string& text);

// The file a shard writes into its output folder, and merge reads from each folder given.
inline constexpr const char* kShardFileName = "shard.json";

}  // namespace swerve
