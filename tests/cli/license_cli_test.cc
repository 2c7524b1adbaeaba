// `mlspaces license`: records as the original prints them, user libraries, --json, --list-all,
// and errors (exit 1 for bad data, 2 for bad usage), on the tutorial library copied here.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "mlspaces/core/json.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::RunCli;
using testing::TempDir;
using testing::WriteText;

class LicenseCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(tmp_ / "lib");
    lib_ = testing::CopyExampleLibrary(tmp_ / "lib");
    // A second asset whose metadata carries license_info (by-nc-sa, a Sketchfab creator).
    Json meta = ParseJsonFile(lib_ / "red_block/red_block.json");
    meta["assetId"] = "nc_block";
    meta["license_info"] = Json{
        {"license", "by-nc-sa"}, {"creator_username", "bob"}, {"creator_display_name", "Bob B"}};
    WriteText(lib_ / "nc_block/nc_block.xml", "<mujoco/>");
    WriteText(lib_ / "nc_block/nc_block.json", meta.dump(4));
    Json index = ParseJsonFile(lib_ / "assets_index.json");
    index["nc_block"] = Json{{"uid", "nc_block"},
                             {"object_path", "nc_block/nc_block.xml"},
                             {"metadata_path", "nc_block/nc_block.json"},
                             {"metadata_npz_path", nullptr}};
    WriteText(lib_ / "assets_index.json", index.dump(4));
    WriteText(tmp_ / "assets/objects/thor/mjthor_resource_file_to_size_mb.json",
              R"({"thor_Cup_2.tar.zst": 1, "thor_Bowl_1.tar.zst": 2})");
    env_ = "env MLSPACES_ASSETS_DIR=" + testing::ShellQuote((tmp_ / "assets").string()) +
           " MLSPACES_CACHE_DIR=" + testing::ShellQuote((tmp_ / "cache").string()) + " ";
  }

  testing::CliResult License(std::vector<std::string> args) {
    args.insert(args.begin(), "license");
    args.push_back("--asset-library");
    args.push_back("custom_assets=" + lib_.string());
    return RunCli(args, env_);
  }

  TempDir tmp_;
  fs::path lib_;
  std::string env_;
};

TEST_F(LicenseCliTest, PrintsRecordsAsTheOriginal) {
  const testing::CliResult nc = License({"nc_block"});
  ASSERT_EQ(nc.exit_code, 0) << nc.err;
  // json.dumps(indent=2): two-space indent, "key": value.
  EXPECT_THAT(nc.out, HasSubstr("{\n  \"data_type\": \"objects\",\n  \"data_source\": "
                                "\"custom_assets\",\n  \"asset_id\": \"nc_block\","));
  const Json record = ParseJson(nc.out, "stdout");
  EXPECT_EQ(record["license"], "CC-BY-NC-SA-4.0");
  EXPECT_EQ(record["commercial_use"], false);
  EXPECT_EQ(record["attribution"],
            "Model by Bob B (bob), licensed under CC BY-NC-SA 4.0. Non-commercial use only.");

  const testing::CliResult both = License({"red_block", "nc_block", "--json"});
  ASSERT_EQ(both.exit_code, 0) << both.err;
  const Json all = ParseJson(both.out, "stdout");
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0]["license"], "unknown");
  EXPECT_EQ(all[1]["asset_id"], "nc_block");

  const testing::CliResult thor = License({"Bowl", "--source", "thor"});
  ASSERT_EQ(thor.exit_code, 0) << thor.err;
  EXPECT_EQ(ParseJson(thor.out, "stdout")["asset_id_or_archive_name"], "Bowl_1");

  const testing::CliResult list = License({"--list-all", "--source", "thor"});
  ASSERT_EQ(list.exit_code, 0) << list.err;
  EXPECT_EQ(ParseJson(list.out, "stdout"), Json::parse(R"(["Bowl_1", "Cup_2"])"));

  const testing::CliResult robot = License({"franka_droid", "--type", "robots"});
  ASSERT_EQ(robot.exit_code, 0) << robot.err;
  EXPECT_EQ(ParseJson(robot.out, "stdout")["license"], "Apache 2.0");
}

TEST_F(LicenseCliTest, ErrorsAreOneLine) {
  const testing::CliResult unknown = License({"nope"});
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_THAT(unknown.err,
              HasSubstr("nope not found in asset libraries [thor, objaverse, objathor_metadata, "
                        "custom_assets]; give --source"));
  EXPECT_EQ(std::count(unknown.err.begin(), unknown.err.end(), '\n'), 1) << unknown.err;

  const testing::CliResult missing = License({"Plate", "--source", "thor"});
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr("identifier='Plate' is not in source='thor' "
                                     "(data_type='objects'); 2 identifiers: Bowl_1, Cup_2"));

  const testing::CliResult other = License({"red_block", "--source", "mystery"});
  EXPECT_EQ(other.exit_code, 1);
  EXPECT_THAT(other.err, HasSubstr("Can't determine license for `objects` with "
                                   "data_source='mystery' and identifier='red_block'"));

  EXPECT_EQ(License({"x", "--type", "textures"}).exit_code, 2);
  const testing::CliResult no_source = License({"5", "--type", "scenes"});
  EXPECT_EQ(no_source.exit_code, 2);
  EXPECT_THAT(no_source.err, HasSubstr("needs --source"));
}

}  // namespace
}  // namespace mlspaces
