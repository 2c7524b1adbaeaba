#include "mlspaces/library/validate.h"

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/npz.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::CopyExampleLibrary;
using ::mlspaces::testing::ExampleLibrary;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

std::vector<std::string> Strings(const std::vector<Problem>& problems) {
  std::vector<std::string> out;
  out.reserve(problems.size());
  for (const Problem& p : problems) out.push_back(p.ToString());
  return out;
}

void WriteGrasps(const fs::path& path, const std::vector<double>& values, std::vector<size_t> shape,
                 DType dtype = DType::kF8) {
  WriteNpz(path, {{"transforms", NpyArray::FromDoubles(dtype, std::move(shape), values)}});
}

std::vector<double> Identity() { return {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}; }

TEST(ValidateTest, ExampleIsClean) {
  EXPECT_THAT(Strings(ValidateLibrary(ExampleLibrary())), IsEmpty());
}

// The example's computed file records its sources; a source changed after the compute makes
// it stale, and validate names the computed file, the source and how to fix it.
TEST(ValidateTest, StaleComputedFileIsAProblem) {
  TempDir tmp;
  const fs::path lib = CopyExampleLibrary(tmp.path());
  EXPECT_THAT(Strings(ValidateLibrary(lib)), IsEmpty());
  WriteText(lib / "red_block/red_block.xml",
            "<mujoco><worldbody><body><geom type=\"box\" size=\"1 1 1\"/></body>"
            "</worldbody></mujoco>");
  const std::string computed = (lib / "red_block/red_block_computed.json").string();
  EXPECT_THAT(Strings(ValidateLibrary(lib)),
              ElementsAre(computed + ": /computed_from/files/red_block.xml: stale: " +
                          (lib / "red_block/red_block.xml").string() +
                          " changed since this file was computed (run mlspaces index-assets "
                          "--compute-metadata again)"));
}

TEST(ValidateTest, ProblemToString) {
  EXPECT_EQ((Problem{"a.json", "/x", "bad"}).ToString(), "a.json: /x: bad");
  EXPECT_EQ((Problem{"a.json", "", "bad"}).ToString(), "a.json: bad");
}

TEST(ValidateTest, MissingFolderAndIndexes) {
  TempDir tmp;
  EXPECT_THAT(Strings(ValidateLibrary(tmp / "nope")),
              ElementsAre((tmp / "nope").string() + ": folder not found"));
  EXPECT_THAT(
      Strings(ValidateLibrary(tmp.path())),
      ElementsAre(tmp.path().string() + ": neither assets_index.json nor grasps_index.json found"));
}

TEST(ValidateTest, IndexEntriesAndFiles) {
  TempDir tmp;
  const fs::path lib = CopyExampleLibrary(tmp.path());
  const std::string index = (lib / "assets_index.json").string();
  WriteText(lib / "assets_index.json", R"({
    "red_block": {"uid": "red_block", "object_path": "red_block/red_block.xml",
                  "metadata_path": "red_block/red_block.json", "metadata_npz_path": null},
    "ghost": {"uid": "phantom", "object_path": "ghost/ghost.xml",
              "metadata_path": 3, "metadata_npz_path": "ghost/ghost.npz"},
    "abs": {"uid": "abs", "object_path": "/etc/passwd", "metadata_path": "red_block"}
  })");
  // Problems come in UID order (the index is read as a sorted map), whatever the file order.
  EXPECT_THAT(
      Strings(ValidateLibrary(lib)),
      ElementsAre(
          index + ": /abs/object_path: expected a path relative to the library folder, got "
                  "'/etc/passwd'",
          index +
              ": /abs/metadata_path: is a folder, expected a file: " + (lib / "red_block").string(),
          index + ": /abs/metadata_npz_path: missing required field (string or null)",
          index + ": /ghost/uid: uid 'phantom' differs from its key 'ghost' (lookups use the key)",
          index + ": /ghost/object_path: file not found: " + (lib / "ghost/ghost.xml").string(),
          index + ": /ghost/metadata_path: expected string, got number",
          index +
              ": /ghost/metadata_npz_path: file not found: " + (lib / "ghost/ghost.npz").string()));
}

TEST(ValidateTest, MalformedIndexNamesLine) {
  TempDir tmp;
  const fs::path lib = CopyExampleLibrary(tmp.path());
  WriteText(lib / "assets_index.json", "{\n\n  \"a\": oops\n}");
  std::vector<std::string> problems = Strings(ValidateLibrary(lib));
  ASSERT_FALSE(problems.empty());
  EXPECT_THAT(problems[0], HasSubstr((lib / "assets_index.json").string() + ": line 3"));
}

TEST(ValidateTest, MetadataFieldTypes) {
  TempDir tmp;
  const fs::path lib = CopyExampleLibrary(tmp.path());
  const fs::path meta = lib / "red_block/red_block_computed.json";
  const std::string m = meta.string();
  WriteText(meta, R"({
    "assetId": 1, "category": "block", "description": null, "description_long": "x",
    "description_short": {"one_word": "block", "two_words": 2},
    "synset": "block", "mass": -1, "boundingBox": {"x": 0.05, "y": "wide"},
    "primaryProperty": "CanPickup", "receptacle": "no", "isObjaverse": false,
    "split": "holdout", "license_info": [], "free_form": {"anything": [1, 2]}
  })");
  EXPECT_THAT(
      Strings(ValidateLibrary(lib)),
      ElementsAre(m + ": /assetId: expected string, got number",
                  m + ": /description: expected string, got null",
                  m + ": /synset: 'block' is not a WordNet synset name (word.pos.NN, e.g. "
                      "block.n.01)",
                  m + ": /description_short/two_words: expected string, got number",
                  m + ": /mass: expected a number >= 0, got -1",
                  m + ": /boundingBox/y: expected number, got string",
                  m + ": /boundingBox/z: missing required field",
                  m + ": /receptacle: expected boolean, got string",
                  m + ": /split: expected \"train\", \"val\", \"test\" or null, got \"holdout\"",
                  m + ": /license_info: expected object, got array"));
}

TEST(ValidateTest, GoodMetadataVariantsPass) {
  TempDir tmp;
  const fs::path lib = CopyExampleLibrary(tmp.path());
  WriteText(lib / "red_block/red_block_computed.json", R"({
    "synset": "st._john's_wort.n.01", "split": null, "mass": 0,
    "boundingBox": {"x": 1, "y": 2.5, "z": 0}, "receptacle": true, "license_info": {}
  })");
  EXPECT_THAT(Strings(ValidateLibrary(lib)), IsEmpty());
}

TEST(ValidateTest, MalformedMetadataJson) {
  TempDir tmp;
  const fs::path lib = CopyExampleLibrary(tmp.path());
  WriteText(lib / "red_block/red_block_computed.json", "{\n  \"a\": 1,\n}");
  std::vector<std::string> problems = Strings(ValidateLibrary(lib));
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_THAT(problems[0],
              HasSubstr((lib / "red_block/red_block_computed.json").string() + ": line 3"));
}

TEST(ValidateTest, NpzMetadataCollisions) {
  TempDir tmp;
  const fs::path lib = CopyExampleLibrary(tmp.path());
  WriteText(lib / "assets_index.json", R"({"red_block": {"uid": "red_block",
      "object_path": "red_block/red_block.xml", "metadata_path": "red_block/red_block.json",
      "metadata_npz_path": "red_block/red_block.npz"}})");
  const fs::path npz = lib / "red_block/red_block.npz";
  const double v[2] = {1, 2};
  auto arr = [&] { return NpyArray::FromDoubles({2}, v); };
  WriteNpz(npz, {{"clip_text_features", arr()},          // new: fine
                 {"description_short/clip", arr()},      // new inside an object: fine
                 {"description_short/one_word", arr()},  // collides with JSON
                 {"category/sub", arr()},                // crosses a string
                 {"clip_text_features/x", arr()},        // crosses an npz array
                 {"new/a", arr()},                       // creates "new"
                 {"new/b", arr()},                       // shares "new": fine
                 {"new/a/c", arr()}});                   // crosses the npz's own array
  const std::string f = npz.string();
  EXPECT_THAT(
      Strings(ValidateLibrary(lib)),
      ElementsAre(f + ": description_short/one_word.npy: Key description_short/one_word from npz "
                      "metadata already exists in metadata for uid=red_block",
                  f + ": category/sub.npy: npz key category/sub crosses /category, which is not an "
                      "object",
                  f + ": clip_text_features/x.npy: npz key clip_text_features/x crosses "
                      "/clip_text_features, which is not an object",
                  f + ": new/a/c.npy: npz key new/a/c crosses /new/a, which is not an object"));
}

TEST(ValidateTest, UnreadableNpzMetadata) {
  TempDir tmp;
  const fs::path lib = CopyExampleLibrary(tmp.path());
  WriteText(lib / "assets_index.json", R"({"red_block": {"uid": "red_block",
      "object_path": "red_block/red_block.xml", "metadata_path": "red_block/red_block.json",
      "metadata_npz_path": "red_block/red_block.npz"}})");
  WriteText(lib / "red_block/red_block.npz", "this is not a zip file");
  std::vector<std::string> problems = Strings(ValidateLibrary(lib));
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_THAT(problems[0], HasSubstr((lib / "red_block/red_block.npz").string()));
}

class GraspValidateTest : public ::testing::Test {
 protected:
  void SetUp() override { lib_ = CopyExampleLibrary(tmp_.path()); }
  fs::path grasp() const { return lib_ / "red_block/droid/grasps.npz"; }
  std::vector<std::string> Run() { return Strings(ValidateLibrary(lib_)); }
  std::string Prefix() const { return grasp().string() + ": transforms.npy: "; }

  TempDir tmp_;
  fs::path lib_;
};

TEST_F(GraspValidateTest, RotatedHalfPrecisionPasses) {
  // A rotation by 0.3 rad about z, then about x, stored as float16 like the built-in files.
  const double c = std::cos(0.3), s = std::sin(0.3);
  std::vector<double> rz = {c, -s, 0, 0.1, s, c, 0, 0.2, 0, 0, 1, 0.3, 0, 0, 0, 1};
  std::vector<double> rx = {1, 0, 0, 0, 0, c, -s, 0, 0, s, c, 0, 0, 0, 0, 1};
  std::vector<double> both = rz;
  both.insert(both.end(), rx.begin(), rx.end());
  WriteGrasps(grasp(), both, {2, 4, 4}, DType::kF2);
  EXPECT_THAT(Run(), IsEmpty());
}

TEST_F(GraspValidateTest, BadShapes) {
  WriteGrasps(grasp(), Identity(), {4, 4});
  EXPECT_THAT(Run(), ElementsAre(Prefix() + "expected shape (N, 4, 4), got (4, 4)"));
  WriteGrasps(grasp(), {}, {0, 4, 4});
  EXPECT_THAT(Run(), ElementsAre(Prefix() + "no grasps (shape (0, 4, 4))"));
}

TEST_F(GraspValidateTest, MissingMember) {
  WriteNpz(grasp(), {{"poses", NpyArray::FromDoubles({1, 4, 4}, Identity())}});
  EXPECT_THAT(Run(), ElementsAre(Prefix() + "missing member (grasp files hold their poses in "
                                            "transforms.npy)"));
}

TEST_F(GraspValidateTest, BadPoses) {
  std::vector<double> v;
  auto add = [&](std::vector<double> m) { v.insert(v.end(), m.begin(), m.end()); };
  add(Identity());                                          // 0: good
  add({2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});    // 1: scaled
  add({-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});   // 2: reflection
  add({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0.5, 1});  // 3: bad last row
  add({1, 0, 0, std::numeric_limits<double>::quiet_NaN(), 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});
  add({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1.5});  // 5: bad last row
  WriteGrasps(grasp(), v, {6, 4, 4});
  EXPECT_THAT(
      Run(),
      ElementsAre(
          Prefix() + "1 of 6 grasps have non-finite values (first: grasp 4)",
          Prefix() + "2 of 6 grasps have a last row other than 0 0 0 1 (first: grasp 3, worst "
                     "deviation = 0.5)",
          Prefix() + "1 of 6 grasps have a rotation that is not orthonormal (first: grasp 1, "
                     "worst |R^T R - I| = 3)",
          Prefix() + "1 of 6 grasps have a rotation with det <= 0 (not right-handed) (first: "
                     "grasp 2)"));
}

TEST_F(GraspValidateTest, CorruptGraspFile) {
  WriteText(grasp(), "PK\x03\x04 truncated");
  std::vector<std::string> problems = Run();
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_THAT(problems[0], HasSubstr(grasp().string()));
}

TEST_F(GraspValidateTest, IndexProblems) {
  const std::string index = (lib_ / "grasps_index.json").string();
  WriteText(lib_ / "grasps_index.json", R"({
    "grasp_paths": {"droid": {"red_block": "red_block/droid/grasps.npz",
                              "blue_block": "blue_block/droid/grasps.npz"},
                    "franka": 4},
    "articulated_grasp_paths": {"droid": {"red_block": {"hinge": 1}}}
  })");
  EXPECT_THAT(
      Run(),
      ElementsAre(index + ": /grasp_paths/droid/blue_block: uid 'blue_block' is not in " +
                      (lib_ / "assets_index.json").string(),
                  index + ": /grasp_paths/droid/blue_block: file not found: " +
                      (lib_ / "blue_block/droid/grasps.npz").string(),
                  index + ": /grasp_paths/franka: expected object, got number",
                  index + ": /articulated_grasp_paths/droid/red_block/hinge: expected string, got "
                          "number"));
}

TEST_F(GraspValidateTest, GraspOnlyLibrarySkipsUidCheck) {
  fs::remove(lib_ / "assets_index.json");
  WriteText(lib_ / "grasps_index.json",
            R"({"grasp_paths": {"droid": {"other": "red_block/droid/grasps.npz"}}})");
  EXPECT_THAT(Run(), IsEmpty());
}

}  // namespace
}  // namespace mlspaces
