// swerve-mpc: command-line entry point. Parses the command line with CLI11, dispatches to the
// registered subcommand, and turns every failure into one line on stderr and a non-zero exit code.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <exception>
#include <iostream>

#include "command_registry.hpp"
#include "swerve/version.hpp"

int main(int argc, char** argv) {
  using swerve::cli::Command;
  CLI::App app{"swerve-mpc: tire-wear-aware MPC for swerve-drive vehicles", "swerve-mpc"};
  app.set_version_flag("-V,--version", std::string("swerve-mpc ") + swerve::kVersion);
  // Subcommands are optional to CLI11 so that an unknown word or flag is reported as itself
  // rather than as "a subcommand is required"; a missing command is caught after parsing.
  app.require_subcommand(0, 1);

  std::function<int()> action;
  std::string command_names;
  for (const Command& command : swerve::cli::all_commands()) {
    CLI::App* sub = app.add_subcommand(command.name, command.summary);
    auto run = command.declare(*sub);
    sub->callback([&action, run]() { action = run; });
    command_names += (command_names.empty() ? "" : ", ") + command.name;
  }
  const auto& commands = swerve::cli::all_commands();
  const bool known = argc > 1 && std::any_of(commands.begin(), commands.end(),
                                             [&](const Command& c) { return c.name == argv[1]; });
  if (argc > 1 && argv[1][0] != '-' && !known) {
    std::cerr << "swerve-mpc: unknown command '" << argv[1] << "' (commands: " << command_names << ")\n";
    return swerve::cli::kExitUsage;
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << app.help();
    return swerve::cli::kExitOk;
  } catch (const CLI::CallForAllHelp&) {
    std::cout << app.help("", CLI::AppFormatMode::All);
    return swerve::cli::kExitOk;
  } catch (const CLI::CallForVersion& version) {
    std::cout << version.what() << "\n";
    return swerve::cli::kExitOk;
  } catch (const CLI::ParseError& error) {
    std::cerr << "swerve-mpc: " << error.what() << " (see swerve-mpc --help)\n";
    return swerve::cli::kExitUsage;
  }

  if (!action) {
    std::cerr << "swerve-mpc: a command is required (commands: " << command_names << "; see --help)\n";
    return swerve::cli::kExitUsage;
  }
  try {
    return action();
  } catch (const std::exception& error) {
    std::cerr << "swerve-mpc: " << error.what() << "\n";
    return swerve::cli::kExitFailure;
  }
}
