// Links the installed SwerveMPC and uses its public API: loads an embedded target config.
#include <iostream>

#include "swerve/app/config_node.hpp"
#include "swerve/app/target_config.hpp"
#include "swerve/version.hpp"

int main(int argc, char** argv) {
  std::cout << "SwerveMPC " << swerve::kVersion << "\n";
  if (argc < 2) return 0;
  try {
    const auto root = swerve::config::ConfigNode::load_file(argv[1]);
    const swerve::TargetConfig target = swerve::load_target_config(root.child("target"));
    root.expect_all_read();
    std::cout << "target " << target.name << ": solve budget " << target.solve_budget * 1e3 << " ms of a "
              << target.control_period * 1e3 << " ms cycle\n";
  } catch (const swerve::ConfigError& error) {
    std::cerr << error.what() << "\n";
    return 1;
  }
  return 0;
}
