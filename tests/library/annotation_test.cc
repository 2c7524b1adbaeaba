#include "mlspaces/library/annotation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/npz.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::TempDir;
using ::testing::HasSubstr;

class AnnotationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    json_ = dir_ / "cube.json";
    npz_ = dir_ / "cube.npz";
    WriteFileAtomic(json_, R"({"category": "block", "description_short": {"one_word": "cube"},
                               "list": [1, 2]})");
  }

  std::string Collision(const std::vector<std::pair<std::string, NpyArray>>& arrays) {
    WriteNpz(npz_, arrays);
    try {
      LoadAnnotation("cube", "lib", json_, &npz_);
    } catch (const Error& e) {
      return e.what();
    }
    return "<no error>";
  }

  TempDir tmp_;
  const fs::path dir_ = tmp_.path();
  fs::path json_, npz_;
};

NpyArray Vec(std::vector<double> v) { return NpyArray::FromDoubles({v.size()}, v); }

TEST_F(AnnotationTest, JsonOnly) {
  Annotation a = LoadAnnotation("cube", "lib", json_, nullptr);
  EXPECT_EQ(a.uid, "cube");
  EXPECT_EQ(a.library, "lib");
  EXPECT_EQ(a.json["category"], "block");
  EXPECT_TRUE(a.arrays.empty());
  // Key order as written.
  std::vector<std::string> keys;
  for (auto& [k, v] : a.json.items()) keys.push_back(k);
  EXPECT_THAT(keys, ::testing::ElementsAre("category", "description_short", "list"));
  EXPECT_EQ(a.ToJson(), a.json);
}

TEST_F(AnnotationTest, MergesNpzKeysAsPaths) {
  const std::vector<double> feats = {0.5, 0.25, 1, 2, 3, 4};
  WriteNpz(npz_, {{"description_short/clip", Vec({0.5, -1.0})},
                  {"clip_img_features", NpyArray::FromDoubles(DType::kF2, {2, 3}, feats)},
                  {"deep/a/b", NpyArray::FromDoubles(DType::kI8, {}, std::vector<double>{7})},
                  {"flags", NpyArray::FromDoubles(DType::kB1, {2}, std::vector<double>{1, 0})}});
  Annotation a = LoadAnnotation("cube", "lib", json_, &npz_);
  ASSERT_EQ(a.arrays.size(), 4u);
  // The JSON stays as written; arrays sit at their pointers.
  EXPECT_FALSE(a.json["description_short"].contains("clip"));
  EXPECT_FALSE(a.json.contains("deep"));
  const NpyArray* clip = a.FindArray("/description_short/clip");
  ASSERT_NE(clip, nullptr);
  EXPECT_EQ(clip->AsDouble(1), -1.0);
  EXPECT_EQ(a.FindArray("/description_short"), nullptr);
  EXPECT_NE(a.FindArray("/deep/a/b"), nullptr);

  const Json merged = a.ToJson();
  EXPECT_EQ(merged["description_short"]["one_word"], "cube");
  EXPECT_EQ(merged["description_short"]["clip"], Json::parse("[0.5, -1.0]"));
  EXPECT_EQ(merged["clip_img_features"], Json::parse("[[0.5, 0.25, 1.0], [2.0, 3.0, 4.0]]"));
  EXPECT_EQ(merged["deep"]["a"]["b"], 7);
  EXPECT_EQ(merged["flags"], Json::parse("[true, false]"));
  EXPECT_EQ(merged["category"], "block");
}

TEST_F(AnnotationTest, DigitKeysStayObjectKeys) {
  WriteNpz(npz_, {{"layers/0", Vec({1})}});
  const Json merged = LoadAnnotation("cube", "lib", json_, &npz_).ToJson();
  ASSERT_TRUE(merged["layers"].is_object());
  EXPECT_EQ(merged["layers"]["0"], Json::parse("[1.0]"));
}

TEST_F(AnnotationTest, CollisionsAreErrors) {
  const std::string prefix = "Key ";
  EXPECT_THAT(Collision({{"category", Vec({1})}}),
              HasSubstr("Key category from npz metadata already exists in metadata for uid=cube"));
  EXPECT_THAT(Collision({{"description_short/one_word", Vec({1})}}),
              HasSubstr("Key description_short/one_word from npz metadata already exists"));
  // Crossing a non-object (a JSON list, or another array).
  EXPECT_THAT(Collision({{"list/x", Vec({1})}}), HasSubstr("Key list/x from npz"));
  EXPECT_THAT(Collision({{"a", Vec({1})}, {"a/b", Vec({2})}}), HasSubstr("Key a/b from npz"));
  // Names the NPZ file.
  EXPECT_THAT(Collision({{"category", Vec({1})}}), HasSubstr(npz_.string()));
  // Siblings under a new object are fine.
  EXPECT_EQ(Collision({{"n/a", Vec({1})}, {"n/b", Vec({2})}}), "<no error>");
}

TEST_F(AnnotationTest, BadFiles) {
  const fs::path missing = dir_ / "missing.json";
  EXPECT_THROW(LoadAnnotation("cube", "lib", missing, nullptr), Error);
  WriteFileAtomic(json_, "[1, 2]");
  try {
    LoadAnnotation("cube", "lib", json_, nullptr);
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("must be a JSON object"));
    EXPECT_EQ(e.path(), json_.string());
  }
  WriteFileAtomic(json_, "{\"a\": ");
  EXPECT_THROW(LoadAnnotation("cube", "lib", json_, nullptr), Error);
  WriteFileAtomic(json_, "{}");
  const fs::path bad_npz = dir_ / "bad.npz";
  WriteFileAtomic(bad_npz, "not a zip");
  EXPECT_THROW(LoadAnnotation("cube", "lib", json_, &bad_npz), Error);
}

TEST_F(AnnotationTest, LargeJsonFileIsReadWhole) {
  std::string big = "{\"pad\": \"" + std::string(200000, 'x') + "\", \"end\": 1}";
  WriteFileAtomic(json_, big);
  Annotation a = LoadAnnotation("cube", "lib", json_, nullptr);
  EXPECT_EQ(a.json["end"], 1);
  EXPECT_EQ(a.json["pad"].get<std::string>().size(), 200000u);
}

}  // namespace
}  // namespace mlspaces
