#include "mlspaces/library/grasp_index.h"

#include <filesystem>
#include <functional>
#include <set>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "../../examples/custom_assets/example_grasps.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/npz.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ErrorOf;
using ::mlspaces::testing::ExampleLibrary;
using ::mlspaces::testing::ListFiles;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using ::testing::HasSubstr;

// {"articulated_grasp_paths": {}, "grasp_paths": {"droid": {"red_block":
// "red_block/droid/grasps.npz"}}} as the original writes it (indent 4, no trailing newline).
constexpr char kExampleIndex[] =
    "{\n"
    "    \"articulated_grasp_paths\": {},\n"
    "    \"grasp_paths\": {\n"
    "        \"droid\": {\n"
    "            \"red_block\": \"red_block/droid/grasps.npz\"\n"
    "        }\n"
    "    }\n"
    "}";

TEST(GraspIndexTest, ExampleGolden) {
  IndexReport report;
  GraspIndex index = BuildGraspIndex(ExampleLibrary(), &report);
  EXPECT_EQ(report.count, 1u);
  EXPECT_EQ(report.robots, 1u);
  EXPECT_EQ(index.Serialize(), kExampleIndex);
  EXPECT_EQ(ReadFile(ExampleLibrary() / "grasps_index.json"), kExampleIndex);
  GraspIndex loaded = GraspIndex::Load(ExampleLibrary() / "grasps_index.json");
  EXPECT_EQ(loaded.grasp_paths, index.grasp_paths);
  EXPECT_EQ(loaded.robots(), std::vector<std::string>{"droid"});
}

// The committed example grasp file is what our writer produces (make_example_grasps).
TEST(GraspIndexTest, ExampleGraspFileIsReproducible) {
  TempDir tmp;
  WriteNpz(tmp / "grasps.npz", examples::RedBlockGrasps());
  const std::string committed = ReadFile(ExampleLibrary() / "red_block/droid/grasps.npz");
  EXPECT_EQ(ReadFile(tmp / "grasps.npz"), committed);
  NpzReader reader(ExampleLibrary() / "red_block/droid/grasps.npz");
  NpyHeader header = reader.ReadHeader("transforms");
  EXPECT_EQ(header.dtype, DType::kF8);
  EXPECT_EQ(header.shape, (std::vector<size_t>{1, 4, 4}));
  EXPECT_EQ(reader.Read("transforms").ToDoubles(),
            (std::vector<double>{1, 0, 0, 0, 0, -1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1}));
}

TEST(GraspIndexTest, SerializeEmpty) {
  EXPECT_EQ(GraspIndex{}.Serialize(),
            "{\n    \"articulated_grasp_paths\": {},\n    \"grasp_paths\": {}\n}");
}

TEST(GraspIndexTest, JointGraspsRobotsAndNesting) {
  TempDir tmp;
  const fs::path root = tmp / "lib";
  WriteText(root / "cab/droid/joint_grasps_door_b.npz", "");
  WriteText(root / "cab/droid/joint_grasps_door_a.npz", "");
  WriteText(root / "x/y/mug/franka/grasps.npz", "");
  WriteText(root / "mug/droid/grasps.npz", "");
  WriteText(root / "mug/droid/other.npz", "");
  IndexReport report;
  GraspIndex index = BuildGraspIndex(root, &report);
  EXPECT_EQ(report.robots, 2u);
  EXPECT_EQ(report.count, 2u);
  EXPECT_EQ(index.robots(), (std::vector<std::string>{"droid", "franka"}));
  EXPECT_EQ(index.grasp_paths.at("franka").at("mug"), "x/y/mug/franka/grasps.npz");
  EXPECT_EQ(index.articulated_grasp_paths.at("droid").at("cab").at("door_a"),
            "cab/droid/joint_grasps_door_a.npz");
  EXPECT_EQ(index.Serialize(),
            "{\n"
            "    \"articulated_grasp_paths\": {\n"
            "        \"droid\": {\n"
            "            \"cab\": {\n"
            "                \"door_a\": \"cab/droid/joint_grasps_door_a.npz\",\n"
            "                \"door_b\": \"cab/droid/joint_grasps_door_b.npz\"\n"
            "            }\n"
            "        }\n"
            "    },\n"
            "    \"grasp_paths\": {\n"
            "        \"droid\": {\n"
            "            \"mug\": \"mug/droid/grasps.npz\"\n"
            "        },\n"
            "        \"franka\": {\n"
            "            \"mug\": \"x/y/mug/franka/grasps.npz\"\n"
            "        }\n"
            "    }\n"
            "}");
  WriteText(tmp / "grasps_index.json", index.Serialize());
  GraspIndex loaded = GraspIndex::Load(tmp / "grasps_index.json");
  EXPECT_EQ(loaded.grasp_paths, index.grasp_paths);
  EXPECT_EQ(loaded.articulated_grasp_paths, index.articulated_grasp_paths);
}

TEST(GraspIndexTest, ArticulatedOnlyCountsZero) {
  TempDir tmp;
  WriteText(tmp / "lib/cab/droid/joint_grasps_hinge.npz", "");
  IndexReport report;
  GraspIndex index = BuildGraspIndex(tmp / "lib", &report);
  EXPECT_EQ(report.count, 0u);
  EXPECT_EQ(report.robots, 0u);
  EXPECT_EQ(index.robots(), std::vector<std::string>{"droid"});
}

TEST(GraspIndexTest, BadLayoutsAreErrors) {
  TempDir tmp;
  const fs::path root = fs::weakly_canonical(tmp.path());
  WriteText(root / "a/grasps.npz", "");
  EXPECT_THAT(ErrorOf([&] { BuildGraspIndex(root / "a", nullptr); }),
              HasSubstr((root / "a/grasps.npz").string() + ": grasp files must be at"));
  WriteText(root / "b/droid/grasps.npz", "");
  EXPECT_THAT(ErrorOf([&] { BuildGraspIndex(root / "b", nullptr); }),
              HasSubstr("grasp files must be at <uid>/<robot>/grasps.npz"));
  WriteText(root / "c/u/droid/joint_grasps_.npz", "");
  EXPECT_THAT(ErrorOf([&] { BuildGraspIndex(root / "c", nullptr); }),
              HasSubstr("empty joint name"));
  WriteText(root / "d/u/droid/grasps.npz", "");
  WriteText(root / "d/deeper/u/droid/grasps.npz", "");
  EXPECT_EQ(ErrorOf([&] { BuildGraspIndex(root / "d", nullptr); }),
            "duplicate grasps for robot 'droid' and uid 'u': deeper/u/droid/grasps.npz and "
            "u/droid/grasps.npz");
}

TEST(GraspIndexTest, LoadDefaultsAndErrors) {
  TempDir tmp;
  const fs::path file = tmp / "grasps_index.json";
  const std::string f = file.string();
  WriteText(file, "{}");
  GraspIndex empty = GraspIndex::Load(file);
  EXPECT_TRUE(empty.grasp_paths.empty());
  EXPECT_TRUE(empty.articulated_grasp_paths.empty());
  WriteText(file, R"({"grasp_paths": {"droid": {"mug": 5}}})");
  EXPECT_EQ(ErrorOf([&] { GraspIndex::Load(file); }),
            f + ": /grasp_paths/droid/mug: expected string, got number");
  WriteText(file, R"({"articulated_grasp_paths": {"droid": {"cab": "x"}}})");
  EXPECT_EQ(ErrorOf([&] { GraspIndex::Load(file); }),
            f + ": /articulated_grasp_paths/droid/cab: expected object, got string");
  WriteText(file, R"({"grasp_paths": []})");
  EXPECT_EQ(ErrorOf([&] { GraspIndex::Load(file); }),
            f + ": /grasp_paths: expected object, got array");
  WriteText(file, "{\"grasp_paths\": {\n\"droid\": {\"mug\": \"a\" \"b\"}}}");
  std::string what = ErrorOf([&] { GraspIndex::Load(file); });
  EXPECT_THAT(what, HasSubstr(f));
  EXPECT_THAT(what, HasSubstr("line 2"));
}

// A grasps file that is a broken symbolic link would be an index entry pointing at nothing.
TEST(GraspIndexTest, BrokenSymlinkIsAnErrorAndWritesNothing) {
  TempDir tmp;
  const fs::path root = fs::weakly_canonical(tmp.path()) / "lib";
  WriteText(root / "u/droid/grasps.npz", "");
  fs::create_directories(root / "v/droid");
  fs::create_symlink(tmp / "gone.npz", root / "v/droid/joint_grasps_hinge.npz");
  EXPECT_EQ(ErrorOf([&] { WriteGraspIndex(root, {}); }),
            (root / "v/droid/joint_grasps_hinge.npz").string() +
                ": broken symbolic link: its target does not exist");
  EXPECT_FALSE(fs::exists(root / "grasps_index.json"));
  // A symlink to an existing file is indexed as before.
  WriteText(tmp / "gone.npz", "");
  EXPECT_EQ(BuildGraspIndex(root, nullptr).articulated_grasp_paths.at("droid").at("v").at("hinge"),
            "v/droid/joint_grasps_hinge.npz");
}

TEST(GraspIndexTest, WriteRefusesExistingOutput) {
  TempDir tmp;
  const fs::path root = fs::weakly_canonical(tmp.path()) / "lib";
  WriteText(root / "u/droid/grasps.npz", "");
  WriteText(root / "grasps_index.json", "old");
  EXPECT_EQ(
      ErrorOf([&] { WriteGraspIndex(root, {}); }),
      (root / "grasps_index.json").string() + " already exists. Use --overwrite to overwrite.");
  EXPECT_EQ(ReadFile(root / "grasps_index.json"), "old");
  GraspIndexOptions options;
  options.overwrite = true;
  IndexReport report = WriteGraspIndex(root, options);
  EXPECT_EQ(report.count, 1u);
  EXPECT_EQ(ListFiles(root), (std::set<std::string>{"u/droid/grasps.npz", "grasps_index.json"}));
  EXPECT_EQ(GraspIndex::Load(root / "grasps_index.json").grasp_paths.at("droid").at("u"),
            "u/droid/grasps.npz");
}

}  // namespace
}  // namespace mlspaces
