// Lossless JSON for the records shards hand to `swerve-mpc merge`: every double written so that it
// reads back bit for bit (nlohmann writes the shortest text that round-trips; NaN and infinities,
// which JSON lacks, as the strings "nan", "inf" and "-inf"), and the run metrics whole.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "swerve/sim/metrics.hpp"

namespace swerve::lossless {

nlohmann::json number(double value);
// Reads what number() wrote; ConfigError naming `where` otherwise.
double read_number(const nlohmann::json& value, const std::string& where);

nlohmann::json metrics(const RunMetrics& m);
RunMetrics read_metrics(const nlohmann::json& j, const std::string& where);

// j[key] or a ConfigError "<where>: missing 'key'".
const nlohmann::json& member(const nlohmann::json& j, const char* key, const std::string& where);

}  // namespace swerve::lossless
