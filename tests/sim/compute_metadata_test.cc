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

// Every path of the index names an existing file.
void ExpectNoDanglingPath(const fs::path& dir) {
  for (const auto& [uid, e] : AssetIndex::Load(dir / "assets_index.json").entries) {
    EXPECT_TRUE(fs::is_regular_file(dir / e.object_path)) << e.object_path;
    EXPECT_TRUE(fs::is_regular_file(dir / e.metadata_path)) << e.metadata_path;
  }
}

TEST_F(ComputeMetadata, WritesComputedFilesLeavesFailuresOutAndIndexes) {
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
  EXPECT_EQ(r.failures[0].path, (dir_ / "broken/broken.xml").string());
  EXPECT_EQ(r.failures[0].field, "line 4, element <geom>");
  EXPECT_EQ(r.failures[1].uid, "multi");
  EXPECT_THAT(r.failures[1].ToString(), HasSubstr("multi.xml: expected a single body"));
  EXPECT_TRUE(r.removed.empty());

  // Source keys in order, then mass, boundingBox, aabb, and what it was computed from.
  std::string red = ReadFile(dir_ / "red_block/red_block_computed.json");
  EXPECT_THAT(red, HasSubstr("    \"synset\": \"block.n.01\",\n    \"mass\": 0.12500000000000003,\n"
                             "    \"boundingBox\": {\n        \"x\": 0.05,"));
  Json given = ParseJsonFile(dir_ / "given/given_computed.json");
  EXPECT_EQ(given["mass"], 3.5);  // the user's values are kept
  EXPECT_EQ(given["boundingBox"]["z"], 3);
  EXPECT_DOUBLE_EQ(given["aabb"]["max"][0].get<double>(), 0.1);
  // neg_tet's texture is not a source: the physics-only compile does not read it.
  Json neg = ParseJsonFile(dir_ / "neg_tet/neg_tet_computed.json");
  EXPECT_EQ(neg["computed_from"]["hash"], "xxh128");
  EXPECT_EQ(neg["computed_from"]["files"],
            (Json{{"neg_tet.json", SourceFileHash(dir_ / "neg_tet/neg_tet.json")},
                  {"neg_tet.obj", SourceFileHash(dir_ / "neg_tet/neg_tet.obj")},
                  {"neg_tet.xml", SourceFileHash(dir_ / "neg_tet/neg_tet.xml")}}));

  // The failed assets are not in the index (no entry for them, no dangling path).
  AssetIndex index = AssetIndex::Load(dir_ / "assets_index.json");
  EXPECT_EQ(index.entries.size(), 3u);
  EXPECT_EQ(r.index.count, 3u);
  EXPECT_EQ(index.entries.at("red_block").metadata_path, "red_block/red_block_computed.json");
  EXPECT_FALSE(index.entries.contains("broken"));
  EXPECT_FALSE(index.entries.contains("multi"));
  ExpectNoDanglingPath(dir_);

  // A second run refuses to replace the index; without overwrite (index removed) it reuses
  // the computed files that match their sources without compiling, and a computed file
  // without a record (not ours) after checking that its asset compiles.
  EXPECT_THROW(ComputeAssetMetadata(dir_, AssetIndexOptions{}, opts), Error);
  fs::remove(dir_ / "assets_index.json");
  WriteFileAtomic(dir_ / "neg_tet/neg_tet_computed.json", "{\"assetId\": \"neg_tet\"}");
  r = ComputeAssetMetadata(dir_, AssetIndexOptions{}, opts);
  EXPECT_EQ(r.reused, 3u);
  EXPECT_EQ(r.computed, 0u);
  EXPECT_EQ(ReadFile(dir_ / "neg_tet/neg_tet_computed.json"), "{\"assetId\": \"neg_tet\"}");
  EXPECT_EQ(ReadFile(dir_ / "red_block/red_block_computed.json"), red);
  index = AssetIndex::Load(dir_ / "assets_index.json");
  EXPECT_EQ(index.entries.at("neg_tet").metadata_path, "neg_tet/neg_tet_computed.json");
  AssetIndexOptions overwrite;
  overwrite.overwrite = true;
  r = ComputeAssetMetadata(dir_, overwrite, opts);
  EXPECT_EQ(r.computed, 3u);
  EXPECT_TRUE(ParseJsonFile(dir_ / "neg_tet/neg_tet_computed.json").contains("mass"));

  // A changed source makes a computed file of ours stale: it is computed again.
  fs::remove(dir_ / "assets_index.json");
  WriteFileAtomic(dir_ / "given/given.json", "{\"assetId\": \"given\", \"mass\": 4}");
  r = ComputeAssetMetadata(dir_, AssetIndexOptions{}, opts);
  EXPECT_EQ(r.computed, 1u);
  EXPECT_EQ(r.reused, 2u);
  EXPECT_EQ(ParseJsonFile(dir_ / "given/given_computed.json")["mass"], 4);
}

// Malformed metadata JSON: reported with its file and line, left out of the index.
TEST_F(ComputeMetadata, MalformedMetadataJsonIsLeftOut) {
  fs::remove_all(dir_ / "broken");
  fs::remove_all(dir_ / "multi");
  WriteFileAtomic(dir_ / "given/given.json", "{\"assetId\": \"given\",\n");
  WriteFileAtomic(dir_ / "neg_tet/neg_tet.json", "[1, 2]");
  ComputeMetadataReport r = ComputeAssetMetadata(dir_, AssetIndexOptions{});
  ASSERT_EQ(r.failures.size(), 2u);
  EXPECT_EQ(r.failures[0].path, (dir_ / "given/given.json").string());
  EXPECT_THAT(r.failures[0].field, HasSubstr("line 2"));
  EXPECT_THAT(r.failures[0].message, HasSubstr("invalid JSON"));
  EXPECT_EQ(r.failures[1].ToString(),
            (dir_ / "neg_tet/neg_tet.json").string() + ": /: expected object, got array");
  EXPECT_FALSE(fs::exists(dir_ / "given/given_computed.json"));
  AssetIndex index = AssetIndex::Load(dir_ / "assets_index.json");
  EXPECT_EQ(index.entries.size(), 1u);
  EXPECT_TRUE(index.entries.contains("red_block"));
  ExpectNoDanglingPath(dir_);
}

// A broken mesh under a computed file of an earlier run: the old file is not kept standing in
// for the failed compute (ours is deleted, anyone else's left alone but not indexed), and the
// compile check of validate names the asset.
TEST_F(ComputeMetadata, BrokenMeshWithOldComputedFile) {
  fs::remove_all(dir_ / "broken");
  fs::remove_all(dir_ / "multi");
  ComputeMetadataReport r = ComputeAssetMetadata(dir_, AssetIndexOptions{});
  ASSERT_TRUE(r.failures.empty());
  EXPECT_THAT(CompileLibraryAssets(dir_), ::testing::IsEmpty());
  const fs::path computed = dir_ / "neg_tet/neg_tet_computed.json";
  ASSERT_TRUE(fs::exists(computed));
  WriteFileAtomic(dir_ / "neg_tet/neg_tet.obj", "v 0 0 0\n");

  std::vector<Diagnostic> problems = CompileLibraryAssets(dir_);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].uid, "neg_tet");
  EXPECT_EQ(problems[0].path, (dir_ / "neg_tet/neg_tet.xml").string());
  EXPECT_THAT(problems[0].message, HasSubstr("asset 'neg_tet' does not compile: "));

  for (bool overwrite : {false, true}) {
    AssetIndexOptions options;
    options.overwrite = overwrite;
    fs::remove(dir_ / "assets_index.json");
    r = ComputeAssetMetadata(dir_, options);
    ASSERT_EQ(r.failures.size(), 1u) << overwrite;
    EXPECT_EQ(r.failures[0].uid, "neg_tet");
    EXPECT_FALSE(AssetIndex::Load(dir_ / "assets_index.json").entries.contains("neg_tet"));
    ExpectNoDanglingPath(dir_);
    if (!overwrite) {
      EXPECT_EQ(r.removed, std::vector<fs::path>{computed});  // ours: deleted
      EXPECT_FALSE(fs::exists(computed));
      WriteFileAtomic(computed, "{\"mass\": 1}");  // the user's own, for the next round
    } else {
      EXPECT_TRUE(r.removed.empty());
      EXPECT_EQ(ReadFile(computed), "{\"mass\": 1}");  // not ours: left alone
    }
  }
  // Not ours and no --overwrite: kept only for an asset that compiles.
  fs::remove(dir_ / "assets_index.json");
  r = ComputeAssetMetadata(dir_, AssetIndexOptions{});
  ASSERT_EQ(r.failures.size(), 1u);
  EXPECT_FALSE(AssetIndex::Load(dir_ / "assets_index.json").entries.contains("neg_tet"));
  EXPECT_EQ(ReadFile(computed), "{\"mass\": 1}");
}

// An unreadable computed file is not silently replaced or indexed without --overwrite.
TEST_F(ComputeMetadata, CorruptComputedFileIsAFailure) {
  fs::remove_all(dir_ / "broken");
  fs::remove_all(dir_ / "multi");
  WriteFileAtomic(dir_ / "given/given_computed.json", "{oops");
  ComputeMetadataReport r = ComputeAssetMetadata(dir_, AssetIndexOptions{});
  ASSERT_EQ(r.failures.size(), 1u);
  EXPECT_EQ(r.failures[0].path, (dir_ / "given/given_computed.json").string());
  EXPECT_THAT(r.failures[0].message, HasSubstr("use --overwrite"));
  EXPECT_EQ(ReadFile(dir_ / "given/given_computed.json"), "{oops");
  EXPECT_FALSE(AssetIndex::Load(dir_ / "assets_index.json").entries.contains("given"));
}

}  // namespace
}  // namespace mlspaces::sim
