// Bounded reading of a whole text file (a config, or a file a config names, like a reference CSV),
// with errors that name the file: the one place the library opens files it was given by name.
#pragma once

#include <cstddef>
#include <string>

namespace swerve::config {

// Config files larger than this are refused before parsing: every shipped config is under 10 KiB,
// and without a limit a stray /dev/zero or a 50 MB list ends in std::bad_alloc after a minute.
inline constexpr std::size_t kMaxConfigFileBytes = std::size_t{1} << 20;  // 1 MiB
// What read_text_file accepts, and the words its messages use ("config files are limited to 1 MiB",
// "give a YAML file").
struct TextFileRules {
  std::size_t max_bytes = kMaxConfigFileBytes;
  const char* kind_plural = "config files";
  const char* format = "YAML";
};

// Reads a whole text file: a config, or a file a config names (a reference CSV). Throws ConfigError
// naming the file when it is missing or unreadable, not a regular file (a directory, /dev/zero, a
// pipe: checked before reading, since those read as empty, never end or block), or larger than
// rules.max_bytes (the read stops one byte past it, so a file that grows meanwhile stays bounded).
std::string read_text_file(const std::string& file_path, const TextFileRules& rules = TextFileRules{});

// Writes `text` to `<file_path>.tmp` and renames it into place, so an interrupted write leaves the
// previous file or none, never half of one. Throws std::runtime_error "<path>.tmp: cannot write" or
// "<path>: cannot write (<reason>)".
void write_text_file_atomically(const std::string& file_path, const std::string& text);

}  // namespace swerve::config
