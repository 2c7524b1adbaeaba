// ParseJson / ParseFlatJson: simdjson parsing converted to nlohmann values must behave exactly
// like nlohmann's own parser (types, key order, duplicates, errors).
#include "mlspaces/core/json.h"

#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "test_util.h"

namespace mlspaces {
namespace {

using ::mlspaces::testing::ErrorOf;
using ::testing::HasSubstr;

// Every parse must equal nlohmann's own, including the type of each number.
void ExpectSameAsNlohmann(const std::string& text) {
  Json ours = ParseJson(text, "x.json");
  Json theirs = Json::parse(text);
  EXPECT_EQ(ours, theirs) << text;
  EXPECT_EQ(ours.dump(), theirs.dump()) << text;
  FlatJson flat = ParseFlatJson(text, "x.json");
  EXPECT_EQ(flat.dump(), FlatJson::parse(text).dump()) << text;
}

TEST(JsonTest, SameValuesAndTypesAsNlohmann) {
  ExpectSameAsNlohmann(R"({"b": 1, "a": -2, "c": 0.12500000000000003, "d": [true, false, null],
      "e": {"z": "\u00e9\ud83d\ude00", "y": 1e-5}, "f": 18446744073709551615, "g": -0.0})");
  ExpectSameAsNlohmann("[]");
  ExpectSameAsNlohmann("{}");
  ExpectSameAsNlohmann("3");
  ExpectSameAsNlohmann(R"("just a string")");
  // Beyond 64 bits: simdjson refuses, nlohmann reads a double; we must read it too.
  ExpectSameAsNlohmann(R"({"big": 123456789012345678901234567890})");
}

TEST(JsonTest, NumberKindsFollowNlohmann) {
  Json j = ParseJson(R"({"u": 7, "i": -7, "f": 7.0})", "x.json");
  EXPECT_TRUE(j["u"].is_number_unsigned());
  EXPECT_TRUE(j["i"].is_number_integer());
  EXPECT_FALSE(j["i"].is_number_unsigned());
  EXPECT_TRUE(j["f"].is_number_float());
  EXPECT_EQ(DumpJsonIndent4(j["f"]), "7.0");
}

TEST(JsonTest, KeyOrderKeptAndDuplicateKeysLastValueWins) {
  Json j = ParseJson(R"({"z": 1, "a": 2, "z": 3})", "x.json");
  ASSERT_EQ(j.size(), 2u);
  EXPECT_EQ(j.begin().key(), "z");
  EXPECT_EQ(j["z"], 3);
  EXPECT_EQ(j.dump(), Json::parse(R"({"z": 1, "a": 2, "z": 3})").dump());
}

TEST(JsonTest, ErrorsNameFileLineAndColumn) {
  EXPECT_THAT(ErrorOf([] { ParseJson("{\n  \"a\": oops\n}", "meta.json"); }),
              HasSubstr("meta.json: line 2, column 8: invalid JSON"));
  EXPECT_THAT(ErrorOf([] { ParseFlatJson("{\"a\": 1", "index.json"); }),
              HasSubstr("index.json: line 1, column"));
  EXPECT_THAT(ErrorOf([] { ParseJson("{\"a\": \"\xff\"}", "bad_utf8.json"); }),
              HasSubstr("bad_utf8.json: line 1"));
  EXPECT_THAT(ErrorOf([] { ParseJson("", "empty.json"); }), HasSubstr("empty.json: line 1"));
}

TEST(JsonTest, DumpEscapesLikePython) {
  Json j = ParseJson(R"({"name": "caf\u00e9", "v": [1, 2]})", "x.json");
  EXPECT_EQ(DumpJsonIndent4(j),
            "{\n    \"name\": \"caf\\u00e9\",\n    \"v\": [\n        1,\n        2\n    ]\n}");
}

TEST(JsonTest, LargeIndexParses) {
  // 200,000 keys: ordered_json insertion would be quadratic; FlatJson must not be.
  std::string text = "{";
  for (int i = 0; i < 200000; ++i) {
    text += (i ? ",\"k" : "\"k") + std::to_string(i) + "\":" + std::to_string(i);
  }
  text += "}";
  FlatJson j = ParseFlatJson(text, "big.json");
  EXPECT_EQ(j.size(), 200000u);
  EXPECT_EQ(j["k199999"], 199999);
}

}  // namespace
}  // namespace mlspaces
