#include "swerve/core/text_file.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <system_error>

#include "swerve/core/config_error.hpp"
#include "swerve/core/error_text.hpp"

namespace swerve::config {
namespace {

const char* describe_file_type(std::filesystem::file_type type) {
  switch (type) {
    case std::filesystem::file_type::directory:
      return "a directory";
    case std::filesystem::file_type::character:
      return "a character device";
    case std::filesystem::file_type::block:
      return "a block device";
    case std::filesystem::file_type::fifo:
      return "a pipe";
    case std::filesystem::file_type::socket:
      return "a socket";
    default:
      return "not a regular file";
  }
}

std::string file_too_large(const std::string& file_path, const std::string& size, const TextFileRules& rules) {
  constexpr std::size_t kMiB = std::size_t{1} << 20;
  const std::string limit = rules.max_bytes % kMiB == 0 ? std::to_string(rules.max_bytes / kMiB) + " MiB (" +
                                                              std::to_string(rules.max_bytes) + " bytes)"
                                                        : std::to_string(rules.max_bytes) + " bytes";
  return printable_value(file_path, std::string::npos) + ": " + size + " bytes: " + rules.kind_plural +
         " are limited to " + limit;
}

}  // namespace

std::string read_text_file(const std::string& file_path, const TextFileRules& rules) {
  namespace fs = std::filesystem;
  const std::string shown = printable_value(file_path, std::string::npos);
  // Checked before reading: a directory reads as an empty document and /dev/zero never ends.
  std::error_code error;
  const fs::file_status status = fs::status(file_path, error);
  if (status.type() == fs::file_type::not_found || (error && !fs::exists(status))) {
    throw ConfigError(shown + ": cannot open the file for reading");
  }
  if (error) throw ConfigError(shown + ": cannot open the file for reading (" + error.message() + ")");
  if (!fs::is_regular_file(status)) {
    throw ConfigError(shown + ": " + describe_file_type(status.type()) + ", not a regular file: give a " +
                      rules.format + " file");
  }
  const std::uintmax_t size = fs::file_size(file_path, error);
  if (!error && size > rules.max_bytes) throw ConfigError(file_too_large(file_path, std::to_string(size), rules));
  std::ifstream in(file_path, std::ios::binary);
  if (!in) throw ConfigError(shown + ": cannot open the file for reading (" + std::strerror(errno) + ")");
  // Sized for the file as measured (not for the limit: a buffer of the limit, zeroed, cost 256 MiB
  // of memset per read of a small file under a large limit), growing if the file grew since, and
  // read at most one byte past the limit, so a growing file stays bounded.
  const std::size_t measured = error ? 0 : static_cast<std::size_t>(size);
  // One below the largest size, so that the limit plus the byte past it never wraps to 0.
  const std::size_t max_bytes = std::min(rules.max_bytes, std::numeric_limits<std::size_t>::max() - 1);
  std::size_t capacity = std::min(max_bytes, measured) + 1;
  std::string text(capacity, '\0');
  std::size_t filled = 0;
  for (;;) {
    in.read(&text[filled], static_cast<std::streamsize>(capacity - filled));
    filled += static_cast<std::size_t>(in.gcount());
    if (filled < capacity || capacity > max_bytes) break;  // the end, or past the limit
    capacity = capacity > max_bytes / 2 ? max_bytes + 1 : 2 * capacity;
    text.resize(capacity);
  }
  text.resize(filled);
  if (in.bad()) throw ConfigError(shown + ": read error");
  if (text.size() > rules.max_bytes) {
    throw ConfigError(file_too_large(file_path, "more than " + std::to_string(rules.max_bytes), rules));
  }
  return text;
}

void write_text_file_atomically(const std::string& file_path, const std::string& text) {
  const std::string temporary = file_path + ".tmp";
  {
    std::ofstream out(temporary);
    if (!out || !(out << text) || !out.flush()) throw std::runtime_error(temporary + ": cannot write");
  }
  std::error_code error;
  std::filesystem::rename(temporary, file_path, error);
  if (error) throw std::runtime_error(file_path + ": cannot write (" + error.message() + ")");
}

}  // namespace swerve::config
