// The kinds of config document swerve-mpc understands, keyed by their top-level key
// (`vehicle:`, `target:`, ...). Each kind loads its section through the library's checked loaders
// and returns what it loaded as JSON, with every default filled in.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "swerve/app/config_node.hpp"

namespace swerve::cli {

struct ConfigKind {
  std::string top_key;
  std::string description;
  nlohmann::json (*load)(const config::ConfigNode& section);
};

const std::vector<ConfigKind>& all_config_kinds();

// Loads every section of a config file, then rejects keys no loader read.
// Returns {"file": ..., "<top_key>": {...}} or throws ConfigError.
nlohmann::json load_any_config_file(const std::string& file_path);

}  // namespace swerve::cli
