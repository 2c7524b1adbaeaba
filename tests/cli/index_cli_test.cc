// Runs the mlspaces binary: index-assets, index-grasps, validate.
#include <sys/stat.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::CliResult;
using ::mlspaces::testing::CopyExampleLibrary;
using ::mlspaces::testing::ListFiles;
using ::mlspaces::testing::RunCli;
using ::mlspaces::testing::Slurp;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

constexpr char kExampleAssetIndexPlain[] =
    "{\n"
    "    \"red_block\": {\n"
    "        \"uid\": \"red_block\",\n"
    "        \"object_path\": \"red_block/red_block.xml\",\n"
    "        \"metadata_path\": \"red_block/red_block.json\",\n"
    "        \"metadata_npz_path\": null\n"
    "    }\n"
    "}";

class IndexCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    lib_ = fs::weakly_canonical(CopyExampleLibrary(tmp_.path()));
    fs::remove(lib_ / "assets_index.json");
    fs::remove(lib_ / "grasps_index.json");
  }
  TempDir tmp_;
  fs::path lib_;
};

TEST_F(IndexCliTest, IndexAssetsExample) {
  CliResult r = RunCli({"index-assets", lib_.string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "Wrote " + (lib_ / "assets_index.json").string() + " with 1 assets.\n");
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(Slurp(lib_ / "assets_index.json"), kExampleAssetIndexPlain);
}

TEST_F(IndexCliTest, IndexGraspsExample) {
  CliResult r = RunCli({"index-grasps", lib_.string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out,
            "Wrote " + (lib_ / "grasps_index.json").string() + " with 1 robots / 1 grasp files.\n");
  EXPECT_EQ(Slurp(lib_ / "grasps_index.json"),
            Slurp(fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets/asset_library/"
                                                    "grasps_index.json"));
}

TEST_F(IndexCliTest, ExistingOutputWithoutOverwrite) {
  WriteText(lib_ / "assets_index.json", "keep me");
  WriteText(lib_ / "grasps_index.json", "keep me too");
  std::set<std::string> before = ListFiles(lib_);
  CliResult r = RunCli({"index-assets", lib_.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "mlspaces: error: " + (lib_ / "assets_index.json").string() +
                       " already exists. Use --overwrite to overwrite.\n");
  r = RunCli({"index-grasps", lib_.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "mlspaces: error: " + (lib_ / "grasps_index.json").string() +
                       " already exists. Use --overwrite to overwrite.\n");
  EXPECT_EQ(Slurp(lib_ / "assets_index.json"), "keep me");
  EXPECT_EQ(Slurp(lib_ / "grasps_index.json"), "keep me too");
  EXPECT_EQ(ListFiles(lib_), before);

  r = RunCli({"index-assets", lib_.string(), "--overwrite"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Slurp(lib_ / "assets_index.json"), kExampleAssetIndexPlain);
  r = RunCli({"index-grasps", "--overwrite", lib_.string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ListFiles(lib_), before);  // same names: no temp files left behind
}

TEST_F(IndexCliTest, CustomOutput) {
  const fs::path out = tmp_.path() / "elsewhere" / "idx.json";
  CliResult r = RunCli({"index-assets", lib_.string(), "-o", out.string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "Wrote " + fs::weakly_canonical(out).string() + " with 1 assets.\n");
  EXPECT_EQ(Slurp(out), kExampleAssetIndexPlain);
  EXPECT_FALSE(fs::exists(lib_ / "assets_index.json"));
}

TEST_F(IndexCliTest, MissingMetadata) {
  WriteText(lib_ / "includes" / "materials.xml", "<mujoco/>");
  std::set<std::string> before = ListFiles(lib_);
  CliResult r = RunCli({"index-assets", lib_.string()});
  EXPECT_EQ(r.exit_code, 1);
  const std::string message =
      "Expected metadata JSON for " + (lib_ / "includes/materials.xml").string() + " at " +
      (lib_ / "includes/materials.json").string() + ", but it was not found.";
  EXPECT_EQ(r.err, "mlspaces: error: " + message + "\n");
  EXPECT_EQ(ListFiles(lib_), before);

  r = RunCli({"index-assets", lib_.string(), "--suppress-missing-metadata"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "Warning: " + message + " Skipping.\n");
  EXPECT_EQ(r.out, "Wrote " + (lib_ / "assets_index.json").string() + " with 1 assets.\n");
}

TEST_F(IndexCliTest, DuplicateUid) {
  WriteText(lib_ / "copy" / "red_block.xml", "<mujoco/>");
  WriteText(lib_ / "copy" / "red_block.json", "{}");
  CliResult r = RunCli({"index-assets", lib_.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err,
            "mlspaces: error: Duplicate asset id 'red_block' found at red_block/red_block.xml "
            "and copy/red_block.xml.\n");
  EXPECT_FALSE(fs::exists(lib_ / "assets_index.json"));
}

TEST_F(IndexCliTest, MissingSourceFolder) {
  CliResult r = RunCli({"index-assets", (tmp_.path() / "nope").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, StartsWith("mlspaces: error: "));
  EXPECT_THAT(r.err, HasSubstr("not found"));
  EXPECT_FALSE(fs::exists(tmp_.path() / "nope"));
  r = RunCli({"index-grasps", (tmp_.path() / "nope").string()});
  EXPECT_EQ(r.exit_code, 1);
}

TEST_F(IndexCliTest, BadUsage) {
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"index-assets"},
        std::vector<std::string>{"index-assets", lib_.string(), "--frobnicate"},
        std::vector<std::string>{"index-grasps"},
        std::vector<std::string>{"index-grasps", lib_.string(), "-o"},
        std::vector<std::string>{"validate"},
        std::vector<std::string>{"validate", lib_.string(), "extra"}}) {
    CliResult r = RunCli(args);
    EXPECT_EQ(r.exit_code, 2) << args.back() << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr("error"));
  }
  EXPECT_FALSE(fs::exists(lib_ / "assets_index.json"));
}

// --compute-metadata needs MuJoCo; until the sim layer wires it up it is a usage error.
// The tutorial's step: index with --compute-metadata writes <uid>_computed.json with the
// compiled mass and box and points the index at it; rerunning keeps (never drops) it.
TEST_F(IndexCliTest, ComputeMetadataWritesComputedJson) {
  fs::remove(lib_ / "red_block/red_block_computed.json");
  CliResult r = RunCli({"index-assets", lib_.string(), "--compute-metadata"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("with 1 assets."));
  const std::string computed = Slurp(lib_ / "red_block/red_block_computed.json");
  EXPECT_THAT(computed, HasSubstr("\"mass\": 0.12500000000000003"));
  EXPECT_THAT(computed, HasSubstr("\"boundingBox\": {\n        \"x\": 0.05,"));
  EXPECT_THAT(Slurp(lib_ / "assets_index.json"),
              HasSubstr("\"metadata_path\": \"red_block/red_block_computed.json\""));

  // Without --overwrite the existing index is refused and left untouched.
  const std::string before = Slurp(lib_ / "assets_index.json");
  r = RunCli({"index-assets", lib_.string(), "--compute-metadata"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("already exists. Use --overwrite to overwrite."));
  EXPECT_EQ(Slurp(lib_ / "assets_index.json"), before);

  // After deleting only the index, the asset is still indexed (the original drops it).
  fs::remove(lib_ / "assets_index.json");
  r = RunCli({"index-assets", lib_.string(), "--compute-metadata"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("(0 computed"));
  EXPECT_THAT(Slurp(lib_ / "assets_index.json"), HasSubstr("red_block_computed.json"));
}

// A broken asset is reported with its file and skipped; the others are indexed; exit 1.
TEST_F(IndexCliTest, ComputeMetadataReportsBrokenAssetAndGoesOn) {
  fs::create_directories(lib_ / "broken");
  WriteText(lib_ / "broken/broken.xml",
            "<mujoco><worldbody><body><geom type=\"box\" size=\"x\"/>"
            "</body></worldbody></mujoco>");
  WriteText(lib_ / "broken/broken.json", "{\"category\": \"junk\"}");
  CliResult r = RunCli({"index-assets", lib_.string(), "--compute-metadata", "--overwrite"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "mlspaces: error: " + (lib_ / "broken/broken.xml").string() +
                       ": line 1, element <geom>: bad format in attribute 'size'\n");
  EXPECT_THAT(r.out, HasSubstr("1 failed"));
  EXPECT_THAT(r.out, HasSubstr("with 1 assets, leaving out the 1 that failed.\n"));
  EXPECT_TRUE(fs::exists(lib_ / "red_block/red_block_computed.json"));
  EXPECT_THAT(Slurp(lib_ / "assets_index.json"), HasSubstr("red_block"));
  EXPECT_THAT(Slurp(lib_ / "assets_index.json"), Not(HasSubstr("broken")));
}

// The issue's case: one asset's metadata JSON is malformed. It is named (file and line) on one
// line, left out of the index (no entry points at a file that is not there), and exit is 1.
TEST_F(IndexCliTest, ComputeMetadataMalformedJsonIsLeftOut) {
  fs::create_directories(lib_ / "bad");
  fs::copy_file(lib_ / "red_block/red_block.xml", lib_ / "bad/bad.xml");
  WriteText(lib_ / "bad/bad.json", "{\"category\": \"x\",\n");
  CliResult r = RunCli({"index-assets", lib_.string(), "--compute-metadata", "--overwrite"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, StartsWith("mlspaces: error: " + (lib_ / "bad/bad.json").string() +
                                ": line 2, column 1: invalid JSON: "));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1);
  EXPECT_THAT(r.out, HasSubstr("(1 computed, 0 reused, 1 failed)"));
  const std::string index = Slurp(lib_ / "assets_index.json");
  EXPECT_THAT(index, Not(HasSubstr("bad")));
  EXPECT_FALSE(fs::exists(lib_ / "bad/bad_computed.json"));
  EXPECT_EQ(RunCli({"validate", lib_.string()}).out, lib_.string() + ": OK\n");
}

// A mesh broken after an earlier compute: the old computed file does not stand in for the
// failed one (it is deleted: mlspaces wrote it), and validate names the asset.
TEST_F(IndexCliTest, ComputeMetadataBrokenMeshAndValidate) {
  const fs::path mesh_lib =
      fs::path(MLSPACES_TESTDATA_DIR).parent_path().parent_path() / "sim/testdata/library/neg_tet";
  fs::copy(mesh_lib, lib_ / "neg_tet");
  ASSERT_EQ(RunCli({"index-assets", lib_.string(), "--compute-metadata"}).exit_code, 0);
  ASSERT_EQ(RunCli({"validate", lib_.string()}).exit_code, 0);
  WriteText(lib_ / "neg_tet/neg_tet.obj", "v 0 0 0\n");

  const std::string xml = (lib_ / "neg_tet/neg_tet.xml").string();
  const std::string computed = (lib_ / "neg_tet/neg_tet_computed.json").string();
  const std::string stale = computed + ": /computed_from/files/neg_tet.obj: stale: " +
                            (lib_ / "neg_tet/neg_tet.obj").string() +
                            " changed since this file was computed (run mlspaces index-assets "
                            "--compute-metadata again)\n";
  CliResult r = RunCli({"validate", lib_.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.out, HasSubstr(stale));
  EXPECT_THAT(r.out, HasSubstr(xml + ": line 6: asset 'neg_tet' does not compile: "));
  EXPECT_THAT(r.out, HasSubstr("2 problems in " + lib_.string() + "\n"));
  r = RunCli({"validate", lib_.string(), "--no-compile"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, stale + "1 problems in " + lib_.string() + "\n");

  fs::remove(lib_ / "assets_index.json");
  r = RunCli({"index-assets", lib_.string(), "--compute-metadata"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("mlspaces: error: " + xml + ": line 6: "));
  EXPECT_THAT(r.err, HasSubstr("mlspaces: removed " + computed));
  EXPECT_FALSE(fs::exists(computed));
  EXPECT_THAT(Slurp(lib_ / "assets_index.json"), Not(HasSubstr("neg_tet")));
  EXPECT_EQ(RunCli({"validate", lib_.string()}).out, lib_.string() + ": OK\n");
}

TEST_F(IndexCliTest, ValidateExample) {
  const std::string dir =
      (fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "asset_library").string();
  CliResult r = RunCli({"validate", dir});
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_EQ(r.out, dir + ": OK\n");
}

TEST_F(IndexCliTest, ValidateReportsProblems) {
  ASSERT_EQ(RunCli({"index-assets", lib_.string()}).exit_code, 0);
  ASSERT_EQ(RunCli({"index-grasps", lib_.string()}).exit_code, 0);
  WriteText(lib_ / "red_block/red_block.json", R"({"mass": "heavy", "synset": "block.n.01"})");
  fs::remove(lib_ / "red_block/red_block.xml");
  CliResult r = RunCli({"validate", lib_.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out,
            (lib_ / "assets_index.json").string() + ": /red_block/object_path: file not found: " +
                (lib_ / "red_block/red_block.xml").string() + "\n" +
                (lib_ / "red_block/red_block.json").string() +
                ": /mass: expected number, got string\n" + "2 problems in " + lib_.string() + "\n");
}

}  // namespace
}  // namespace mlspaces
