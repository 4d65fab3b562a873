#include "command_registry.hpp"

namespace swerve::cli {

const std::vector<Command>& all_commands() {
  static const std::vector<Command> commands = {
      make_run_command(),
      make_sweep_command(),
      make_tune_command(),
      make_check_config_command(),
  };
  return commands;
}

}  // namespace swerve::cli
