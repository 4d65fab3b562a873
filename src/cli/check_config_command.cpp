// `swerve-mpc check-config FILE...`: loads each file exactly as the library would and prints what
// it loaded (defaults filled in), or the first error with file, key path and value.
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>

#include "command_registry.hpp"
#include "config_kinds.hpp"

namespace swerve::cli {

Command make_check_config_command() {
  return {"check-config", "Validate config files and print what was loaded",
          [](CLI::App& app) -> std::function<int()> {
            auto files = std::make_shared<std::vector<std::string>>();
            auto quiet = std::make_shared<bool>(false);
            app.add_option("files", *files, "YAML config files (vehicle, controller, scenario, target)")
                ->required();
            app.add_flag("-q,--quiet", *quiet, "Print only errors");
            return [files, quiet]() {
              int exit_code = kExitOk;
              for (const std::string& file : *files) {
                try {
                  const nlohmann::json loaded = load_any_config_file(file);
                  if (!*quiet) std::cout << loaded.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
                } catch (const ConfigError& error) {
                  std::cerr << "swerve-mpc check-config: " << error.what() << "\n";
                  exit_code = kExitFailure;
                }
              }
              return exit_code;
            };
          }};
}

}  // namespace swerve::cli
