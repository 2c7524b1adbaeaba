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

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/core/rng.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ErrorOf;
using ::mlspaces::testing::TempDir;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

/// Grasp k of a fixture file: identity rotation, translation (k, file_tag, 0).
Mat4 FixturePose(size_t k, double file_tag = 0) {
  Mat4 m;
  m(0, 3) = static_cast<double>(k);
  m(1, 3) = file_tag;
  return m;
}

void WriteGrasps(const fs::path& file, size_t n, double file_tag = 0,
                 DType dtype = DType::kF8, bool compress = false) {
  std::vector<double> values;
  for (size_t k = 0; k < n; ++k) {
    Mat4 m = FixturePose(k, file_tag);
    values.insert(values.end(), m.m.begin(), m.m.end());
  }
  fs::create_directories(file.parent_path());
  NpzWriteOptions options;
  options.compress = compress;
  WriteNpz(file, {{"transforms", NpyArray::FromDoubles(dtype, {n, 4, 4}, values)}}, options);
}

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
            "User library empty path " + tmp.path().string() +
                " does not contain an assets_index.json file");
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
  EXPECT_EQ(registry.PickupGraspPath("a"), tmp.path() / "lib" / "a" / "droid" / "grasps.npz");
}

TEST(RegistryTest, GraspRegistrationErrorsMatchTheOriginal) {
  TempDir tmp;
  WriteAssetLibrary(tmp.path() / "lib", {"a"});
  Registry registry;
  registry.RegisterAssetLibrary("lib", tmp.path() / "lib");
  EXPECT_EQ(ErrorOf([&] { registry.RegisterGraspLibrary("g", tmp.path() / "lib", "lib"); }),
            (tmp.path() / "lib").string() + "/grasps_index.json does not exist");
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
  WriteGraspLibrary(tmp.path() / "two",
                    {{{"a_robot", {{"a", 1}}}, {"b_robot", {{"a", 1}}}, {"c_robot", {{"a", 1}}}},
                     {}});
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
  EXPECT_THAT(registry.grasp_libraries_of("assets"),
              ElementsAre("g2/mid", "g1/alpha", "g1/zeta"));
  const GraspLibraryInfo* info = registry.FindGraspLibrary("g1/zeta");
  ASSERT_NE(info, nullptr);
  EXPECT_EQ(info->robot, "zeta");
  EXPECT_EQ(info->asset_library, "assets");
  EXPECT_FALSE(info->builtin);
  // The first robot in sorted order wins when no filter is given.
  EXPECT_EQ(registry.FindPickupGraspFile("a")->library, "g1/alpha");
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
  EXPECT_THAT(dup_summary,
              ::testing::UnorderedElementsAre("Bowl_1: thor thor", "Bowl_1: thor user",
                                              "Cup_1: thor objaverse"));

  // Built-in grasp libraries, after user grasps registered against thor.
  EXPECT_THAT(registry.grasp_libraries_of("thor"), ElementsAre("droid"));
  EXPECT_THAT(registry.grasp_libraries_of("objaverse"), ElementsAre("droid_objaverse"));
  EXPECT_TRUE(registry.FindGraspLibrary("droid")->builtin);
  EXPECT_EQ(registry.PickupGraspPath("Bowl_1"),
            assets / "grasps/droid/Bowl_1/Bowl_1_grasps_filtered.npz");
  // The user grasps for Bowl_1 serve "user", which Bowl_1 does not resolve to.
  registry.RegisterGraspLibrary("ug", tmp.path() / "user", "user");
  EXPECT_THAT(registry.GraspLibrariesFor("Bowl_1"), ElementsAre("droid"));
  registry.RegisterGraspLibrary("tg", tmp.path() / "user", "thor");
  EXPECT_THAT(registry.GraspLibrariesFor("Bowl_1"), ElementsAre("tg/franka", "droid"));
  EXPECT_EQ(registry.LoadPickupGrasps("Bowl_1").poses[0](1, 3), 5);  // user grasps first
  const std::vector<std::string> droid = {"droid"};
  EXPECT_EQ(registry.LoadPickupGrasps("Bowl_1", droid).poses.size(), 3u);

  // Joint grasps use the library's own folder (the original hard-codes droid).
  EXPECT_EQ(registry.JointGraspPath("Bowl_1", "lid_hinge"),
            assets / "grasps/droid/Bowl_1/lid_hinge_grasps_filtered.npz");
  EXPECT_EQ(registry.JointGraspPath("abc123", "door"),
            assets / "grasps/droid_objaverse/abc123/door_grasps_filtered.npz");
  EXPECT_EQ(registry.LoadJointGrasps("abc123", "door").poses.size(), 5u);
  EXPECT_FALSE(registry.JointGraspPath("abc123", "lid_hinge").has_value());
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
  EXPECT_FALSE(registry_.PickupGraspPath("a", root_only).has_value());
  EXPECT_THAT(registry_.GraspLibrariesFor("unknown"), IsEmpty());
}

TEST_F(GraspLookupTest, FirstExistingCandidateWins) {
  EXPECT_EQ(registry_.PickupGraspPath("a"), tmp_.path() / "g2/a/gamma/grasps.npz");
  const std::vector<std::string> beta_first = {"g1/beta", "g1/alpha"};
  // g1/beta lists a but has no file: the next library answers.
  auto found = registry_.FindPickupGraspFile("a", beta_first);
  ASSERT_TRUE(found.has_value());
  EXPECT_EQ(found->library, "g1/alpha");
  EXPECT_EQ(found->path, tmp_.path() / "g1/a/alpha/grasps.npz");
  const std::vector<std::string> beta = {"g1/beta"};
  EXPECT_FALSE(registry_.PickupGraspPath("a", beta).has_value());
  EXPECT_EQ(registry_.PickupGraspPath("b"), tmp_.path() / "g1/b/beta/grasps.npz");
  EXPECT_FALSE(registry_.PickupGraspPath("nope").has_value());
}

TEST_F(GraspLookupTest, HasValidComparesRowCount) {
  const std::vector<std::string> alpha = {"g1/alpha"};
  EXPECT_TRUE(registry_.HasValidPickupGrasps("a", 5, alpha));
  EXPECT_FALSE(registry_.HasValidPickupGrasps("a", 6, alpha));
  EXPECT_TRUE(registry_.HasValidPickupGrasps("a"));
  EXPECT_TRUE(registry_.HasValidPickupGrasps("a", 7));
  EXPECT_FALSE(registry_.HasValidPickupGrasps("a", 8));
  const std::vector<std::string> beta = {"g1/beta"};
  EXPECT_FALSE(registry_.HasValidPickupGrasps("a", 1, beta));  // no file: false, no error
  EXPECT_FALSE(registry_.HasValidPickupGrasps("nope"));
  // A grasp file without transforms.npy raises, as the original does.
  WriteNpz(tmp_.path() / "g1/a/alpha/grasps.npz",
           {{"other", NpyArray::FromDoubles({1}, std::vector<double>{1.0})}});
  EXPECT_THROW(registry_.HasValidPickupGrasps("a", 1, alpha), Error);
}

TEST_F(GraspLookupTest, JointTrio) {
  EXPECT_EQ(registry_.JointGraspPath("a", "hinge"),
            tmp_.path() / "g2/a/gamma/joint_grasps_hinge.npz");
  const std::vector<std::string> alpha = {"g1/alpha"};
  EXPECT_EQ(registry_.JointGraspPath("a", "hinge", alpha),
            tmp_.path() / "g1/a/alpha/joint_grasps_hinge.npz");
  EXPECT_TRUE(registry_.HasValidJointGrasps("a", "hinge", 3));
  EXPECT_FALSE(registry_.HasValidJointGrasps("a", "hinge", 4));
  EXPECT_TRUE(registry_.HasValidJointGrasps("a", "hinge", 4, alpha));
  EXPECT_FALSE(registry_.HasValidJointGrasps("a", "door"));
  const GraspSet set = registry_.LoadJointGrasps("a", "hinge", alpha);
  EXPECT_EQ(set.poses.size(), 4u);
  EXPECT_EQ(set.poses[3](0, 3), 3);
  EXPECT_EQ(set.poses[3](1, 3), 1);  // file tag of g1
  EXPECT_EQ(ErrorOf([&] { registry_.LoadJointGrasps("a", "door"); }),
            "No joint grasp file found for a/door");
}

TEST_F(GraspLookupTest, SingleLibraryBypassOnlyForUnknownUids) {
  // An unknown UID (e.g. iTHOR articulated objects) with exactly one library: asked directly.
  WriteGraspLibrary(tmp_.path() / "g3", {{}, {{"delta", {{"ghost", {{"door", 2}}}}}}});
  registry_.RegisterGraspLibrary("g3", tmp_.path() / "g3", "assets");
  const std::vector<std::string> one = {"g3/delta"};
  EXPECT_EQ(registry_.JointGraspPath("ghost", "door", one),
            tmp_.path() / "g3/ghost/delta/joint_grasps_door.npz");
  EXPECT_FALSE(registry_.JointGraspPath("ghost", "door").has_value());
  const std::vector<std::string> two = {"g3/delta", "g1/alpha"};
  EXPECT_FALSE(registry_.JointGraspPath("ghost", "door", two).has_value());
  // A located UID keeps the availability filter (the original skipped it).
  TempDir other;
  WriteAssetLibrary(other.path() / "other", {"o"});
  WriteGraspLibrary(other.path() / "og", {{}, {{"r", {{"a", {{"hinge", 1}}}}}}});
  registry_.RegisterAssetLibrary("other", other.path() / "other");
  registry_.RegisterGraspLibrary("og", other.path() / "og", "other");
  const std::vector<std::string> og = {"og/r"};
  EXPECT_FALSE(registry_.JointGraspPath("a", "hinge", og).has_value());
}

TEST_F(GraspLookupTest, LoadAllOrSubsample) {
  const std::vector<std::string> alpha = {"g1/alpha"};
  const GraspSet all = registry_.LoadPickupGrasps("a", alpha, 5);
  ASSERT_EQ(all.poses.size(), 5u);
  EXPECT_THAT(all.indices, ElementsAre(0, 1, 2, 3, 4));
  EXPECT_EQ(all.source, tmp_.path() / "g1/a/alpha/grasps.npz");
  EXPECT_EQ(all.stored_dtype, DType::kF8);
  for (size_t i = 0; i < 5; ++i) EXPECT_EQ(all.poses[i](0, 3), static_cast<double>(i));

  const GraspSet some = registry_.LoadPickupGrasps("a", alpha, 3, 42);
  ASSERT_EQ(some.poses.size(), 3u);
  EXPECT_EQ(some.indices, SubsampleIndices(5, 3, 42));
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(some.poses[i](0, 3), static_cast<double>(some.indices[i]));
  }
  EXPECT_EQ(registry_.LoadPickupGrasps("a", alpha, 3, 42).indices, some.indices);
  EXPECT_EQ(ErrorOf([&] { registry_.LoadPickupGrasps("nope"); }),
            "No grasp file found for nope");
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
  EXPECT_TRUE(registry.HasValidPickupGrasps("red_block", 1));
  EXPECT_FALSE(registry.HasValidPickupGrasps("red_block", 2));
  const GraspSet grasps = registry.LoadPickupGrasps("red_block");
  ASSERT_EQ(grasps.poses.size(), 1u);
  EXPECT_EQ(grasps.poses[0](1, 1), -1);
  EXPECT_EQ(grasps.poses[0](2, 2), -1);
  EXPECT_EQ(grasps.poses[0](0, 0), 1);
}

// ---- grasp files, subsampling, world grasps ------------------------------------------------

TEST(ReadGraspFileTest, ValidatesShapeAndValues) {
  TempDir tmp;
  const fs::path f = tmp.path() / "g.npz";
  WriteNpz(f, {{"transforms", NpyArray::FromDoubles({2, 3, 3}, std::vector<double>(18, 0.0))}});
  EXPECT_THAT(ErrorOf([&] { ReadGraspFile(f); }),
              HasSubstr("must have shape (N, 4, 4), got (2, 3, 3)"));
  WriteNpz(f, {{"transforms", NpyArray::FromDoubles({16}, std::vector<double>(16, 0.0))}});
  EXPECT_THAT(ErrorOf([&] { ReadGraspFile(f); }), HasSubstr("got (16,)"));
  std::vector<double> values(32, 0.0);
  values[16 + 5] = std::numeric_limits<double>::quiet_NaN();
  WriteNpz(f, {{"transforms", NpyArray::FromDoubles({2, 4, 4}, values)}});
  EXPECT_THAT(ErrorOf([&] { ReadGraspFile(f); }), HasSubstr("grasp 1 has a non-finite value"));
  const std::vector<size_t> first = {0};
  EXPECT_EQ(ReadGraspFile(f, &first).poses.size(), 1u);  // row 1 not read
  const std::vector<size_t> out_of_range = {2};
  EXPECT_THROW(ReadGraspFile(f, &out_of_range), Error);
  WriteNpz(f, {{"grasps", NpyArray::FromDoubles({1, 4, 4}, std::vector<double>(16, 0.0))}});
  EXPECT_THAT(ErrorOf([&] { ReadGraspFile(f); }), HasSubstr("no transforms.npy"));
  EXPECT_THROW(ReadGraspFile(tmp.path() / "missing.npz"), Error);
}

TEST(ReadGraspFileTest, ConvertsStoredDtypesToDouble) {
  TempDir tmp;
  for (DType dtype : {DType::kF2, DType::kF4, DType::kF8}) {
    for (bool compress : {false, true}) {
      const fs::path f = tmp.path() / "g.npz";
      WriteGrasps(f, 6, 0.5, dtype, compress);
      const GraspSet all = ReadGraspFile(f);
      EXPECT_EQ(all.stored_dtype, dtype);
      ASSERT_EQ(all.poses.size(), 6u);
      EXPECT_EQ(all.poses[4](0, 3), 4.0);
      EXPECT_EQ(all.poses[4](1, 3), 0.5);
      EXPECT_EQ(all.poses[4](3, 3), 1.0);
      const std::vector<size_t> rows = {5, 1, 5};
      const GraspSet some = ReadGraspFile(f, &rows);
      EXPECT_THAT(some.indices, ElementsAre(5, 1, 5));
      EXPECT_EQ(some.poses[0](0, 3), 5.0);
      EXPECT_EQ(some.poses[1](0, 3), 1.0);
    }
  }
}

/// The documented algorithm, dense, as a reference.
std::vector<size_t> ReferenceSubsample(size_t n, size_t k, uint64_t seed) {
  std::vector<size_t> a(n);
  for (size_t i = 0; i < n; ++i) a[i] = i;
  Rng rng(seed);
  std::vector<size_t> out;
  for (size_t i = 0; i < k; ++i) {
    size_t j = i + rng.UniformInt(n - i);
    std::swap(a[i], a[j]);
    out.push_back(a[i]);
  }
  return out;
}

TEST(SubsampleTest, AllWhenFewEnough) {
  EXPECT_THAT(SubsampleIndices(4, 4, 9), ElementsAre(0, 1, 2, 3));
  EXPECT_THAT(SubsampleIndices(3, 50, 9), ElementsAre(0, 1, 2));
  EXPECT_THAT(SubsampleIndices(0, 5, 9), IsEmpty());
  EXPECT_THAT(SubsampleIndices(10, 0, 9), IsEmpty());
}

TEST(SubsampleTest, DeterministicDistinctInRange) {
  for (uint64_t seed : {0ull, 1ull, 12345ull}) {
    const std::vector<size_t> a = SubsampleIndices(1000, 50, seed);
    EXPECT_EQ(a, SubsampleIndices(1000, 50, seed));
    ASSERT_EQ(a.size(), 50u);
    EXPECT_EQ(std::set<size_t>(a.begin(), a.end()).size(), 50u);
    for (size_t i : a) EXPECT_LT(i, 1000u);
    EXPECT_EQ(a, ReferenceSubsample(1000, 50, seed));
  }
  EXPECT_NE(SubsampleIndices(1000, 50, 1), SubsampleIndices(1000, 50, 2));
  // k = n - 1 is a full permutation but one.
  const std::vector<size_t> p = SubsampleIndices(10, 9, 3);
  EXPECT_EQ(std::set<size_t>(p.begin(), p.end()).size(), 9u);
}

TEST(SubsampleTest, SparsePathMatchesTheDenseAlgorithm) {
  // Large n with small k takes the sparse path; the draws must be the same.
  for (uint64_t seed : {0ull, 7ull}) {
    EXPECT_EQ(SubsampleIndices(1000000, 40, seed), ReferenceSubsample(1000000, 40, seed));
    EXPECT_EQ(SubsampleIndices(5000, 600, seed), ReferenceSubsample(5000, 600, seed));
  }
  // Small n so that collisions among displaced slots happen, through the public function.
  const std::vector<size_t> s = SubsampleIndices(4097, 512, 5);
  EXPECT_EQ(s, ReferenceSubsample(4097, 512, 5));
  EXPECT_EQ(std::set<size_t>(s.begin(), s.end()).size(), 512u);
}

TEST(SubsampleTest, PinnedDraws) {
  // The documented stream (docs/formats.md) must never change silently.
  const std::vector<size_t> got = SubsampleIndices(100, 5, 0);
  EXPECT_EQ(got, ReferenceSubsample(100, 5, 0));
  EXPECT_THAT(got, ElementsAre(60, 75, 12, 43, 74));
}

Mat4 Make(std::initializer_list<double> rows) {
  Mat4 m;
  std::copy(rows.begin(), rows.end(), m.m.begin());
  return m;
}

TEST(GraspsInWorldTest, ComposesAndFlipsExactly) {
  // Body: rotation of +90 deg about z, at (1, 2, 3).
  const Mat4 body = Make({0, -1, 0, 1,  //
                          1, 0, 0, 2,   //
                          0, 0, 1, 3,   //
                          0, 0, 0, 1});
  // Grasp: the tutorial's top-down grasp, 0.1 m along the body x axis.
  const Mat4 grasp = Make({1, 0, 0, 0.1,  //
                           0, -1, 0, 0,   //
                           0, 0, -1, 0,   //
                           0, 0, 0, 1});
  const std::vector<Mat4> grasps = {grasp, Mat4{}};
  const std::vector<Mat4> w = GraspsInWorld(body, grasps);
  ASSERT_EQ(w.size(), 4u);
  // Hand-computed: R_body * R_grasp = [[0,1,0],[1,0,0],[0,0,-1]]; p = (1, 2.1, 3).
  const Mat4 w0 = Make({0, 1, 0, 1,    //
                        1, 0, 0, 2.1,  //
                        0, 0, -1, 3,   //
                        0, 0, 0, 1});
  EXPECT_EQ(w[0].m, w0.m);
  EXPECT_EQ(w[1].m, body.m);
  // Flipped twins follow all originals: x and y columns negated, z and position kept.
  const Mat4 w0_flipped = Make({0, -1, 0, 1,    //
                                -1, 0, 0, 2.1,  //
                                0, 0, -1, 3,    //
                                0, 0, 0, 1});
  EXPECT_EQ(w[2].m, w0_flipped.m);
  const Mat4 body_flipped = Make({0, 1, 0, 1,   //
                                  -1, 0, 0, 2,  //
                                  0, 0, 1, 3,   //
                                  0, 0, 0, 1});
  EXPECT_EQ(w[3].m, body_flipped.m);
  // Exactly W * diag(-1, -1, 1, 1), and its jaw axis (y) reversed.
  const Mat4 flip = Make({-1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});
  EXPECT_EQ((w[0] * flip).m, w[2].m);
  const std::vector<Mat4> unflipped = GraspsInWorld(body, grasps, false);
  ASSERT_EQ(unflipped.size(), 2u);
  EXPECT_EQ(unflipped[0].m, w0.m);
  EXPECT_TRUE(GraspsInWorld(body, {}).empty());
}

}  // namespace
}  // namespace mlspaces
