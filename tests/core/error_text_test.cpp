// find_invalid_utf8 and printable_value: the text rules behind every one-line error message.
#include "swerve/core/error_text.hpp"

#include <gtest/gtest.h>

#include <string>

namespace swerve {
namespace {

TEST(FindInvalidUtf8, AcceptsAsciiAndEveryLengthOfWellFormedSequence) {
  EXPECT_EQ(find_invalid_utf8(""), std::string::npos);
  EXPECT_EQ(find_invalid_utf8("plain ascii"), std::string::npos);
  EXPECT_EQ(find_invalid_utf8("caf\xc3\xa9 \xe2\x86\x92 \xf0\x9f\x9a\x97 \xf4\x8f\xbf\xbf"),
            std::string::npos);
}

TEST(FindInvalidUtf8, ReportsTheOffsetOfTheFirstBadByte) {
  EXPECT_EQ(find_invalid_utf8("caf\xe9"), 3u);  // Latin-1, not UTF-8
  EXPECT_EQ(find_invalid_utf8("ab\x80"), 2u);   // stray continuation byte
  EXPECT_EQ(find_invalid_utf8("ok\xc3"), 2u);   // truncated sequence
}

TEST(FindInvalidUtf8, RejectsOverlongFormsSurrogatesAndCodePointsAboveTheRange) {
  EXPECT_EQ(find_invalid_utf8("\xc0\xaf"), 0u);          // overlong '/'
  EXPECT_EQ(find_invalid_utf8("\xe0\x80\xaf"), 0u);      // overlong, 3 bytes
  EXPECT_EQ(find_invalid_utf8("\xed\xa0\x80"), 0u);      // U+D800, a UTF-16 surrogate
  EXPECT_EQ(find_invalid_utf8("\xf4\x90\x80\x80"), 0u);  // U+110000
  EXPECT_EQ(find_invalid_utf8("\xff"), 0u);
}

TEST(PrintableValue, LeavesShortPrintableTextAlone) {
  EXPECT_EQ(printable_value("0.05"), "0.05");
  EXPECT_EQ(printable_value("caf\xc3\xa9"), "caf\xc3\xa9");
}

TEST(PrintableValue, EscapesControlCharactersAndInvalidBytes) {
  EXPECT_EQ(printable_value("a\nb\tc\rd\x01\x7f"), "a\\nb\\tc\\rd\\x01\\x7f");
  EXPECT_EQ(printable_value("caf\xe9"), "caf\\xe9");
}

TEST(PrintableValue, CutsLongTextAndSaysHowLongItWas) {
  EXPECT_EQ(printable_value(std::string(1000, 'x')),
            std::string(kMaxEchoedValueChars, 'x') + "... (1000 bytes)");
  EXPECT_EQ(printable_value("abcdef", 3), "abc... (6 bytes)");
  EXPECT_EQ(printable_value("abc", 3), "abc");
}

TEST(PrintableValue, NeverCutsAMultiByteCharacterInHalf) {
  // Two-byte characters: the cut falls after the third character, on a character boundary.
  EXPECT_EQ(printable_value("\xc3\xa9\xc3\xa9\xc3\xa9\xc3\xa9", 3), "\xc3\xa9\xc3\xa9\xc3\xa9... (8 bytes)");
}

}  // namespace
}  // namespace swerve
