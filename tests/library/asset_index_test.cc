#include "mlspaces/library/asset_index.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <optional>
#include <set>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/library/grasp_index.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ErrorOf;
using ::mlspaces::testing::ExampleLibrary;
using ::mlspaces::testing::ListFiles;
using ::mlspaces::testing::MinimalMetadata;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using ::testing::HasSubstr;

// What MolmoSpaces' generator writes for the example after --compute-metadata.
constexpr char kExampleIndex[] =
    "{\n"
    "    \"red_block\": {\n"
    "        \"uid\": \"red_block\",\n"
    "        \"object_path\": \"red_block/red_block.xml\",\n"
    "        \"metadata_path\": \"red_block/red_block_computed.json\",\n"
    "        \"metadata_npz_path\": null\n"
    "    }\n"
    "}";

void AddAsset(const fs::path& root, const std::string& rel_dir, const std::string& uid,
              bool npz = false) {
  WriteText(root / rel_dir / (uid + ".xml"), "<mujoco/>\n");
  WriteText(root / rel_dir / (uid + ".json"), MinimalMetadata(uid));
  if (npz) WriteText(root / rel_dir / (uid + ".npz"), "");
}

TEST(AssetIndexTest, ExampleGoldenWithComputedMetadata) {
  IndexReport report;
  AssetIndex index = BuildAssetIndex(ExampleLibrary(), {}, &report, /*use_computed=*/true);
  EXPECT_EQ(report.count, 1u);
  EXPECT_TRUE(report.warnings.empty());
  EXPECT_EQ(index.Serialize(), kExampleIndex);
  EXPECT_EQ(index.Serialize(), ReadFile(ExampleLibrary() / "assets_index.json"));
}

TEST(AssetIndexTest, WithoutComputedUsesPlainJson) {
  AssetIndex index = BuildAssetIndex(ExampleLibrary(), {}, nullptr);
  ASSERT_EQ(index.entries.size(), 1u);
  const AssetEntry& e = index.entries.at("red_block");
  EXPECT_EQ(e.metadata_path, "red_block/red_block.json");
  EXPECT_EQ(e.object_path, "red_block/red_block.xml");
  EXPECT_FALSE(e.metadata_npz_path.has_value());
}

TEST(AssetIndexTest, LoadExample) {
  AssetIndex index = AssetIndex::Load(ExampleLibrary() / "assets_index.json");
  ASSERT_EQ(index.entries.size(), 1u);
  AssetEntry expected{"red_block", "red_block/red_block.xml", "red_block/red_block_computed.json",
                      std::nullopt};
  EXPECT_EQ(index.entries.at("red_block"), expected);
  EXPECT_EQ(index.Serialize(), kExampleIndex);
}

TEST(AssetIndexTest, SerializeEmptyAndSortedAndEscaped) {
  AssetIndex index;
  EXPECT_EQ(index.Serialize(), "{}");
  index.entries["b"] = {"b", "b/b.xml", "b/b.json", "b/b.npz"};
  index.entries["a\"q"] = {"a\"q", "x/a\"q.xml", "x/a\"q.json", std::nullopt};
  index.entries["\xc3\xa9t\xc3\xa9"] = {"\xc3\xa9t\xc3\xa9", "e.xml", "e.json", std::nullopt};
  std::string text = index.Serialize();
  // Code-point order: "a\"q" < "b" < "été"; UTF-8 kept as is (pydantic), quotes escaped.
  EXPECT_LT(text.find("\"a\\\"q\": {"), text.find("\"b\": {"));
  EXPECT_LT(text.find("\"b\": {"), text.find("\"\xc3\xa9t\xc3\xa9\": {"));
  EXPECT_THAT(text, HasSubstr("\"metadata_npz_path\": \"b/b.npz\""));
  EXPECT_NE(text.back(), '\n');
  TempDir tmp;
  WriteText(tmp / "assets_index.json", text);
  EXPECT_EQ(AssetIndex::Load(tmp / "assets_index.json").entries, index.entries);
}

TEST(AssetIndexTest, LoadAcceptsExtraKeysAndMismatchedUid) {
  TempDir tmp;
  WriteText(tmp / "assets_index.json",
            R"({"k": {"uid": "other", "object_path": "k.xml", "metadata_path": "k.json",
                      "metadata_npz_path": "k.npz", "extra": 3}})");
  AssetIndex index = AssetIndex::Load(tmp / "assets_index.json");
  EXPECT_EQ(index.entries.at("k").uid, "other");
  EXPECT_EQ(index.entries.at("k").metadata_npz_path, "k.npz");
}

TEST(AssetIndexTest, LoadReportsFileAndPointer) {
  TempDir tmp;
  const fs::path file = tmp / "assets_index.json";
  const std::string f = file.string();
  WriteText(file, R"({"red_block": {"uid": "red_block", "object_path": 7,
      "metadata_path": "a.json", "metadata_npz_path": null}})");
  EXPECT_EQ(ErrorOf([&] { AssetIndex::Load(file); }),
            f + ": /red_block/object_path: expected string, got number");

  WriteText(file, R"({"a/b": {"uid": "a", "object_path": "a.xml", "metadata_path": "a.json"}})");
  EXPECT_EQ(ErrorOf([&] { AssetIndex::Load(file); }),
            f + ": /a~1b/metadata_npz_path: missing required field (string or null)");

  WriteText(file, R"({"a": {"uid": "a", "object_path": "a.xml", "metadata_path": "a.json",
      "metadata_npz_path": false}})");
  EXPECT_EQ(ErrorOf([&] { AssetIndex::Load(file); }),
            f + ": /a/metadata_npz_path: expected string or null, got boolean");

  WriteText(file, R"({"a": {"object_path": "a.xml"}})");
  EXPECT_EQ(ErrorOf([&] { AssetIndex::Load(file); }), f + ": /a/uid: missing required field");

  WriteText(file, R"({"a": []})");
  EXPECT_EQ(ErrorOf([&] { AssetIndex::Load(file); }), f + ": /a: expected object, got array");

  WriteText(file, R"([1])");
  EXPECT_EQ(ErrorOf([&] { AssetIndex::Load(file); }), f + ": /: expected object, got array");
}

TEST(AssetIndexTest, LoadMalformedJsonNamesFileAndLine) {
  TempDir tmp;
  const fs::path file = tmp / "assets_index.json";
  WriteText(file, "{\n  \"a\": {\n    \"uid\": \"a\",,\n  }\n}");
  std::string what = ErrorOf([&] { AssetIndex::Load(file); });
  EXPECT_THAT(what, HasSubstr(file.string()));
  EXPECT_THAT(what, HasSubstr("line 3"));
  EXPECT_THAT(ErrorOf([&] { AssetIndex::Load(tmp / "missing.json"); }),
              HasSubstr((tmp / "missing.json").string()));
}

TEST(AssetIndexTest, BuildSortsNestsAndFindsNpz) {
  TempDir tmp;
  const fs::path root = tmp / "lib";
  AddAsset(root, "z", "zeta");
  AddAsset(root, "a/deep/er", "alpha", /*npz=*/true);
  AddAsset(root, "", "top");
  WriteText(root / "readme.txt", "not an asset");
  IndexReport report;
  AssetIndex index = BuildAssetIndex(root, {}, &report);
  EXPECT_EQ(report.count, 3u);
  ASSERT_EQ(index.entries.size(), 3u);
  EXPECT_EQ(index.entries.at("alpha").object_path, "a/deep/er/alpha.xml");
  EXPECT_EQ(index.entries.at("alpha").metadata_npz_path, "a/deep/er/alpha.npz");
  EXPECT_EQ(index.entries.at("top").object_path, "top.xml");
  EXPECT_EQ(index.entries.at("zeta").metadata_path, "z/zeta.json");
  EXPECT_FALSE(index.entries.at("zeta").metadata_npz_path.has_value());
}

TEST(AssetIndexTest, SymlinkedFoldersAreNotFollowed) {
  TempDir tmp;
  AddAsset(tmp / "outside", "", "hidden");
  AddAsset(tmp / "lib", "real", "real");
  fs::create_directory_symlink(tmp / "outside", tmp / "lib" / "link");
  AssetIndex index = BuildAssetIndex(tmp / "lib", {}, nullptr);
  EXPECT_EQ(index.entries.size(), 1u);
  EXPECT_TRUE(index.entries.contains("real"));
}

TEST(AssetIndexTest, MissingMetadataIsAnErrorUnlessSuppressed) {
  TempDir tmp;
  const fs::path root = fs::weakly_canonical(tmp.path()) / "lib";
  AddAsset(root, "ok", "ok");
  WriteText(root / "inc" / "include.xml", "<mujoco/>");
  EXPECT_EQ(ErrorOf([&] { BuildAssetIndex(root, {}, nullptr); }),
            "Expected metadata JSON for " + (root / "inc/include.xml").string() + " at " +
                (root / "inc/include.json").string() + ", but it was not found.");
  AssetIndexOptions options;
  options.suppress_missing_metadata = true;
  IndexReport report;
  AssetIndex index = BuildAssetIndex(root, options, &report);
  EXPECT_EQ(index.entries.size(), 1u);
  ASSERT_EQ(report.warnings.size(), 1u);
  const Diagnostic& w = report.warnings[0];
  EXPECT_EQ(w.path, (root / "inc/include.xml").string());
  EXPECT_EQ(w.field, "");
  EXPECT_EQ(w.uid, "include");
  EXPECT_EQ(w.severity, Severity::kWarning);
  EXPECT_EQ(IndexWarningLine(w),
            "Warning: Expected metadata JSON for " + (root / "inc/include.xml").string() + " at " +
                (root / "inc/include.json").string() + ", but it was not found. Skipping.");
}

TEST(AssetIndexTest, DuplicateUidNamesBothFiles) {
  TempDir tmp;
  AddAsset(tmp / "lib", "a", "block");
  AddAsset(tmp / "lib", "b/c", "block");
  EXPECT_EQ(ErrorOf([&] { BuildAssetIndex(tmp / "lib", {}, nullptr); }),
            "Duplicate asset id 'block' found at b/c/block.xml and a/block.xml.");
}

TEST(AssetIndexTest, BrokenSymlinkIsAnError) {
  TempDir tmp;
  const fs::path root = fs::weakly_canonical(tmp.path()) / "lib";
  AddAsset(root, "a", "a");
  WriteText(root / "b/b.json", MinimalMetadata("b"));
  fs::create_symlink(tmp / "gone.xml", root / "b/b.xml");
  EXPECT_EQ(ErrorOf([&] { WriteAssetIndex(root, {}); }),
            (root / "b/b.xml").string() + ": broken symbolic link: its target does not exist");
  EXPECT_FALSE(fs::exists(root / "assets_index.json"));
  WriteText(tmp / "gone.xml", "<mujoco/>");
  EXPECT_EQ(BuildAssetIndex(root, {}, nullptr).entries.at("b").object_path, "b/b.xml");
}

// The record of a computed file: sources relative to its folder, XXH3-128 as xxh128sum prints
// it; a change, a missing source or a malformed record is a problem naming the field.
TEST(AssetIndexTest, ComputedFromRecordAndCheck) {
  TempDir tmp;
  WriteText(tmp / "empty", "");
  WriteText(tmp / "a/x.json", "abc");
  EXPECT_EQ(SourceFileHash(tmp / "empty"), "99aa06d3014798d86001c324468d497f");
  EXPECT_EQ(SourceFileHash(tmp / "a/x.json"), "06b05ab6733a618578af5f94892f3950");
  EXPECT_THAT(ErrorOf([&] { SourceFileHash(tmp / "nope"); }),
              HasSubstr((tmp / "nope").string() + ": cannot read"));

  const fs::path computed = tmp / "a/x_computed.json";
  Json record = ComputedFromRecord(computed, {tmp / "a/x.json", tmp / "empty"});
  EXPECT_EQ(record.dump(),
            R"({"hash":"xxh128","files":{"../empty":"99aa06d3014798d86001c324468d497f",)"
            R"("x.json":"06b05ab6733a618578af5f94892f3950"}})");
  Json meta = {{"mass", 1}, {"computed_from", record}};
  EXPECT_FALSE(CheckComputedFrom(computed, Json{{"mass", 1}}).has_value());  // not ours
  ASSERT_TRUE(CheckComputedFrom(computed, meta).has_value());
  EXPECT_TRUE(CheckComputedFrom(computed, meta)->empty());

  WriteText(tmp / "a/x.json", "abd");
  fs::remove(tmp / "empty");
  std::vector<std::string> problems;
  std::optional<std::vector<Diagnostic>> check = CheckComputedFrom(computed, meta);
  ASSERT_TRUE(check.has_value());
  for (const Diagnostic& d : *check) problems.push_back(d.ToString());
  const std::string c = computed.string();
  EXPECT_THAT(
      problems,
      ::testing::ElementsAre(
          c + ": /computed_from/files/..~1empty: source file not found: " +
              (tmp / "empty").string() + " (run mlspaces index-assets --compute-metadata again)",
          c + ": /computed_from/files/x.json: stale: " + (tmp / "a/x.json").string() +
              " changed since this file was computed (run mlspaces index-assets "
              "--compute-metadata again)"));
  meta["computed_from"] = "yes";
  EXPECT_EQ(CheckComputedFrom(computed, meta)->at(0).ToString(),
            c + ": /computed_from: expected object, got string");
}

TEST(AssetIndexTest, MissingSourceFolderIsAnError) {
  TempDir tmp;
  EXPECT_THAT(ErrorOf([&] { WriteAssetIndex(tmp / "nope", {}); }), HasSubstr("not found"));
  EXPECT_FALSE(fs::exists(tmp / "nope"));
}

TEST(AssetIndexTest, WriteRefusesExistingOutputBeforeScanning) {
  TempDir tmp;
  const fs::path root = fs::weakly_canonical(tmp.path()) / "lib";
  AddAsset(root, "a", "a");
  WriteText(root / "stray.xml", "<mujoco/>");  // would fail the scan
  WriteText(root / "assets_index.json", "old");
  EXPECT_EQ(
      ErrorOf([&] { WriteAssetIndex(root, {}); }),
      (root / "assets_index.json").string() + " already exists. Use --overwrite to overwrite.");
  EXPECT_EQ(ReadFile(root / "assets_index.json"), "old");
  // A failing scan with --overwrite leaves the old file and no temp files.
  AssetIndexOptions options;
  options.overwrite = true;
  EXPECT_THAT(ErrorOf([&] { WriteAssetIndex(root, options); }),
              HasSubstr("Expected metadata JSON"));
  EXPECT_EQ(ReadFile(root / "assets_index.json"), "old");
  fs::remove(root / "stray.xml");
  IndexReport report = WriteAssetIndex(root, options);
  EXPECT_EQ(report.count, 1u);
  EXPECT_EQ(report.output, root / "assets_index.json");
  EXPECT_EQ(ListFiles(root), (std::set<std::string>{"a/a.xml", "a/a.json", "assets_index.json"}));
  EXPECT_EQ(AssetIndex::Load(root / "assets_index.json").entries.at("a").object_path, "a/a.xml");
}

TEST(AssetIndexTest, WriteToCustomOutputCreatesFolders) {
  TempDir tmp;
  AddAsset(tmp / "lib", "a", "a");
  AssetIndexOptions options;
  options.output = tmp / "out" / "sub" / "index.json";
  IndexReport report = WriteAssetIndex(tmp / "lib", options);
  EXPECT_EQ(report.count, 1u);
  EXPECT_EQ(AssetIndex::Load(options.output).entries.at("a").metadata_path, "a/a.json");
}

// 10,000 assets and 10,000 grasp files in one folder, as the benchmark uses.
TEST(AssetIndexScaleTest, TenThousandAssetsAndGrasps) {
  TempDir tmp;
  const fs::path root = tmp / "lib";
  // One tiny valid grasp npz, copied as raw bytes.
  const double eye[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  WriteNpz(tmp / "g.npz", {{"transforms", NpyArray::FromDoubles({1, 4, 4}, eye)}});
  const std::string grasp_bytes = ReadFile(tmp / "g.npz");
  WriteText(tmp / "t.xml", "<mujoco/>");
  WriteText(tmp / "t.json", MinimalMetadata("any"));
  fs::create_directories(root);
  // Folders and hard links with raw syscalls: creating 50,000 entries is slow enough on some
  // filesystems without the extra stats of create_directories and ofstream.
  auto mkdir = [](const fs::path& p) { ASSERT_EQ(::mkdir(p.c_str(), 0755), 0) << p; };
  auto link = [](const fs::path& from, const fs::path& to) {
    ASSERT_EQ(::link(from.c_str(), to.c_str()), 0) << to;
  };
  constexpr int kN = 10000;
  char uid[32];
  for (int i = 0; i < kN; ++i) {
    std::snprintf(uid, sizeof uid, "asset_%05d", i);
    const fs::path d = root / uid;
    mkdir(d);
    mkdir(d / "droid");
    link(tmp / "t.xml", d / (std::string(uid) + ".xml"));
    link(tmp / "t.json", d / (std::string(uid) + ".json"));
    if (i % 10 == 0) link(tmp / "g.npz", d / (std::string(uid) + ".npz"));
    link(tmp / "g.npz", d / "droid" / "grasps.npz");
  }
  AssetIndexOptions options;
  IndexReport report = WriteAssetIndex(root, options);
  EXPECT_EQ(report.count, static_cast<size_t>(kN));
  AssetIndex index = AssetIndex::Load(root / "assets_index.json");
  ASSERT_EQ(index.entries.size(), static_cast<size_t>(kN));
  EXPECT_EQ(index.entries.at("asset_00000").metadata_npz_path, "asset_00000/asset_00000.npz");
  EXPECT_FALSE(index.entries.at("asset_00001").metadata_npz_path.has_value());
  EXPECT_EQ(index.entries.at("asset_09999").object_path, "asset_09999/asset_09999.xml");
  EXPECT_EQ(index.entries.begin()->first, "asset_00000");
  EXPECT_EQ(index.entries.rbegin()->first, "asset_09999");
  EXPECT_EQ(index.Serialize(), ReadFile(root / "assets_index.json"));

  IndexReport grasps = WriteGraspIndex(root, {});
  EXPECT_EQ(grasps.robots, 1u);
  EXPECT_EQ(grasps.count, static_cast<size_t>(kN));
  GraspIndex gindex = GraspIndex::Load(root / "grasps_index.json");
  ASSERT_EQ(gindex.grasp_paths.at("droid").size(), static_cast<size_t>(kN));
  EXPECT_EQ(gindex.grasp_paths.at("droid").at("asset_04242"), "asset_04242/droid/grasps.npz");
  EXPECT_TRUE(gindex.articulated_grasp_paths.empty());
  EXPECT_EQ(gindex.Serialize(), ReadFile(root / "grasps_index.json"));
}

}  // namespace
}  // namespace mlspaces
