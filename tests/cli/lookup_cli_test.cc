// Runs the mlspaces binary: locate, meta, grasps; outputs and exit codes.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/library/registry.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::CliResult;
using ::mlspaces::testing::RunCli;
using ::mlspaces::testing::ShellQuote;
using ::mlspaces::testing::TempDir;
using ::testing::HasSubstr;
using ::testing::Not;

class LookupCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // The bundled example, copied so a missing grasps.npz can be supplied.
    const fs::path example = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets";
    ASSERT_TRUE(fs::exists(example / "asset_library/assets_index.json"));
    fs::copy(example, dir_ / "ex", fs::copy_options::recursive);
    const fs::path npz = dir_ / "ex/asset_library/red_block/droid/grasps.npz";
    if (!fs::exists(npz)) {
      const std::vector<double> pose = {1, 0, 0, 0, 0, -1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1};
      WriteNpz(npz, {{"transforms", NpyArray::FromDoubles({1, 4, 4}, pose)}});
    }
    lib_ = dir_ / "ex/asset_library";
  }
  // Runs the binary without the caller's MLSPACES_ASSETS_DIR; `env` is extra NAME=VALUE words.
  CliResult Run(const std::vector<std::string>& args, const std::string& env = "") {
    return RunCli(args, "env -u MLSPACES_ASSETS_DIR " + env + " ");
  }

  std::string AssetFlag() const { return "custom_assets=" + lib_.string(); }
  std::string GraspFlag() const { return "custom_grasps=" + lib_.string() + ":custom_assets"; }

  TempDir tmp_;
  const fs::path dir_ = tmp_.path();
  fs::path lib_;
};

TEST_F(LookupCliTest, LocateWithYamlAndFlags) {
  const std::string mjcf = (lib_ / "red_block/red_block.xml").string();
  CliResult r = Run({"locate", "red_block", "--libraries", (dir_ / "ex/libraries.yaml").string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "library: custom_assets\nmjcf_path: " + mjcf + "\n");
  EXPECT_EQ(r.err, "");
  r = Run({"locate", "--asset-library", AssetFlag(), "red_block", "--json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j["library"], "custom_assets");
  EXPECT_EQ(j["mjcf_path"], mjcf);
  EXPECT_EQ(j["shadowed"], Json::array());
}

TEST_F(LookupCliTest, LocateUnknownUidAndBadFlags) {
  CliResult r = Run({"locate", "blue_block", "--asset-library", AssetFlag()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "mlspaces: error: blue_block not found in asset libraries ['custom_assets']\n");
  r = Run({"locate", "red_block", "--asset-library", "custom_assets"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("NAME=DIR"));
  r = Run({"locate", "red_block", "--asset-library", "a/b=" + lib_.string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("User library a/b must not contain slashes"));
  r = Run({"locate", "red_block", "--asset-library", "thor=" + lib_.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("name conflicts with a built-in object source"));
  r = Run({"locate", "red_block", "--asset-library", "x=" + dir_.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("assets_index.json: User library"));
  r = Run({"locate"});
  EXPECT_EQ(r.exit_code, 2);
}

TEST_F(LookupCliTest, DuplicateUidsAreWarned) {
  CliResult r = Run({"locate", "red_block", "--asset-library", AssetFlag(), "--asset-library",
                     "second=" + lib_.string()});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_THAT(r.out, HasSubstr("library: custom_assets\n"));
  EXPECT_THAT(r.out, HasSubstr("shadows: second\n"));
  EXPECT_THAT(r.err, HasSubstr("mlspaces: warning: UID red_block is in several asset "
                               "libraries: custom_assets ("));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1);
}

TEST_F(LookupCliTest, BuiltinsFromTheEnvironment) {
  const fs::path assets = dir_ / "assets";
  WriteFileAtomic(assets / "objects/thor/kitchen/Bowl_1.xml", "<mujoco/>");
  CliResult r = Run({"locate", "Bowl_1"}, "MLSPACES_ASSETS_DIR=" + ShellQuote(assets.string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "library: thor\nmjcf_path: " +
                       (assets / "objects/thor/kitchen/Bowl_1.xml").string() + "\n");
  r = Run({"locate", "Bowl_1"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "mlspaces: error: Bowl_1 not found in asset libraries []\n");
}

TEST_F(LookupCliTest, Meta) {
  CliResult r = Run({"meta", "red_block", "--asset-library", AssetFlag()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  EXPECT_EQ(j["assetId"], "red_block");
  EXPECT_EQ(j["mass"].get<double>(), 0.12500000000000003);
  EXPECT_THAT(r.out, HasSubstr("\n    \"category\": \"block\",\n"));  // indent 4
  // With an array NPZ, the arrays are merged in as lists.
  WriteNpz(lib_ / "red_block/red_block.npz",
           {{"description_short/clip", NpyArray::FromDoubles({2}, std::vector<double>{1, 2})}});
  Json index = Json::parse(ReadFile(lib_ / "assets_index.json"));
  index["red_block"]["metadata_npz_path"] = "red_block/red_block.npz";
  WriteFileAtomic(lib_ / "assets_index.json", index.dump(4));
  r = Run({"meta", "red_block", "--asset-library", AssetFlag()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json::parse(r.out)["description_short"]["clip"], Json::parse("[1.0, 2.0]"));
  r = Run({"meta", "nope", "--asset-library", AssetFlag()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("nope not found in asset libraries"));
}

TEST_F(LookupCliTest, Grasps) {
  CliResult r =
      Run({"grasps", "red_block", "--asset-library", AssetFlag(), "--grasp-library", GraspFlag()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("library: custom_grasps/droid\n"));
  EXPECT_THAT(r.out, HasSubstr("path: " + (lib_ / "red_block/droid/grasps.npz").string()));
  EXPECT_THAT(r.out, HasSubstr("count: 1 (stored <f8)\n"));
  EXPECT_THAT(r.out, HasSubstr("grasp 0 (row 0):\n"
                               "   1.000000  0.000000  0.000000  0.000000\n"
                               "   0.000000 -1.000000  0.000000  0.000000\n"
                               "   0.000000  0.000000 -1.000000  0.000000\n"
                               "   0.000000  0.000000  0.000000  1.000000\n"));

  r = Run({"grasps", "red_block", "--libraries", (dir_ / "ex/libraries.yaml").string(), "--robot",
           "franka"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("no grasp library for robot franka serves red_block"));
  r = Run({"grasps", "red_block", "--libraries", (dir_ / "ex/libraries.yaml").string(), "--robot",
           "droid"});
  EXPECT_EQ(r.exit_code, 0) << r.err;

  r = Run({"grasps", "red_block", "--asset-library", AssetFlag()});  // no grasp library
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "mlspaces: error: No grasp file found for red_block\n");
  r = Run({"grasps", "red_block", "--asset-library", AssetFlag(), "--grasp-library", GraspFlag(),
           "--joint", "lid"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("No joint grasp file found for red_block/lid"));
  r = Run({"grasps", "red_block", "--asset-library", AssetFlag(), "--grasp-library",
           "custom_grasps=" + lib_.string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("NAME=DIR:ASSET_LIBRARY"));
  r = Run({"grasps", "red_block", "--asset-library", AssetFlag(), "--num", "0"});
  EXPECT_EQ(r.exit_code, 2);
}

TEST_F(LookupCliTest, GraspsSubsampleAndWrite) {
  // 20 grasps: translation x = row index.
  std::vector<double> values;
  for (int k = 0; k < 20; ++k) {
    const double m[16] = {1, 0, 0, static_cast<double>(k), 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    values.insert(values.end(), m, m + 16);
  }
  WriteNpz(lib_ / "red_block/droid/grasps.npz",
           {{"transforms", NpyArray::FromDoubles(DType::kF4, {20, 4, 4}, values)}});
  const fs::path out = dir_ / "out.npz";
  const std::vector<std::string> base = {"grasps",    "red_block",       "--asset-library",
                                         AssetFlag(), "--grasp-library", GraspFlag()};
  std::vector<std::string> args = base;
  args.insert(args.end(), {"--num", "5", "--seed", "7", "--out", out.string()});
  CliResult r = Run(args);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("count: 5 (stored <f4)\n"));
  EXPECT_THAT(r.out, HasSubstr("wrote " + out.string() + " (5 grasps)"));
  NpzReader reader(out);
  const NpyArray t = reader.Read("transforms");
  EXPECT_EQ(t.dtype, DType::kF8);
  EXPECT_EQ(t.shape, (std::vector<size_t>{5, 4, 4}));
  // Same rows as the library's subsampling, and distinct.
  const std::vector<size_t> rows = SubsampleIndices(20, 5, 7);
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(t.AsDouble(i * 16 + 3), static_cast<double>(rows[i]));
    EXPECT_THAT(
        r.out, HasSubstr("grasp " + std::to_string(i) + " (row " + std::to_string(rows[i]) + "):"));
  }
  // All 20: a summary instead of every matrix.
  r = Run(base);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("count: 20"));
  EXPECT_THAT(r.out, HasSubstr("... 17 more"));
  EXPECT_THAT(r.out, Not(HasSubstr("grasp 3 (")));
}

}  // namespace
}  // namespace mlspaces
