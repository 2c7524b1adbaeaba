// Small string helpers (src/core/strings.cc).
#include "mlspaces/core/strings.h"

#include <gtest/gtest.h>

namespace mlspaces {
namespace {

TEST(StringsTest, LowerIsAsciiOnly) {
  EXPECT_EQ(Lower("Block_Pickup"), "block_pickup");
  EXPECT_EQ(Lower("ABC xyz 09_-"), "abc xyz 09_-");
  EXPECT_EQ(Lower(""), "");
  // Bytes >= 0x80 (UTF-8) stay as they are, whatever the locale.
  EXPECT_EQ(Lower("\xC3\x84X"), "\xC3\x84x");
}

TEST(StringsTest, PrintableEscapesControlCharactersAndBadUtf8) {
  EXPECT_EQ(Printable("red_block"), "red_block");
  EXPECT_EQ(Printable("a\x1b[31mb\nc\td\x7f"), "a\\x1b[31mb\\x0ac\\x09d\\x7f");
  EXPECT_EQ(Printable(std::string("a\0b", 3)), "a\\x00b");
  // UTF-8 stays; a lone continuation byte, a cut sequence and C1 controls do not.
  EXPECT_EQ(Printable("\xC3\x84 \xE2\x82\xAC"), "\xC3\x84 \xE2\x82\xAC");
  EXPECT_EQ(Printable("\x80x\xC3"), "\\x80x\\xc3");
  EXPECT_EQ(Printable("\xC2\x9B"), "\\xc2\\x9b");
  // Applying it twice changes nothing.
  EXPECT_EQ(Printable(Printable("a\x1b"
                                "b")),
            "a\\x1bb");
}

}  // namespace
}  // namespace mlspaces
