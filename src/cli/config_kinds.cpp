#include "config_kinds.hpp"

#include "swerve/config/target_config.hpp"

namespace swerve::cli {
namespace {

nlohmann::json load_target(const config::ConfigNode& section) {
  const TargetConfig target = load_target_config(section);
  return {{"name", target.name},
          {"description", target.description},
          {"control_period_s", target.control_period},
          {"solve_budget_s", target.solve_budget},
          {"cores", target.cores},
          {"cpu_slowdown", target.cpu_slowdown}};
}

}  // namespace

const std::vector<ConfigKind>& all_config_kinds() {
  static const std::vector<ConfigKind> kinds = {
      {"target", "an embedded target's real-time budget (configs/targets/)", &load_target},
  };
  return kinds;
}

nlohmann::json load_any_config_file(const std::string& file_path) {
  const config::ConfigNode root = config::ConfigNode::load_file(file_path);
  nlohmann::json loaded = {{"file", file_path}};
  bool found_any = false;
  for (const ConfigKind& kind : all_config_kinds()) {
    if (const auto section = root.optional_child(kind.top_key)) {
      loaded[kind.top_key] = kind.load(*section);
      found_any = true;
    }
  }
  if (!found_any) {
    std::string expected;
    for (const ConfigKind& kind : all_config_kinds()) {
      expected += (expected.empty() ? "" : ", ") + kind.top_key;
    }
    root.fail("no known section at the top level (expected one of: " + expected + ")");
  }
  root.expect_all_read();
  return loaded;
}

}  // namespace swerve::cli
