// Bounded reading of whole text files: contents come back whole, a file past the limit is refused
// naming the file and the limit, and the buffer follows the file, not the limit.
#include "swerve/core/text_file.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "swerve/core/config_error.hpp"

namespace swerve::config {
namespace {

std::string write_file(const std::string& text) {
  const std::string path = ::testing::TempDir() + "text_file_test_" + std::to_string(::getpid()) + ".txt";
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

TEST(ReadTextFile, ReturnsTheWholeFileUpToTheLimitAndRefusesOneByteMore) {
  const std::string text(1000, 'x');
  const std::string path = write_file(text);
  TextFileRules rules;
  rules.max_bytes = 1000;
  EXPECT_EQ(read_text_file(path, rules), text);
  rules.max_bytes = 999;
  try {
    read_text_file(path, rules);
    FAIL() << "a file past the limit was read";
  } catch (const ConfigError& error) {
    EXPECT_EQ(std::string(error.what()), path + ": 1000 bytes: config files are limited to 999 bytes");
  }
  std::remove(path.c_str());
}

// The buffer was once the limit's size, zeroed: 256 MiB of memset for each small shard record, and
// a limit beyond memory threw std::bad_alloc for a file of a few bytes.
TEST(ReadTextFile, ASmallFileUnderAHugeLimitAllocatesForTheFileNotTheLimit) {
  const std::string path = write_file("seed: 1\n");
  TextFileRules rules;
  rules.max_bytes = std::size_t{1} << 50;  // 1 PiB
  EXPECT_EQ(read_text_file(path, rules), "seed: 1\n");
  std::remove(path.c_str());
}

}  // namespace
}  // namespace swerve::config
