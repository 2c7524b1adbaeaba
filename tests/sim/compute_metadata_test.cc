// Asset facts and --compute-metadata against values worked out by hand.
#include "mlspaces/sim/compute_metadata.h"

#include <cmath>
#include <filesystem>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/sim/asset_facts.h"
#include "test_util.h"

namespace mlspaces::sim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
const fs::path kData = MLSPACES_TESTDATA_DIR;

TEST(AssetFacts, RedBlock) {
  AssetFacts f = ComputeAssetFacts(kData / "custom_assets/asset_library/red_block/red_block.xml");
  EXPECT_EQ(f.mass, 0.12500000000000003);  // 8 * 0.025^3 * 1000 as MuJoCo rounds it
  for (int i = 0; i < 3; ++i) {
    EXPECT_DOUBLE_EQ(f.bounding_box[i], 0.05);
    EXPECT_DOUBLE_EQ(f.aabb_min[i], -0.025);
    EXPECT_DOUBLE_EQ(f.aabb_max[i], 0.025);
  }
}

TEST(AssetFacts, NegativeSideMeshIsBoxedRight) {
  // Tetrahedron (0,0,0), (-0.1,0,0), (0,-0.1,0), (0,0,-0.1): volume 0.1^3 / 6. The original's
  // 2 * max-corner would give 0; the box centred on the origin that holds it is 0.2 wide.
  AssetFacts f = ComputeAssetFacts(kData / "facts/neg_tet/neg_tet.xml");
  EXPECT_NEAR(f.mass, 1000 * 0.001 / 6, 1e-6);  // float vertices in mjModel
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(f.aabb_min[i], -0.1, 1e-7);
    EXPECT_NEAR(f.aabb_max[i], 0.0, 1e-7);
    EXPECT_NEAR(f.bounding_box[i], 0.2, 1e-7);
  }
}

TEST(AssetFacts, FastPathEqualsFullCompile) {
  for (const char* file : {"facts/neg_tet/neg_tet.xml", "facts/rotated_cylinder.xml"}) {
    AssetFacts fast = ComputeAssetFacts(kData / file, true);
    AssetFacts full = ComputeAssetFacts(kData / file, false);
    EXPECT_EQ(fast.mass, full.mass) << file;
    EXPECT_EQ(fast.aabb_min, full.aabb_min) << file;
    EXPECT_EQ(fast.aabb_max, full.aabb_max) << file;
  }
}

TEST(AssetFacts, RotatedCylinderExactExtentsRelativeToBodyOrigin) {
  // Cylinder r 0.1, half-length 0.2, axis turned onto y; sphere r 0.05 at z = -0.3 (mass 0).
  // The body sits at x = 5: the box is relative to the body origin.
  AssetFacts f = ComputeAssetFacts(kData / "facts/rotated_cylinder.xml");
  EXPECT_NEAR(f.mass, 1000 * std::numbers::pi * 0.01 * 0.4, 1e-9);
  std::array<double, 3> lo{-0.1, -0.2, -0.35}, hi{0.1, 0.2, 0.1}, box{0.2, 0.4, 0.7};
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(f.aabb_min[i], lo[i], 1e-12) << i;
    EXPECT_NEAR(f.aabb_max[i], hi[i], 1e-12) << i;
    EXPECT_NEAR(f.bounding_box[i], box[i], 1e-12) << i;
  }
}

TEST(AssetFacts, MoreThanOneBodyIsAnError) {
  try {
    ComputeAssetFacts(kData / "facts/two_bodies.xml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.message(), HasSubstr("expected a single body"));
    EXPECT_THAT(e.path(), HasSubstr("two_bodies.xml"));
  }
}

class ComputeMetadata : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tmp_ / "library";
    fs::copy(kData / "library", dir_, fs::copy_options::recursive);
  }
  mlspaces::testing::TempDir tmp_;
  fs::path dir_;
};

TEST_F(ComputeMetadata, WritesComputedFilesSkipsFailuresAndIndexes) {
  ComputeMetadataOptions opts;
  opts.threads = 2;
  size_t calls = 0;
  opts.progress = [&](size_t done, size_t total) {
    ++calls;
    EXPECT_LE(done, total);
  };
  ComputeMetadataReport r = ComputeAssetMetadata(dir_, AssetIndexOptions{}, opts);
  EXPECT_EQ(calls, 5u);
  EXPECT_EQ(r.computed, 3u);
  ASSERT_EQ(r.failures.size(), 2u);
  EXPECT_EQ(r.failures[0].uid, "broken");
  EXPECT_THAT(r.failures[0].message, HasSubstr("broken.xml: line 4, element <geom>"));
  EXPECT_EQ(r.failures[1].uid, "multi");
  EXPECT_THAT(r.failures[1].message, HasSubstr("expected a single body"));

  // Source keys in order, then mass, boundingBox, aabb.
  std::string red = ReadFile(dir_ / "red_block/red_block_computed.json");
  EXPECT_THAT(red, HasSubstr("    \"synset\": \"block.n.01\",\n    \"mass\": 0.12500000000000003,\n"
                             "    \"boundingBox\": {\n        \"x\": 0.05,"));
  Json given = ParseJsonFile(dir_ / "given/given_computed.json");
  EXPECT_EQ(given["mass"], 3.5);  // the user's values are kept
  EXPECT_EQ(given["boundingBox"]["z"], 3);
  EXPECT_DOUBLE_EQ(given["aabb"]["max"][0].get<double>(), 0.1);

  AssetIndex index = AssetIndex::Load(dir_ / "assets_index.json");
  EXPECT_EQ(index.entries.size(), 5u);
  EXPECT_EQ(index.entries.at("red_block").metadata_path, "red_block/red_block_computed.json");
  EXPECT_EQ(index.entries.at("broken").metadata_path, "broken/broken.json");

  // A second run refuses to replace the index; with overwrite it reuses nothing, and without
  // overwrite (index removed) it reuses the computed files and keeps them in the index.
  EXPECT_THROW(ComputeAssetMetadata(dir_, AssetIndexOptions{}, opts), Error);
  fs::remove(dir_ / "assets_index.json");
  WriteFileAtomic(dir_ / "neg_tet/neg_tet_computed.json", "{\"assetId\": \"neg_tet\"}");
  r = ComputeAssetMetadata(dir_, AssetIndexOptions{}, opts);
  EXPECT_EQ(r.reused, 3u);
  EXPECT_EQ(r.computed, 0u);
  EXPECT_EQ(ReadFile(dir_ / "neg_tet/neg_tet_computed.json"), "{\"assetId\": \"neg_tet\"}");
  index = AssetIndex::Load(dir_ / "assets_index.json");
  EXPECT_EQ(index.entries.at("neg_tet").metadata_path, "neg_tet/neg_tet_computed.json");
  AssetIndexOptions overwrite;
  overwrite.overwrite = true;
  r = ComputeAssetMetadata(dir_, overwrite, opts);
  EXPECT_EQ(r.computed, 3u);
  EXPECT_TRUE(ParseJsonFile(dir_ / "neg_tet/neg_tet_computed.json").contains("mass"));
}

}  // namespace
}  // namespace mlspaces::sim
