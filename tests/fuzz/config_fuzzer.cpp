// Fuzz target: bytes as the text of a config file, loaded the way `swerve-mpc check-config` loads
// one (every section through the library's checked loaders, then no unread keys). A ConfigError is
// the expected answer to bad input; its message must be one line of at most ~1000 characters.
// Anything else (another exception, a crash, a sanitizer report, a hang) is a finding.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "config_kinds.hpp"
#include "fuzz_support.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/app/config_node.hpp"

namespace {

// Files named inside a scenario (vehicle, controllers, a CSV reference) resolve beside this name,
// so the shipped scenarios' relative paths (../vehicles/agv_4wheel.yaml) load real files.
const std::string kSourceName = std::string(SWERVE_SOURCE_DIR) + "/configs/scenarios/<fuzz>.yaml";

// The ConfigError promise (config_error.hpp): kMaxConfigErrorChars plus the "... (N bytes)" tail.
constexpr std::size_t kMaxMessageChars = swerve::kMaxConfigErrorChars + 100;

// SWERVE_FUZZ_VERBOSE=1 prints each input's outcome (to see what a corpus file exercises).
const bool kVerbose = std::getenv("SWERVE_FUZZ_VERBOSE") != nullptr;

void check_message(const char* message) {
  if (kVerbose) std::fprintf(stderr, "ConfigError: %s\n", message);
  const std::size_t length = std::strlen(message);
  SWERVE_FUZZ_CHECK(length > 0, "empty ConfigError message");
  SWERVE_FUZZ_CHECK(length <= kMaxMessageChars, "ConfigError message of %zu chars: %.200s...", length, message);
  SWERVE_FUZZ_CHECK(std::strchr(message, '\n') == nullptr && std::strchr(message, '\r') == nullptr,
                    "multi-line ConfigError message: %s", message);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const swerve::config::ConfigNode root = swerve::config::ConfigNode::parse(text, kSourceName);
    for (const swerve::cli::ConfigKind& kind : swerve::cli::all_config_kinds()) {
      if (const auto section = root.optional_child(kind.top_key)) {
        const nlohmann::json loaded = kind.load(*section);
        (void)loaded.dump();
      }
    }
    root.expect_all_read();
    if (kVerbose) std::fprintf(stderr, "loaded\n");
  } catch (const swerve::ConfigError& error) {
    check_message(error.what());
  } catch (const std::exception& error) {
    SWERVE_FUZZ_CHECK(false, "unexpected exception (not a ConfigError): %s", error.what());
  } catch (...) {
    SWERVE_FUZZ_CHECK(false, "unexpected exception of an unknown type");
  }
  return 0;
}
