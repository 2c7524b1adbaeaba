// Runs `mlspaces search`: CLIP queries by embedding file and by UID over a store and a user
// library's annotations, word search, --json, the licence policy and bad input.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/npy.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/library/clip_store.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::CliResult;
using ::mlspaces::testing::RunCli;
using ::mlspaces::testing::TempDir;
using ::testing::HasSubstr;

constexpr size_t kDim = 16;

// Asset i's vectors point mostly along axis i % kDim (views slightly apart).
std::vector<double> Vec(size_t axis, double tilt, size_t other) {
  std::vector<double> v(kDim, 0.01);
  v[axis % kDim] = 1.0;
  v[other % kDim] += tilt;
  return v;
}

class SearchCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ClipStoreWriter writer(store_, 3, kDim);
    for (size_t i = 0; i < 12; ++i) {
      std::vector<float> img, text;
      for (size_t v = 0; v < 3; ++v) {
        for (double x : Vec(i, 0.1 * static_cast<double>(v), i + 1)) img.push_back(float(x));
      }
      for (double x : Vec(i, 0.05, i + 2)) text.push_back(static_cast<float>(x));
      writer.Add("obj" + std::to_string(i), img, text);
    }
    writer.Finish();
    // A user library: "mug_nc" has CLIP arrays (along axis 3, like obj3) and a by-nc licence,
    // "plate" has none.
    const fs::path lib = dir_ / "lib";
    Json index = Json::object();
    for (const std::string uid : {"mug_nc", "plate"}) {
      fs::create_directories(lib / uid);
      WriteFileAtomic(lib / uid / (uid + ".xml"), "<mujoco/>");
      Json meta = {{"category", uid == "plate" ? "Plate" : "Coffee mug"},
                   {"description", uid == "plate" ? "a white dinner plate" : "a blue mug"}};
      if (uid == "mug_nc") meta["license_info"] = {{"license", "by-nc"}};
      WriteFileAtomic(lib / uid / (uid + ".json"), meta.dump());
      Json entry = {{"uid", uid},
                    {"object_path", uid + "/" + uid + ".xml"},
                    {"metadata_path", uid + "/" + uid + ".json"},
                    {"metadata_npz_path", nullptr}};
      if (uid == "mug_nc") {
        std::vector<double> img;
        for (int v = 0; v < 3; ++v) {
          for (double x : Vec(3, 0.0, 4)) img.push_back(x);
        }
        WriteNpz(lib / uid / "clip.npz",
                 {{"clip_img_features", NpyArray::FromDoubles(DType::kF4, {3, kDim}, img)},
                  {"clip_text_features", NpyArray::FromDoubles(DType::kF4, {kDim}, Vec(3, 0, 4))}});
        entry["metadata_npz_path"] = uid + "/clip.npz";
      }
      index[uid] = entry;
    }
    WriteFileAtomic(lib / "assets_index.json", index.dump());
    WriteNpyFile((dir_ / "q.npy").string(),
                 NpyArray::FromDoubles(DType::kF2, {kDim}, Vec(3, 0.0, 4)));
  }
  CliResult Search(std::vector<std::string> args, const std::string& env = "") {
    args.insert(args.begin(), {"search", "--clip-store", store_.string(), "--asset-library",
                               "user=" + (dir_ / "lib").string()});
    return RunCli(args, "env -u MLSPACES_ASSETS_DIR -u MLSPACES_LICENSE_POLICY " + env + " ");
  }

  TempDir tmp_;
  const fs::path dir_ = tmp_.path();
  const fs::path store_ = dir_ / "clip_features.mlsc";
};

TEST_F(SearchCliTest, EmbeddingQueryJsonBestFirst) {
  const CliResult r = Search({"--embedding", (dir_ / "q.npy").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("1 annotated assets have no clip_img_features"));
  const Json hits = ParseJson(r.out, "stdout");
  ASSERT_TRUE(hits.is_array());
  ASSERT_GE(hits.size(), 2u);
  // mug_nc's vectors equal the query (score 1.5); obj3's are close behind.
  EXPECT_EQ(hits[0]["uid"], "mug_nc");
  EXPECT_NEAR(hits[0]["score"].get<double>(), 1.5, 2e-3);
  EXPECT_EQ(hits[1]["uid"], "obj3");
  for (size_t i = 0; i < hits.size(); ++i) {
    EXPECT_GE(hits[i]["score"].get<double>(), 0.5);
    if (i > 0) {
      EXPECT_LE(hits[i]["score"].get<double>(), hits[i - 1]["score"].get<double>());
    }
  }
}

TEST_F(SearchCliTest, TopKThresholdPolicyAndUidQuery) {
  CliResult r = Search({"--embedding", (dir_ / "q.npy").string(), "--json", "--top-k", "1"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ParseJson(r.out, "stdout").size(), 1u);
  r = Search({"--embedding", (dir_ / "q.npy").string(), "--json", "--threshold", "1.6"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "[]\n");
  r = Search(
      {"--embedding", (dir_ / "q.npy").string(), "--json", "--license-policy", "commercial_safe"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ParseJson(r.out, "stdout")[0]["uid"], "obj3");
  r = Search({"--embedding", (dir_ / "q.npy").string(), "--json"},
             "MLSPACES_LICENSE_POLICY=commercial_safe");
  EXPECT_EQ(ParseJson(r.out, "stdout")[0]["uid"], "obj3");
  r = Search({"--uid", "obj7", "--json", "--approx"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ParseJson(r.out, "stdout")[0]["uid"], "obj7");
  r = Search({"--uid", "obj7"});  // the table
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("rank  score     uid\n1     "));
}

TEST_F(SearchCliTest, WordSearch) {
  CliResult r = Search({"--text", "MUG plate", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  Json hits = ParseJson(r.out, "stdout");
  ASSERT_EQ(hits.size(), 2u);
  // Both match one word in their category (2 of 4 points); ties by UID.
  EXPECT_EQ(hits[0]["uid"], "mug_nc");
  EXPECT_EQ(hits[1]["uid"], "plate");
  EXPECT_DOUBLE_EQ(hits[0]["score"].get<double>(), 0.5);
  r = Search({"--text", "white dinner plate", "--json"});
  hits = ParseJson(r.out, "stdout");
  ASSERT_EQ(hits.size(), 1u);
  EXPECT_DOUBLE_EQ(hits[0]["score"].get<double>(), 4.0 / 6.0);
  r = Search({"--text", "mug", "--json", "--license-policy", "commercial_safe"});
  EXPECT_EQ(r.out, "[]\n");
}

TEST_F(SearchCliTest, LibrariesYamlAssetsDirFindsTheStore) {
  // No --clip-store, no MLSPACES_ASSETS_DIR: the store comes from the YAML's assets_dir.
  const fs::path assets = dir_ / "yaml_assets";
  const fs::path index = assets / "objects" / "objathor_metadata" / ".mlspaces" / "index";
  fs::create_directories(index);
  fs::copy_file(store_, index / "clip_features.mlsc");
  WriteFileAtomic(dir_ / "libs.yaml", "assets_dir: " + assets.string() + "\n");
  const CliResult r =
      RunCli({"search", "--libraries", (dir_ / "libs.yaml").string(), "--uid", "obj5", "--json"},
             "env -u MLSPACES_ASSETS_DIR -u MLSPACES_LICENSE_POLICY ");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json hits = ParseJson(r.out, "stdout");
  ASSERT_GE(hits.size(), 1u);
  EXPECT_EQ(hits[0]["uid"], "obj5");
  EXPECT_NEAR(hits[0]["score"].get<double>(), 1.5, 2e-3);
}

TEST_F(SearchCliTest, BadInputIsOneLineAndExitCode) {
  CliResult r = Search({"--json"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("exactly one of --uid, --embedding, --text"));
  WriteFileAtomic(dir_ / "bad.npy", "not an npy file");
  r = Search({"--embedding", (dir_ / "bad.npy").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("bad.npy"));
  WriteNpyFile((dir_ / "short.npy").string(),
               NpyArray::FromDoubles(DType::kF4, {3}, std::vector<double>{1, 2, 3}));
  r = Search({"--embedding", (dir_ / "short.npy").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("query has 3 values"));
  r = Search({"--uid", "nope"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("nope"));
  WriteFileAtomic(store_, ReadFile(store_).substr(0, 500));
  r = Search({"--uid", "obj1"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("clip_features.mlsc"));
  r = RunCli({"search", "--help"});
  EXPECT_THAT(r.out, HasSubstr("No text-to-CLIP model"));
}

}  // namespace
}  // namespace mlspaces
