// swerve-mpc: command-line entry point. Parses the command line with CLI11, dispatches to the
// registered subcommand, and turns every failure into one line on stderr and a non-zero exit code:
// 2 when the command line is wrong, 1 otherwise; never a stack trace or a core dump.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <new>

#include "command_registry.hpp"
#include "swerve/core/error_text.hpp"
#include "swerve/version.hpp"

namespace {

// Longest error line printed: long enough for a nested config error, short enough to read.
constexpr std::size_t kMaxErrorLineChars = 1000;

int report(const std::string& message, int exit_code) {
  std::cerr << "swerve-mpc: " << swerve::printable_value(message, kMaxErrorLineChars) << "\n";
  return exit_code;
}

// An exception escaping a noexcept function ends in std::terminate, whose default handler aborts
// with a core dump; say what happened in one line and exit instead.
[[noreturn]] void report_termination() {
  std::string what = "internal error: terminated";
  if (const std::exception_ptr current = std::current_exception()) {
    try {
      std::rethrow_exception(current);
    } catch (const std::exception& error) {
      what = std::string("internal error: ") + error.what();
    } catch (...) {
      what = "internal error: an unknown exception";
    }
  }
  report(what, swerve::cli::kExitFailure);
  std::_Exit(swerve::cli::kExitFailure);
}

int run_main(int argc, char** argv) {
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
    return report(std::string("unknown command '") + argv[1] + "' (commands: " + command_names + ")",
                  swerve::cli::kExitUsage);
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
    return report(std::string(error.what()) + " (see swerve-mpc --help)", swerve::cli::kExitUsage);
  }

  if (!action) {
    return report("a command is required (commands: " + command_names + "; see --help)",
                  swerve::cli::kExitUsage);
  }
  try {
    return action();
  } catch (const swerve::cli::UsageError& error) {
    return report(std::string(error.what()) + " (see swerve-mpc --help)", swerve::cli::kExitUsage);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::set_terminate(report_termination);
  try {
    return run_main(argc, argv);
  } catch (const std::bad_alloc&) {
    return report("out of memory", swerve::cli::kExitFailure);
  } catch (const std::exception& error) {
    return report(error.what(), swerve::cli::kExitFailure);
  } catch (...) {
    return report("an unknown exception", swerve::cli::kExitFailure);
  }
}
