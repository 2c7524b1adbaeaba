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

}  // namespace
}  // namespace mlspaces
