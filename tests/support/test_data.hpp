// Where the tests' data files are: tests/<suite>/data/ in the source tree (SWERVE_SOURCE_DIR).
#pragma once

#include <string>

namespace swerve::testing {

// tests/app/data/<name>, the scenario and controller files of the app-layer tests.
inline std::string app_data_file(const std::string& name) {
  return std::string(SWERVE_SOURCE_DIR) + "/tests/app/data/" + name;
}

}  // namespace swerve::testing
