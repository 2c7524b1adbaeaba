#include "mlspaces/library/registry.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "library/grasp_fixture.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/npz.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ErrorOf;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteGrasps;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

/// An asset library: <uid>/<uid>.xml and <uid>/<uid>.json for each UID, and its index.
void WriteAssetLibrary(const fs::path& dir, const std::vector<std::string>& uids) {
  Json index = Json::object();
  for (const std::string& uid : uids) {
    WriteFileAtomic(dir / uid / (uid + ".xml"), "<mujoco model=\"" + uid + "\"/>");
    WriteFileAtomic(dir / uid / (uid + ".json"),
                    R"({"assetId": ")" + uid + R"(", "category": "thing"})");
    index[uid] = {{"uid", uid},
                  {"object_path", uid + "/" + uid + ".xml"},
                  {"metadata_path", uid + "/" + uid + ".json"},
                  {"metadata_npz_path", nullptr}};
  }
  WriteFileAtomic(dir / "assets_index.json", DumpJsonIndent4(index));
}

/// A grasp library: robot -> uid -> number of grasps (0: listed in the index, no file),
/// and robot -> uid -> joint -> number of grasps.
struct GraspSpec {
  std::map<std::string, std::map<std::string, size_t>> pickup;
  std::map<std::string, std::map<std::string, std::map<std::string, size_t>>> joints;
};

void WriteGraspLibrary(const fs::path& dir, const GraspSpec& spec, double file_tag = 0) {
  Json index = {{"articulated_grasp_paths", Json::object()}, {"grasp_paths", Json::object()}};
  for (const auto& [robot, uids] : spec.pickup) {
    for (const auto& [uid, n] : uids) {
      const std::string rel = uid + "/" + robot + "/grasps.npz";
      index["grasp_paths"][robot][uid] = rel;
      if (n > 0) WriteGrasps(dir / rel, n, file_tag);
    }
  }
  for (const auto& [robot, uids] : spec.joints) {
    for (const auto& [uid, joints] : uids) {
      for (const auto& [joint, n] : joints) {
        const std::string rel = uid + "/" + robot + "/joint_grasps_" + joint + ".npz";
        index["articulated_grasp_paths"][robot][uid][joint] = rel;
        if (n > 0) WriteGrasps(dir / rel, n, file_tag);
      }
    }
  }
  WriteFileAtomic(dir / "grasps_index.json", DumpJsonIndent4(index));
}

// ---- registration --------------------------------------------------------------------------

TEST(RegistryTest, AssetRegistrationErrorsMatchTheOriginal) {
  TempDir tmp;
  WriteAssetLibrary(tmp.path() / "lib", {"a"});
  Registry registry;
  EXPECT_THROW(registry.RegisterAssetLibrary("x/y", tmp.path() / "lib"), UsageError);
  EXPECT_EQ(ErrorOf([&] { registry.RegisterAssetLibrary("x/y", tmp.path() / "lib"); }),
            "User library x/y must not contain slashes");
  EXPECT_THROW(registry.RegisterAssetLibrary("", tmp.path() / "lib"), UsageError);
  for (std::string builtin : {"thor", "objaverse", "objathor_metadata"}) {
    EXPECT_EQ(ErrorOf([&] { registry.RegisterAssetLibrary(builtin, tmp.path() / "lib"); }),
              "User library " + builtin + " name conflicts with a built-in object source");
  }
  EXPECT_EQ(ErrorOf([&] { registry.RegisterAssetLibrary("empty", tmp.path()); }),
            (tmp.path() / "assets_index.json").string() +
                ": User library empty has no assets_index.json (no such file)");
  registry.RegisterAssetLibrary("lib", tmp.path() / "lib");
  EXPECT_EQ(ErrorOf([&] { registry.RegisterAssetLibrary("lib", tmp.path() / "lib"); }),
            "User library lib already registered");
  EXPECT_THAT(registry.asset_libraries(), ElementsAre("lib"));
}

TEST(RegistryTest, BadAssetIndexLeavesRegistryUnchanged) {
  TempDir tmp;
  WriteAssetLibrary(tmp.path() / "good", {"a"});
  fs::create_directories(tmp.path() / "bad");
  WriteFileAtomic(tmp.path() / "bad" / "assets_index.json", R"({"b": {"uid": "b"}})");
  Registry registry;
  registry.RegisterAssetLibrary("good", tmp.path() / "good");
  try {
    registry.RegisterAssetLibrary("bad", tmp.path() / "bad");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.path(), HasSubstr("assets_index.json"));
  }
  EXPECT_THAT(registry.asset_libraries(), ElementsAre("good"));
  EXPECT_EQ(registry.num_uids(), 1u);
  EXPECT_FALSE(registry.Locate("b").has_value());
  // The name is still free.
  WriteAssetLibrary(tmp.path() / "bad", {"b"});
  registry.RegisterAssetLibrary("bad", tmp.path() / "bad");
  EXPECT_EQ(registry.Locate("b")->library, "bad");
}

TEST(RegistryTest, PathsAreMadeAbsoluteAtRegistration) {
  TempDir tmp;
  WriteAssetLibrary(tmp.path() / "lib", {"a"});
  WriteGraspLibrary(tmp.path() / "lib", {{{"droid", {{"a", 2}}}}, {}});
  const fs::path old_cwd = fs::current_path();
  fs::current_path(tmp.path());
  Registry registry;
  registry.RegisterAssetLibrary("lib", "./lib/");
  registry.RegisterGraspLibrary("g", "lib", "lib");
  fs::current_path(old_cwd);  // lookups no longer depend on the cwd
  const AssetLocation loc = registry.LocateOrThrow("a");
  EXPECT_EQ(loc.mjcf_path, tmp.path() / "lib" / "a" / "a.xml");
  EXPECT_TRUE(loc.mjcf_path.is_absolute());
  EXPECT_EQ(registry.FindGraspLibrary("g/droid")->dir, tmp.path() / "lib");
  EXPECT_EQ(registry.GraspPath({"a"}), tmp.path() / "lib" / "a" / "droid" / "grasps.npz");
}

TEST(RegistryTest, GraspRegistrationErrorsMatchTheOriginal) {
  TempDir tmp;
  WriteAssetLibrary(tmp.path() / "lib", {"a"});
  Registry registry;
  registry.RegisterAssetLibrary("lib", tmp.path() / "lib");
  EXPECT_EQ(ErrorOf([&] { registry.RegisterGraspLibrary("g", tmp.path() / "lib", "lib"); }),
            (tmp.path() / "lib").string() +
                "/grasps_index.json: User grasp library g has no grasps_index.json (no such file)");
  WriteGraspLibrary(tmp.path() / "lib", {{{"droid", {{"a", 1}}}}, {}});
  EXPECT_EQ(ErrorOf([&] { registry.RegisterGraspLibrary("g", tmp.path() / "lib", "nope"); }),
            "Object library nope not found");
  EXPECT_THROW(registry.RegisterGraspLibrary("g/h", tmp.path() / "lib", "lib"), UsageError);
  EXPECT_THROW(registry.RegisterGraspLibrary("", tmp.path() / "lib", "lib"), UsageError);
  EXPECT_THAT(registry.RegisterGraspLibrary("g", tmp.path() / "lib", "lib"),
              ElementsAre("g/droid"));
  EXPECT_EQ(ErrorOf([&] { registry.RegisterGraspLibrary("g", tmp.path() / "lib", "lib"); }),
            "User grasp library g/droid already registered");
  // Built-in object sources may take user grasps even without an assets dir.
  EXPECT_THAT(registry.RegisterGraspLibrary("t", tmp.path() / "lib", "thor"),
              ElementsAre("t/droid"));
  EXPECT_THAT(registry.grasp_libraries_of("thor"), ElementsAre("t/droid"));
}

TEST(RegistryTest, FailedGraspRegistrationLeavesRegistryUnchanged) {
  TempDir tmp;
  WriteAssetLibrary(tmp.path() / "assets", {"a"});
  WriteGraspLibrary(tmp.path() / "one", {{{"b_robot", {{"a", 1}}}}, {}});
  WriteGraspLibrary(
      tmp.path() / "two",
      {{{"a_robot", {{"a", 1}}}, {"b_robot", {{"a", 1}}}, {"c_robot", {{"a", 1}}}}, {}});
  Registry registry;
  registry.RegisterAssetLibrary("assets", tmp.path() / "assets");
  registry.RegisterGraspLibrary("g", tmp.path() / "one", "assets");
  // "g/a_robot" would be fine, "g/b_robot" conflicts: nothing of the second call remains.
  EXPECT_EQ(ErrorOf([&] { registry.RegisterGraspLibrary("g", tmp.path() / "two", "assets"); }),
            "User grasp library g/b_robot already registered");
  EXPECT_THAT(registry.grasp_libraries_of("assets"), ElementsAre("g/b_robot"));
  EXPECT_EQ(registry.FindGraspLibrary("g/a_robot"), nullptr);
  EXPECT_EQ(registry.FindGraspLibrary("g/c_robot"), nullptr);
  EXPECT_EQ(registry.FindGraspLibrary("g/b_robot")->dir, tmp.path() / "one");
  // A malformed index changes nothing either.
  fs::create_directories(tmp.path() / "bad");
  WriteFileAtomic(tmp.path() / "bad" / "grasps_index.json", R"({"grasp_paths": [1]})");
  EXPECT_THROW(registry.RegisterGraspLibrary("h", tmp.path() / "bad", "assets"), Error);
  EXPECT_THAT(registry.grasp_libraries_of("assets"), ElementsAre("g/b_robot"));
}

TEST(RegistryTest, GraspPriorityIsNewestFirstRobotsSorted) {
  TempDir tmp;
  WriteAssetLibrary(tmp.path() / "assets", {"a"});
  WriteGraspLibrary(tmp.path() / "g1", {{{"zeta", {{"a", 1}}}, {"alpha", {{"a", 1}}}}, {}});
  WriteGraspLibrary(tmp.path() / "g2", {{}, {{"mid", {{"a", {{"j", 1}}}}}}});
  WriteGraspLibrary(tmp.path() / "empty", {});
  Registry registry;
  registry.RegisterAssetLibrary("assets", tmp.path() / "assets");
  EXPECT_THAT(registry.RegisterGraspLibrary("g1", tmp.path() / "g1", "assets"),
              ElementsAre("g1/alpha", "g1/zeta"));
  // Robots come from joint grasps too.
  EXPECT_THAT(registry.RegisterGraspLibrary("g2", tmp.path() / "g2", "assets"),
              ElementsAre("g2/mid"));
  EXPECT_THAT(registry.RegisterGraspLibrary("e", tmp.path() / "empty", "assets"), IsEmpty());
  EXPECT_THAT(registry.grasp_libraries_of("assets"), ElementsAre("g2/mid", "g1/alpha", "g1/zeta"));
  const GraspLibraryInfo* info = registry.FindGraspLibrary("g1/zeta");
  ASSERT_NE(info, nullptr);
  EXPECT_EQ(info->robot, "zeta");
  EXPECT_EQ(info->asset_library, "assets");
  EXPECT_FALSE(info->builtin);
  // The first robot in sorted order wins when no filter is given.
  EXPECT_EQ(registry.FindGraspFile({"a"})->library, "g1/alpha");
}

// ---- locate and duplicates -------------------------------------------------------------------

TEST(RegistryTest, LocatesInRegistrationOrderAndReportsDuplicates) {
  TempDir tmp;
  WriteAssetLibrary(tmp.path() / "A", {"x", "y"});
  WriteAssetLibrary(tmp.path() / "B", {"y", "z"});
  WriteAssetLibrary(tmp.path() / "C", {"y", "z", "w"});
  Registry registry;
  registry.RegisterAssetLibrary("A", tmp.path() / "A");
  registry.RegisterAssetLibrary("B", tmp.path() / "B");
  registry.RegisterAssetLibrary("C", tmp.path() / "C");
  EXPECT_EQ(registry.num_uids(), 4u);

  const AssetLocation y = registry.LocateOrThrow("y");
  EXPECT_EQ(y.library, "A");
  EXPECT_EQ(y.mjcf_path, tmp.path() / "A" / "y" / "y.xml");
  EXPECT_THAT(y.shadowed, ElementsAre("B", "C"));
  ASSERT_NE(y.entry, nullptr);
  EXPECT_EQ(y.entry->metadata_path, "y/y.json");
  const AssetLocation w = registry.LocateOrThrow("w");
  EXPECT_EQ(w.library, "C");
  EXPECT_THAT(w.shadowed, IsEmpty());

  const std::vector<DuplicateUid>& dups = registry.duplicates();
  ASSERT_EQ(dups.size(), 2u);
  EXPECT_EQ(dups[0].uid, "y");
  EXPECT_THAT(dups[0].libraries, ElementsAre("A", "B", "C"));
  EXPECT_EQ(dups[0].paths[2], tmp.path() / "C" / "y" / "y.xml");
  EXPECT_EQ(dups[1].uid, "z");
  EXPECT_THAT(dups[1].libraries, ElementsAre("B", "C"));

  EXPECT_FALSE(registry.Locate("nope").has_value());
  try {
    registry.LocateOrThrow("nope");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "nope not found in asset libraries ['A', 'B', 'C']");
    EXPECT_EQ(e.uid(), "nope");
  }
}

TEST(RegistryTest, BuiltinLibrariesFromTheAssetsDir) {
  TempDir tmp;
  const fs::path assets = tmp.path() / "assets";
  // Two thor files with one stem: the lexicographically-first path wins, both reported.
  WriteFileAtomic(assets / "objects/thor/b/Bowl_1.xml", "<mujoco/>");
  WriteFileAtomic(assets / "objects/thor/a/Bowl_1.xml", "<mujoco/>");
  WriteFileAtomic(assets / "objects/thor/a/Cup_1.xml", "<mujoco/>");
  WriteFileAtomic(assets / "objects/thor/a/Cup_1.obj", "");
  WriteFileAtomic(assets / "objects/objaverse/0/abc123.xml", "<mujoco/>");
  WriteFileAtomic(assets / "objects/objaverse/1/Cup_1.xml", "<mujoco/>");
  WriteGrasps(assets / "grasps/droid/Bowl_1/Bowl_1_grasps_filtered.npz", 3, 1);
  WriteGrasps(assets / "grasps/droid/Bowl_1/lid_hinge_grasps_filtered.npz", 2, 2);
  WriteGrasps(assets / "grasps/droid_objaverse/abc123/abc123_grasps_filtered.npz", 4, 3);
  WriteGrasps(assets / "grasps/droid_objaverse/abc123/door_grasps_filtered.npz", 5, 4);
  WriteAssetLibrary(tmp.path() / "user", {"Bowl_1", "mine"});
  WriteGraspLibrary(tmp.path() / "user", {{{"franka", {{"Bowl_1", 6}}}}, {}}, 5);

  Registry registry(Registry::Options{assets});
  registry.RegisterAssetLibrary("user", tmp.path() / "user");
  EXPECT_THAT(registry.asset_libraries(),
              ElementsAre("thor", "objaverse", "objathor_metadata", "user"));

  const AssetLocation bowl = registry.LocateOrThrow("Bowl_1");
  EXPECT_EQ(bowl.library, "thor");
  EXPECT_EQ(bowl.mjcf_path, assets / "objects/thor/a/Bowl_1.xml");
  EXPECT_EQ(bowl.entry, nullptr);
  EXPECT_THAT(bowl.shadowed, ElementsAre("user"));
  const AssetLocation cup = registry.LocateOrThrow("Cup_1");
  EXPECT_EQ(cup.library, "thor");
  EXPECT_THAT(cup.shadowed, ElementsAre("objaverse"));
  EXPECT_EQ(registry.LocateOrThrow("abc123").library, "objaverse");
  const AssetLocation mine = registry.LocateOrThrow("mine");
  EXPECT_EQ(mine.library, "user");
  EXPECT_NE(mine.entry, nullptr);

  std::vector<std::string> dup_summary;
  for (const DuplicateUid& d : registry.duplicates()) {
    std::string s = d.uid + ":";
    for (const std::string& l : d.libraries) s += " " + l;
    dup_summary.push_back(s);
  }
  EXPECT_THAT(dup_summary, ::testing::UnorderedElementsAre("Bowl_1: thor thor", "Bowl_1: thor user",
                                                           "Cup_1: thor objaverse"));

  // Built-in grasp libraries, after user grasps registered against thor.
  EXPECT_THAT(registry.grasp_libraries_of("thor"), ElementsAre("droid"));
  EXPECT_THAT(registry.grasp_libraries_of("objaverse"), ElementsAre("droid_objaverse"));
  EXPECT_TRUE(registry.FindGraspLibrary("droid")->builtin);
  EXPECT_EQ(registry.GraspPath({"Bowl_1"}),
            assets / "grasps/droid/Bowl_1/Bowl_1_grasps_filtered.npz");
  // The user grasps for Bowl_1 serve "user", which Bowl_1 does not resolve to.
  registry.RegisterGraspLibrary("ug", tmp.path() / "user", "user");
  EXPECT_THAT(registry.GraspLibrariesFor("Bowl_1"), ElementsAre("droid"));
  registry.RegisterGraspLibrary("tg", tmp.path() / "user", "thor");
  EXPECT_THAT(registry.GraspLibrariesFor("Bowl_1"), ElementsAre("tg/franka", "droid"));
  EXPECT_EQ(registry.LoadGrasps({"Bowl_1"}).poses[0](1, 3), 5);  // user grasps first
  const std::vector<std::string> droid = {"droid"};
  EXPECT_EQ(registry.LoadGrasps({"Bowl_1", "", droid}).poses.size(), 3u);

  // Joint grasps use the library's own folder (the original hard-codes droid).
  EXPECT_EQ(registry.GraspPath({"Bowl_1", "lid_hinge"}),
            assets / "grasps/droid/Bowl_1/lid_hinge_grasps_filtered.npz");
  EXPECT_EQ(registry.GraspPath({"abc123", "door"}),
            assets / "grasps/droid_objaverse/abc123/door_grasps_filtered.npz");
  EXPECT_EQ(registry.LoadGrasps({"abc123", "door"}).poses.size(), 5u);
  EXPECT_FALSE(registry.GraspPath({"abc123", "lid_hinge"}).has_value());
}

TEST(RegistryTest, WithoutAssetsDirBuiltinsAnswerNothing) {
  TempDir tmp;
  WriteAssetLibrary(tmp.path() / "user", {"a"});
  Registry registry;
  registry.RegisterAssetLibrary("user", tmp.path() / "user");
  EXPECT_THAT(registry.asset_libraries(), ElementsAre("user"));
  EXPECT_THAT(registry.grasp_libraries_of("thor"), IsEmpty());
  EXPECT_EQ(registry.FindGraspLibrary("droid"), nullptr);
  EXPECT_FALSE(registry.Locate("Bowl_1").has_value());
}

// ---- grasp lookups --------------------------------------------------------------------------

class GraspLookupTest : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteAssetLibrary(tmp_.path() / "assets", {"a", "b"});
    // g1: robots alpha (file for a: 5 grasps) and beta (listed for a, but no file).
    WriteGraspLibrary(tmp_.path() / "g1",
                      {{{"alpha", {{"a", 5}}}, {"beta", {{"a", 0}, {"b", 2}}}},
                       {{"alpha", {{"a", {{"hinge", 4}}}}}}},
                      1);
    // g2 (newer): robot gamma with a file for a and joint grasps.
    WriteGraspLibrary(tmp_.path() / "g2",
                      {{{"gamma", {{"a", 7}}}}, {{"gamma", {{"a", {{"hinge", 3}}}}}}}, 2);
    registry_.RegisterAssetLibrary("assets", tmp_.path() / "assets");
    registry_.RegisterGraspLibrary("g1", tmp_.path() / "g1", "assets");
    registry_.RegisterGraspLibrary("g2", tmp_.path() / "g2", "assets");
  }
  TempDir tmp_;
  Registry registry_;
};

TEST_F(GraspLookupTest, FilterKeepsCallerOrderAndDropsUnavailable) {
  EXPECT_THAT(registry_.GraspLibrariesFor("a"), ElementsAre("g2/gamma", "g1/alpha", "g1/beta"));
  const std::vector<std::string> filter = {"g1/beta", "nope/x", "g2/gamma", "g1"};
  EXPECT_THAT(registry_.GraspLibrariesFor("a", filter), ElementsAre("g1/beta", "g2/gamma"));
  const std::vector<std::string> root_only = {"g1"};  // names must be "<root>/<robot>"
  EXPECT_THAT(registry_.GraspLibrariesFor("a", root_only), IsEmpty());
  EXPECT_FALSE(registry_.GraspPath({"a", "", root_only}).has_value());
  EXPECT_THAT(registry_.GraspLibrariesFor("unknown"), IsEmpty());
}

TEST_F(GraspLookupTest, FirstExistingCandidateWins) {
  EXPECT_EQ(registry_.GraspPath({"a"}), tmp_.path() / "g2/a/gamma/grasps.npz");
  const std::vector<std::string> beta_first = {"g1/beta", "g1/alpha"};
  // g1/beta lists a but has no file: the next library answers.
  auto found = registry_.FindGraspFile({"a", "", beta_first});
  ASSERT_TRUE(found.has_value());
  EXPECT_EQ(found->library, "g1/alpha");
  EXPECT_EQ(found->path, tmp_.path() / "g1/a/alpha/grasps.npz");
  const std::vector<std::string> beta = {"g1/beta"};
  EXPECT_FALSE(registry_.GraspPath({"a", "", beta}).has_value());
  EXPECT_EQ(registry_.GraspPath({"b"}), tmp_.path() / "g1/b/beta/grasps.npz");
  EXPECT_FALSE(registry_.GraspPath({"nope"}).has_value());
}

TEST_F(GraspLookupTest, HasValidComparesRowCount) {
  const std::vector<std::string> alpha = {"g1/alpha"};
  EXPECT_TRUE(registry_.HasValidGrasps({"a", "", alpha}, 5));
  EXPECT_FALSE(registry_.HasValidGrasps({"a", "", alpha}, 6));
  EXPECT_TRUE(registry_.HasValidGrasps({"a"}));
  EXPECT_TRUE(registry_.HasValidGrasps({"a"}, 7));
  EXPECT_FALSE(registry_.HasValidGrasps({"a"}, 8));
  const std::vector<std::string> beta = {"g1/beta"};
  EXPECT_FALSE(registry_.HasValidGrasps({"a", "", beta}, 1));  // no file: false, no error
  EXPECT_FALSE(registry_.HasValidGrasps({"nope"}));
  // A grasp file without transforms.npy raises, as the original does.
  WriteNpz(tmp_.path() / "g1/a/alpha/grasps.npz",
           {{"other", NpyArray::FromDoubles({1}, std::vector<double>{1.0})}});
  EXPECT_THROW(registry_.HasValidGrasps({"a", "", alpha}, 1), Error);
}

TEST_F(GraspLookupTest, JointTrio) {
  EXPECT_EQ(registry_.GraspPath({"a", "hinge"}), tmp_.path() / "g2/a/gamma/joint_grasps_hinge.npz");
  const std::vector<std::string> alpha = {"g1/alpha"};
  EXPECT_EQ(registry_.GraspPath({"a", "hinge", alpha}),
            tmp_.path() / "g1/a/alpha/joint_grasps_hinge.npz");
  EXPECT_TRUE(registry_.HasValidGrasps({"a", "hinge"}, 3));
  EXPECT_FALSE(registry_.HasValidGrasps({"a", "hinge"}, 4));
  EXPECT_TRUE(registry_.HasValidGrasps({"a", "hinge", alpha}, 4));
  EXPECT_FALSE(registry_.HasValidGrasps({"a", "door"}));
  const GraspSet set = registry_.LoadGrasps({"a", "hinge", alpha});
  EXPECT_EQ(set.poses.size(), 4u);
  EXPECT_EQ(set.poses[3](0, 3), 3);
  EXPECT_EQ(set.poses[3](1, 3), 1);  // file tag of g1
  EXPECT_EQ(ErrorOf([&] {
              registry_.LoadGrasps({"a", "door"});
            }),
            "No joint grasp file found for a/door");
}

TEST_F(GraspLookupTest, SingleLibraryBypassOnlyForUnknownUids) {
  // An unknown UID (e.g. iTHOR articulated objects) with exactly one library: asked directly.
  WriteGraspLibrary(tmp_.path() / "g3", {{}, {{"delta", {{"ghost", {{"door", 2}}}}}}});
  registry_.RegisterGraspLibrary("g3", tmp_.path() / "g3", "assets");
  const std::vector<std::string> one = {"g3/delta"};
  EXPECT_EQ(registry_.GraspPath({"ghost", "door", one}),
            tmp_.path() / "g3/ghost/delta/joint_grasps_door.npz");
  EXPECT_FALSE(registry_.GraspPath({"ghost", "door"}).has_value());
  const std::vector<std::string> two = {"g3/delta", "g1/alpha"};
  EXPECT_FALSE(registry_.GraspPath({"ghost", "door", two}).has_value());
  // A located UID keeps the availability filter (the original skipped it).
  TempDir other;
  WriteAssetLibrary(other.path() / "other", {"o"});
  WriteGraspLibrary(other.path() / "og", {{}, {{"r", {{"a", {{"hinge", 1}}}}}}});
  registry_.RegisterAssetLibrary("other", other.path() / "other");
  registry_.RegisterGraspLibrary("og", other.path() / "og", "other");
  const std::vector<std::string> og = {"og/r"};
  EXPECT_FALSE(registry_.GraspPath({"a", "hinge", og}).has_value());
}

TEST_F(GraspLookupTest, LoadAllOrSubsample) {
  const std::vector<std::string> alpha = {"g1/alpha"};
  const GraspSet all = registry_.LoadGrasps({"a", "", alpha}, 5);
  ASSERT_EQ(all.poses.size(), 5u);
  EXPECT_THAT(all.indices, ElementsAre(0, 1, 2, 3, 4));
  EXPECT_EQ(all.source, tmp_.path() / "g1/a/alpha/grasps.npz");
  EXPECT_EQ(all.stored_dtype, DType::kF8);
  for (size_t i = 0; i < 5; ++i) EXPECT_EQ(all.poses[i](0, 3), static_cast<double>(i));

  const GraspSet some = registry_.LoadGrasps({"a", "", alpha}, 3, 42);
  ASSERT_EQ(some.poses.size(), 3u);
  EXPECT_EQ(some.indices, SubsampleIndices(5, 3, 42));
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(some.poses[i](0, 3), static_cast<double>(some.indices[i]));
  }
  EXPECT_EQ(registry_.LoadGrasps({"a", "", alpha}, 3, 42).indices, some.indices);
  EXPECT_EQ(ErrorOf([&] { registry_.LoadGrasps({"nope"}); }), "No grasp file found for nope");
}

// ---- annotations ---------------------------------------------------------------------------

TEST(RegistryTest, AnnotationsAreCachedAndShared) {
  TempDir tmp;
  WriteAssetLibrary(tmp.path() / "A", {"x"});
  WriteAssetLibrary(tmp.path() / "B", {"x", "y"});
  WriteFileAtomic(tmp.path() / "B/x/x.json", R"({"category": "from B"})");
  Registry registry;
  registry.RegisterAssetLibrary("A", tmp.path() / "A");
  registry.RegisterAssetLibrary("B", tmp.path() / "B");
  std::shared_ptr<const Annotation> x = registry.GetAnnotation("x");
  ASSERT_NE(x, nullptr);
  EXPECT_EQ(x->library, "A");  // first library wins, as in the original's union view
  EXPECT_EQ(x->json["category"], "thing");
  EXPECT_EQ(registry.GetAnnotation("x").get(), x.get());
  // Once cached, the file is not read again.
  WriteFileAtomic(tmp.path() / "A/x/x.json", R"({"category": "changed"})");
  EXPECT_EQ(registry.GetAnnotation("x")->json["category"], "thing");
  EXPECT_EQ(registry.GetAnnotation("nope"), nullptr);
  WriteFileAtomic(tmp.path() / "B/y/y.json", "{oops");
  try {
    registry.GetAnnotation("y");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), (tmp.path() / "B/y/y.json").string());
  }
}

TEST(RegistryTest, BundledExample) {
  const fs::path example = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "asset_library";
  ASSERT_TRUE(fs::exists(example / "assets_index.json")) << example;
  // Copy it, so a missing grasps.npz (built by the example's tool) can be supplied.
  TempDir tmp;
  fs::copy(example, tmp.path() / "lib", fs::copy_options::recursive);
  const fs::path npz = tmp.path() / "lib/red_block/droid/grasps.npz";
  if (!fs::exists(npz)) {
    const std::vector<double> pose = {1, 0, 0, 0, 0, -1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1};
    WriteNpz(npz, {{"transforms", NpyArray::FromDoubles({1, 4, 4}, pose)}});
  }
  Registry registry;
  registry.RegisterAssetLibrary("custom_assets", tmp.path() / "lib");
  EXPECT_THAT(registry.RegisterGraspLibrary("custom_grasps", tmp.path() / "lib", "custom_assets"),
              ElementsAre("custom_grasps/droid"));
  EXPECT_EQ(registry.LocateOrThrow("red_block").mjcf_path,
            tmp.path() / "lib/red_block/red_block.xml");
  auto annotation = registry.GetAnnotation("red_block");
  ASSERT_NE(annotation, nullptr);
  EXPECT_EQ(annotation->json["category"], "block");
  EXPECT_EQ(annotation->json["mass"].get<double>(), 0.12500000000000003);
  EXPECT_TRUE(registry.HasValidGrasps({"red_block"}, 1));
  EXPECT_FALSE(registry.HasValidGrasps({"red_block"}, 2));
  const GraspSet grasps = registry.LoadGrasps({"red_block"});
  ASSERT_EQ(grasps.poses.size(), 1u);
  EXPECT_EQ(grasps.poses[0](1, 1), -1);
  EXPECT_EQ(grasps.poses[0](2, 2), -1);
  EXPECT_EQ(grasps.poses[0](0, 0), 1);
}

}  // namespace
}  // namespace mlspaces
