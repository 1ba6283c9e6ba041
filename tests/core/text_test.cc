// Text from files is made valid UTF-8 and printable (core/util/text.h).
#include "core/util/text.h"

#include <gtest/gtest.h>

namespace furn {
namespace {

TEST(Text, ValidUtf8IsRecognisedAndIllFormedIsNot) {
  EXPECT_TRUE(IsValidUtf8("Küche 😀 \u2028"));
  EXPECT_FALSE(IsValidUtf8("\xFF"));
  EXPECT_FALSE(IsValidUtf8("\xC0\xAF"));          // overlong '/'
  EXPECT_FALSE(IsValidUtf8("\xED\xA0\xBD"));      // a surrogate (CESU-8 half)
  EXPECT_FALSE(IsValidUtf8("\xF4\x90\x80\x80"));  // above U+10FFFF
  EXPECT_FALSE(IsValidUtf8("\xE2\x82"));          // cut short
}

TEST(Text, IllFormedBytesBecomeReplacementCharacters) {
  EXPECT_EQ(ValidUtf8("a\xFF"
                      "b"),
            "a\xEF\xBF\xBD"
            "b");
  std::string six_replacements;
  for (int k = 0; k < 6; ++k) six_replacements += "\xEF\xBF\xBD";
  EXPECT_EQ(ValidUtf8("\xED\xA0\xBD\xED\xB8\x80"), six_replacements);  // byte by byte
  EXPECT_EQ(ValidUtf8("Küche"), "Küche");
  EXPECT_TRUE(IsValidUtf8(ValidUtf8(std::string("\x80\xC3\x28\xF0\x9F\x98", 6))));
}

TEST(Text, ControlCharactersArePrintedAsEscapes) {
  EXPECT_EQ(PrintableText("a\nb\tc\r"), "a\\nb\\tc\\r");
  EXPECT_EQ(PrintableText("\x1B[2J"), "\\x1B[2J");
  EXPECT_EQ(PrintableText("x\u2028y"), "x\\u2028y");
  EXPECT_EQ(PrintableText("\xC2\x9B"), "\\x9B");  // C1 CSI
  EXPECT_EQ(PrintableText("Küche 😀"), "Küche 😀");
  EXPECT_EQ(PrintableText(std::string("a\0b", 3)), "a\\x00b");
}

TEST(Text, CodePointsEncode) {
  EXPECT_EQ(Utf8FromCodePoint(0x1F600), "😀");
  EXPECT_EQ(Utf8FromCodePoint(0xD83D), "\xEF\xBF\xBD");
  EXPECT_EQ(Utf8FromCodePoint(0x41), "A");
}

}  // namespace
}  // namespace furn
