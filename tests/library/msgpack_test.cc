// The metadata store's MessagePack decoder: round trips against nlohmann::to_msgpack, and
// malformed input (every truncation, trailing bytes, bin/ext types, deep nesting) rejected
// without reading outside the input (the ASan stage and fuzz/msgpack_fuzz.cc check that).
#include "mlspaces/library/msgpack.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace mlspaces {
namespace {

Json Sample() {
  return ParseJson(R"({"z_first": 1, "a_second": -2, "nested": {"b": [1.5, true, null,
      "str\u00e9"], "a": {"deep": 18446744073709551615}}, "float": 0.1, "neg": -9007199254740993,
      "i8": -100, "i16": -30000, "i32": -2000000000, "u8": 200, "u16": 60000, "u32": 4000000000,
      "empty_obj": {}, "empty_arr": [], "unicode": "\u6e2c\u8a66",
      "long": "0123456789012345678901234567890123456789"})",
                   "sample");
}

bool Decode(const std::vector<uint8_t>& bytes, Json& out) { return DecodeMsgpackJson(bytes, out); }

TEST(MsgpackTest, RoundTripsWhatNlohmannWrites) {
  const Json sample = Sample();
  Json out;
  ASSERT_TRUE(Decode(Json::to_msgpack(sample), out));
  EXPECT_EQ(out, sample);
  EXPECT_EQ(out.dump(), sample.dump());  // key order kept
  // Big containers and strings take the 16/32-bit length forms.
  Json big = Json::array();
  for (int i = 0; i < 70000; ++i) big.push_back(i % 3 == 0 ? Json(i) : Json("x"));
  Json obj = Json::object();
  for (int i = 0; i < 20; ++i) obj["k" + std::to_string(i)] = std::string(300, 'a' + i % 26);
  for (const Json& j : {big, obj, Json(std::string(70000, 'q')), Json(nullptr), Json(false)}) {
    ASSERT_TRUE(Decode(Json::to_msgpack(j), out));
    EXPECT_EQ(out, j);
  }
}

TEST(MsgpackTest, RejectsEveryTruncationAndTrailingBytes) {
  const std::vector<uint8_t> bytes = Json::to_msgpack(Sample());
  for (size_t n = 0; n < bytes.size(); ++n) {
    Json out;
    EXPECT_FALSE(DecodeMsgpackJson({bytes.data(), n}, out)) << n;
  }
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0xc0);
  Json out;
  EXPECT_FALSE(Decode(longer, out));
}

TEST(MsgpackTest, RejectsTypesJsonNeverHolds) {
  Json out;
  EXPECT_FALSE(Decode({0xc4, 0x01, 0x00}, out));              // bin 8
  EXPECT_FALSE(Decode({0xd4, 0x01, 0x00}, out));              // fixext 1
  EXPECT_FALSE(Decode({0xc1}, out));                          // never used
  EXPECT_FALSE(Decode({0x81, 0x01, 0x02}, out));              // map key not a string
  EXPECT_FALSE(Decode({0xdd, 0xff, 0xff, 0xff, 0xff}, out));  // huge count, no items
  EXPECT_TRUE(Decode({0x82, 0xa1, 'a', 0x01, 0xa1, 'a', 0x02}, out));
  EXPECT_EQ(out, ParseJson(R"({"a": 1})", "dup"));  // first of duplicate keys kept
}

TEST(MsgpackTest, LimitsNesting) {
  std::vector<uint8_t> ok(kMaxMsgpackDepth, 0x91);  // [[[...]]]
  ok.push_back(0xc0);
  Json out;
  EXPECT_TRUE(Decode(ok, out));
  std::vector<uint8_t> deep(kMaxMsgpackDepth + 1, 0x91);
  deep.push_back(0xc0);
  EXPECT_FALSE(Decode(deep, out));
  std::vector<uint8_t> very_deep(1 << 20, 0x91);  // never recurses past the limit
  EXPECT_FALSE(Decode(very_deep, out));
}

}  // namespace
}  // namespace mlspaces
