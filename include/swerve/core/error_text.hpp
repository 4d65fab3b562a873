// Text rules shared by every error message and every config loader: config text must be UTF-8,
// and a value echoed in an error is shown on one line, escaped and cut to a readable length, so a
// 1 MB or multi-line value never turns an error into a 1 MB or multi-line message.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace swerve {

// Echoed values longer than this many characters are cut and end in "...".
inline constexpr std::size_t kMaxEchoedValueChars = 80;

// The byte offset of the first byte that does not start a well-formed UTF-8 sequence (overlong
// forms, surrogates and code points above U+10FFFF are ill-formed), or npos when `text` is valid.
std::size_t find_invalid_utf8(std::string_view text) noexcept;

// `text` as it should appear inside a one-line error message: control characters and invalid
// UTF-8 bytes escaped (\n, \t, \xff), cut after `max_chars` characters with "... (N bytes)".
std::string printable_value(std::string_view text, std::size_t max_chars = kMaxEchoedValueChars);

}  // namespace swerve
