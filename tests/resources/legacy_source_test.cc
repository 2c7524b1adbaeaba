// MolmoSpaces-format sources: a source installed the way the ORIGINAL resource manager does
// (size manifest, tries, extracted archives, extraction flags, none of our stores) gets a UID
// index from its tries, and the Registry and the CLI answer lookups from that index.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "library_fixture.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/library/packed_store.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/resources/archive.h"
#include "mlspaces/resources/legacy_source.h"
#include "mlspaces/resources/pack.h"
#include "mlspaces/resources/package.h"
#include "test_util.h"

namespace mlspaces {
namespace {
namespace fs = std::filesystem;
using ::testing::ElementsAre;
using testing::ExpectError;
using testing::FixtureUid;
using ::testing::HasSubstr;
using ::testing::Not;
using testing::RunCli;
using testing::ShellQuote;
using testing::Slurp;
using testing::TempDir;
using testing::WriteText;

constexpr size_t kAssets = 12;  // 4 archives of 3

std::string Gzip(const std::string& data, int level = Z_DEFAULT_COMPRESSION) {
  z_stream zs{};
  EXPECT_EQ(deflateInit2(&zs, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&zs, data.size()) + 64, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  zs.avail_in = static_cast<uInt>(data.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

void WriteTries(const fs::path& version_dir, const std::string& json) {
  WriteText(version_dir / std::string(kTriesFile), Gzip(json));
}

/// Installs `package` (a remote version folder written by pack) into `version_dir` the way
/// MolmoSpaces' resource manager does: its size manifest and tries, every archive extracted
/// and flagged. Our stores and manifest are NOT copied.
void InstallLikeTheOriginal(const fs::path& package, const fs::path& version_dir,
                            const fs::path& staging_root) {
  fs::create_directories(version_dir);
  for (std::string_view f : {kSizeManifestFile, kTriesFile}) {
    fs::copy_file(package / std::string(f), version_dir / std::string(f));
  }
  const FlatJson sizes = ParseFlatJsonFile(version_dir / std::string(kSizeManifestFile));
  ASSERT_FALSE(sizes.empty());
  for (auto it = sizes.begin(); it != sizes.end(); ++it) {
    const std::string& archive = it.key();
    const fs::path staging = staging_root / archive;
    ExtractTarZst(package / archive, staging);
    for (const auto& e : fs::recursive_directory_iterator(staging)) {
      if (e.is_directory()) continue;
      const fs::path dest = version_dir / e.path().lexically_relative(staging);
      fs::create_directories(dest.parent_path());
      fs::rename(e.path(), dest);
    }
    fs::remove_all(staging);
    WriteText(version_dir / ExtractFlagName(archive), "");
  }
}

class LegacySourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    library = tmp / "library";
    testing::MakeFixtureLibrary(library, kAssets);
    PackOptions options;
    options.name = "fixlib";
    options.version = "1";
    options.assets_per_archive = 3;
    PackLibrary(library, tmp / "remote", options);
    package = tmp / "remote" / "objects" / "fixlib" / "1";
    assets = tmp / "assets";
    fs::create_directories(assets / "objects");
  }

  /// An original-format install of the fixture package as objects/<name>; returns its
  /// version folder in the cache.
  fs::path AddOriginalSource(const std::string& name) {
    fs::path version_dir = tmp / "cache" / "objects" / name / "20251117";
    InstallLikeTheOriginal(package, version_dir, tmp / "staging" / name);
    fs::create_directory_symlink(version_dir, assets / "objects" / name);
    return version_dir;
  }

  Registry Installed() const {
    Registry::Options o;
    o.assets_dir = assets;
    return Registry(o);
  }

  std::string Env() const {
    return "env MLSPACES_ASSETS_DIR=" + ShellQuote(assets.string()) +
           " MLSPACES_PINNED_ASSETS_FILE= ";
  }

  TempDir tmp;
  fs::path library, package, assets;
};

TEST_F(LegacySourceTest, IndexesAnOriginalInstallAndTheRegistryLocatesThroughIt) {
  const fs::path version_dir = AddOriginalSource("objaverse");
  // It looks like the original's install: flags and files, none of our stores.
  ASSERT_TRUE(fs::exists(version_dir / ExtractFlagName("fixlib_00000.tar.zst")));
  ASSERT_TRUE(fs::exists(version_dir / "obj_1000" / "obj_1000.xml"));
  ASSERT_FALSE(fs::exists(version_dir / std::string(kUidIndexFile)));
  ASSERT_FALSE(fs::exists(version_dir / std::string(kPackageManifestFile)));
  // Before indexing, the registry does not treat it as a package.
  EXPECT_EQ(Installed().FindPackedLibrary("objaverse"), nullptr);

  const LegacyIndexReport report = BuildLegacyIndex(version_dir, "objaverse");
  EXPECT_EQ(report.assets, kAssets);
  EXPECT_EQ(report.archives, 4u);
  EXPECT_THAT(report.warnings, ::testing::IsEmpty());
  EXPECT_EQ(report.index_dir, version_dir / std::string(kLegacyIndexDir));
  EXPECT_TRUE(fs::exists(report.index_dir / std::string(kUidIndexFile)));
  EXPECT_TRUE(fs::exists(report.index_dir / std::string(kMetadataStoreFile)));
  EXPECT_FALSE(fs::exists(version_dir / std::string(kUidIndexFile)));
  PackedLibrary::Open(report.index_dir, "objaverse", version_dir)->Check();

  // A file the tries do not list is not found: lookups read the index, not the folders.
  WriteText(version_dir / "stray" / "stray_uid.xml", "<mujoco/>");

  const auto truth = PackedLibrary::Open(package, "fixlib");  // our own package's index
  const Registry registry = Installed();
  ASSERT_NE(registry.FindPackedLibrary("objaverse"), nullptr);
  EXPECT_EQ(registry.FindPackedLibrary("objaverse")->size(), kAssets);
  const fs::path root = assets / "objects" / "objaverse";
  for (size_t i = 0; i < kAssets; ++i) {
    const std::string uid = FixtureUid(i);
    const auto loc = registry.Locate(uid);
    ASSERT_TRUE(loc.has_value()) << uid;
    EXPECT_EQ(loc->library, "objaverse");
    const auto expected = truth->Find(uid);
    ASSERT_TRUE(expected.has_value());
    EXPECT_EQ(loc->archive, truth->archives()[expected->archive]) << uid;
    EXPECT_TRUE(loc->installed) << uid;
    EXPECT_EQ(loc->mjcf_path, root / uid / (uid + ".xml"));
    EXPECT_TRUE(IsFile(loc->mjcf_path)) << loc->mjcf_path;
    EXPECT_TRUE(loc->shadowed.empty());
    EXPECT_EQ(registry.GetAnnotation(uid), nullptr);  // the tries carry no annotations
  }
  EXPECT_FALSE(registry.Locate("stray_uid").has_value());
  EXPECT_FALSE(registry.Locate("obj_100").has_value());  // a key, not a suffix match
  EXPECT_THAT(testing::ErrorOf([&] { registry.LocateOrThrow("nope"); }), HasSubstr("objaverse"));

  // An archive without its flag is reported as not installed.
  fs::remove(version_dir / ExtractFlagName(truth->archives()[truth->Find(FixtureUid(0))->archive]));
  const auto loc = Installed().Locate(FixtureUid(0));
  ASSERT_TRUE(loc.has_value());
  EXPECT_FALSE(loc->installed);

  // Rebuilding gives the same bytes.
  const std::string before = Slurp(report.index_dir / std::string(kUidIndexFile));
  BuildLegacyIndex(version_dir, "objaverse");
  EXPECT_EQ(Slurp(report.index_dir / std::string(kUidIndexFile)), before);
}

TEST_F(LegacySourceTest, ThorComesFirstAheadOfOtherSourcesAndUserLibraries) {
  BuildLegacyIndex(AddOriginalSource("objaverse"), "objaverse");
  BuildLegacyIndex(AddOriginalSource("thor"), "thor");
  Registry registry = Installed();
  registry.RegisterAssetLibrary("mylib", library);  // the same UIDs again
  const std::vector<std::string> libs = registry.asset_libraries();
  ASSERT_FALSE(libs.empty());
  EXPECT_EQ(libs.front(), "thor");
  for (size_t i = 0; i < kAssets; ++i) {
    const auto loc = registry.Locate(FixtureUid(i));
    ASSERT_TRUE(loc.has_value());
    EXPECT_EQ(loc->library, "thor");
    EXPECT_TRUE(loc->installed);
    EXPECT_EQ(loc->mjcf_path.parent_path().parent_path(), assets / "objects" / "thor");
    EXPECT_THAT(loc->shadowed, ElementsAre("objaverse", "mylib"));
  }
}

TEST(ObjectSources, AllFoldersSortedWithTheirKind) {
  TempDir tmp;
  const fs::path objects = tmp / "assets" / "objects";
  WriteText(objects / "b_legacy" / std::string(kTriesFile), "x");
  WriteText(objects / "a_package" / std::string(kUidIndexFile), "x");
  fs::create_directories(objects / "c_other");
  WriteText(tmp / "elsewhere" / std::string(kTriesFile), "x");
  fs::create_directory_symlink(tmp / "elsewhere", objects / "d_link");
  WriteText(objects / "e_file.txt", "not a folder");
  fs::create_directory_symlink(tmp / "gone", objects / "f_dangling");

  const std::vector<ObjectSource> all = FindObjectSources(tmp / "assets", {});
  std::vector<std::string> names;
  names.reserve(all.size());
  for (const ObjectSource& s : all) names.push_back(s.name);
  EXPECT_THAT(names, ElementsAre("a_package", "b_legacy", "c_other", "d_link"));
  EXPECT_EQ(all[0].kind, ObjectSource::Kind::kPackage);
  EXPECT_EQ(all[1].kind, ObjectSource::Kind::kLegacy);
  EXPECT_EQ(all[2].kind, ObjectSource::Kind::kOther);
  EXPECT_EQ(all[3].kind, ObjectSource::Kind::kLegacy);
  EXPECT_EQ(all[3].root, objects / "d_link");

  // Named: in the order given; each must be a source.
  const std::vector<ObjectSource> named =
      FindObjectSources(tmp / "assets", {"d_link", "a_package"});
  ASSERT_EQ(named.size(), 2u);
  EXPECT_EQ(named[0].name, "d_link");
  EXPECT_EQ(named[1].kind, ObjectSource::Kind::kPackage);
  ExpectError([&] { FindObjectSources(tmp / "assets", {"c_other"}); },
              {(objects / "c_other").string(), "not a MolmoSpaces-format source"});
  ExpectError([&] { FindObjectSources(tmp / "assets", {"f_dangling"}); },
              {(objects / "f_dangling").string(), "no such source"});
  EXPECT_THROW(FindObjectSources(tmp / "assets", {"../x"}), UsageError);
  EXPECT_THROW(FindObjectSources(tmp / "assets", {""}), UsageError);
  ExpectError([&] { FindObjectSources(tmp / "nowhere", {}); },
              {(tmp / "nowhere" / "objects").string(), "no objects folder"});
  fs::remove_all(objects);
  fs::create_directories(objects);
  EXPECT_TRUE(FindObjectSources(tmp / "assets", {}).empty());
}

TEST_F(LegacySourceTest, BuildLegacySourceIndexFollowsTheLink) {
  const fs::path version_dir = AddOriginalSource("thor");
  const std::vector<ObjectSource> sources = FindObjectSources(assets, {"thor"});
  ASSERT_EQ(sources.size(), 1u);
  const LegacyIndexReport report = BuildLegacySourceIndex(sources[0]);
  EXPECT_EQ(report.assets, kAssets);
  EXPECT_EQ(report.archives, 4u);
  EXPECT_TRUE(IsFile(version_dir / ".mlspaces" / "index" / std::string(kUidIndexFile)));
}

TEST(LegacyIndex, CompactedKeysDuplicatesAndNonXmlLeaves) {
  TempDir tmp;
  const fs::path dir = tmp / "v";
  // Written out of order on purpose: archives are sorted, and the first in (archive, path)
  // order wins, not the first in the file or in a depth-first walk.
  WriteTries(dir, R"({
    "b.tar.zst": {"x/y": {"dup.xml": {}}, "only_b.xml": {}},
    "a.tar.zst": {
      "a/b": {"c.xml": {}, "c.json": {}, "meshes": {"m.obj": {}}},
      "z": {"dup.xml": {}},
      "notes.txt": {},
      "dir.xml": {"inner.obj": {}}
    },
    "c.tar.zst": {"a": {"dup2.xml": {}}, "a-b": {"dup2.xml": {}}, "p/q/r.s.xml": {}},
    "empty.tar.zst": {}
  })");
  const LegacyIndexReport report = BuildLegacyIndex(dir, "hand");
  EXPECT_EQ(report.archives, 4u);
  EXPECT_EQ(report.assets, 5u);  // c, dup, only_b, dup2, r.s
  ASSERT_EQ(report.warnings.size(), 2u);
  // Each warning names the file ignored (archive, path in it) and the UID.
  EXPECT_EQ(report.warnings[0].path, "b.tar.zst");
  EXPECT_EQ(report.warnings[0].field, "x/y/dup.xml");
  EXPECT_EQ(report.warnings[0].uid, "dup");
  EXPECT_EQ(report.warnings[0].severity, Severity::kWarning);
  EXPECT_EQ(report.warnings[0].message, "is ignored; a.tar.zst: z/dup.xml wins");
  EXPECT_EQ(LegacyWarningLine(report.warnings[0]),
            "duplicate UID dup: b.tar.zst: x/y/dup.xml is ignored; a.tar.zst: z/dup.xml wins");
  // '-' sorts before '/', so "a-b/dup2.xml" comes first although the walk meets "a" first.
  EXPECT_EQ(report.warnings[1].path, "c.tar.zst");
  EXPECT_EQ(report.warnings[1].field, "a/dup2.xml");
  EXPECT_EQ(report.warnings[1].uid, "dup2");
  EXPECT_EQ(LegacyWarningLine(report.warnings[1]),
            "duplicate UID dup2: c.tar.zst: a/dup2.xml is ignored; c.tar.zst: a-b/dup2.xml wins");

  const auto lib = PackedLibrary::Open(report.index_dir, "hand", dir);
  lib->Check();
  EXPECT_THAT(std::vector<std::string>(lib->archives().begin(), lib->archives().end()),
              ElementsAre("a.tar.zst", "b.tar.zst", "c.tar.zst", "empty.tar.zst"));
  auto expect = [&](const std::string& uid, const std::string& mjcf, const std::string& archive) {
    const auto a = lib->Find(uid);
    ASSERT_TRUE(a.has_value()) << uid;
    EXPECT_EQ(a->mjcf, mjcf);
    EXPECT_EQ(lib->archives()[a->archive], archive);
    EXPECT_EQ(a->metadata_size, 0u);
    EXPECT_EQ(a->num_grasps, 0u);
  };
  expect("c", "a/b/c.xml", "a.tar.zst");
  expect("dup", "z/dup.xml", "a.tar.zst");
  expect("only_b", "only_b.xml", "b.tar.zst");
  expect("dup2", "a-b/dup2.xml", "c.tar.zst");
  expect("r.s", "p/q/r.s.xml", "c.tar.zst");
  for (const char* absent : {"dir", "inner", "notes", "m", "c.json"}) {
    EXPECT_FALSE(lib->Find(absent).has_value()) << absent;
  }

  // Concatenated gzip members (gzip -c a b) read as one stream.
  const std::string json = R"({"a.tar.zst": {"u": {"u.xml": {}}}})";
  WriteText(dir / std::string(kTriesFile), Gzip(json.substr(0, 10)) + Gzip(json.substr(10)));
  EXPECT_EQ(BuildLegacyIndex(dir, "hand").assets, 1u);
  // An empty tries file gives an empty, valid index.
  WriteTries(dir, "{}");
  const LegacyIndexReport empty = BuildLegacyIndex(dir, "hand");
  EXPECT_EQ(empty.assets, 0u);
  EXPECT_EQ(PackedLibrary::Open(empty.index_dir, "hand", dir)->size(), 0u);
}

TEST(LegacyIndex, AFileNamedOnlyXmlIsAWarningNamingArchiveAndPath) {
  TempDir tmp;
  const fs::path dir = tmp / "v";
  WriteTries(dir, R"({"a.tar.zst": {"d": {".xml": {}}, "ok.xml": {}}})");
  const LegacyIndexReport report = BuildLegacyIndex(dir, "hand");
  EXPECT_EQ(report.assets, 1u);
  ASSERT_EQ(report.warnings.size(), 1u);
  const Diagnostic& w = report.warnings[0];
  EXPECT_EQ(w.path, "a.tar.zst");
  EXPECT_EQ(w.field, "d/.xml");
  EXPECT_EQ(w.uid, "");
  EXPECT_EQ(w.severity, Severity::kWarning);
  EXPECT_EQ(LegacyWarningLine(w),
            "a.tar.zst: d/.xml: a file named only \".xml\" has no UID; ignored");
}

TEST(LegacyIndex, BadTriesFilesAreOneLineErrorsNamingFileAndPointer) {
  TempDir tmp;
  const fs::path dir = tmp / "v";
  const std::string file = (dir / std::string(kTriesFile)).string();
  ExpectError([&] { BuildLegacyIndex(dir, "x"); }, {file, "no MolmoSpaces tries file"});

  WriteText(dir / std::string(kTriesFile), R"({"a.tar.zst": {}})");
  ExpectError([&] { BuildLegacyIndex(dir, "x"); }, {file, "not a gzip file"});
  WriteText(dir / std::string(kTriesFile), "");
  ExpectError([&] { BuildLegacyIndex(dir, "x"); }, {file, "not a gzip file"});

  const std::string good = Gzip(R"({"a.tar.zst": {"u": {"u.xml": {}}}})");
  WriteText(dir / std::string(kTriesFile), good.substr(0, good.size() / 2));
  ExpectError([&] { BuildLegacyIndex(dir, "x"); }, {file, "truncated gzip stream"});
  std::string flipped = good;
  flipped[12] = static_cast<char>(flipped[12] ^ 0x55);
  flipped[13] = static_cast<char>(flipped[13] ^ 0x55);
  WriteText(dir / std::string(kTriesFile), flipped);
  ExpectError([&] { BuildLegacyIndex(dir, "x"); }, {file});
  WriteText(dir / std::string(kTriesFile), good + "junk");
  ExpectError([&] { BuildLegacyIndex(dir, "x"); }, {file, "trailing bytes"});

  struct Case {
    std::string json;
    std::vector<std::string> parts;
  };
  const std::vector<Case> cases = {
      {R"({"a.tar.zst": )", {"line"}},
      {R"([{"a.tar.zst": {}}])", {"top level", "got array"}},
      {R"({"a.tar.zst": 3})", {"/a.tar.zst", "got number"}},
      {R"({"a.tar.zst": {"x": {"y": []}}})", {"/a.tar.zst/x/y", "got array"}},
      {R"({"ok.tar.zst": {}, "a/b.tar.zst": {"k~": {"l": null}}})",
       {"/a~1b.tar.zst/k~0/l", "got null"}},
      {R"({"a.tar.zst": {"../evil.xml": {}}})", {"/a.tar.zst/..~1evil.xml", "'..'"}},
      {R"({"a.tar.zst": {"d": {"x//y.xml": {}}}})", {"/a.tar.zst/d/x~1~1y.xml", "bad path"}},
      {R"({"a.tar.zst": {"": {}}})", {"/a.tar.zst/", "bad path"}},
      {R"({"": {}})", {"empty archive name"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.json);
    WriteTries(dir, c.json);
    std::vector<std::string> parts = c.parts;
    parts.push_back(file);
    try {
      BuildLegacyIndex(dir, "x");
      ADD_FAILURE() << "expected an Error";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      for (const std::string& p : parts) EXPECT_THAT(what, HasSubstr(p));
    }
  }
  // Nothing was written by the failed builds.
  EXPECT_FALSE(fs::exists(dir / std::string(kLegacyIndexDir) / std::string(kUidIndexFile)));
}

TEST_F(LegacySourceTest, CliIndexBuiltinThenLocate) {
  const fs::path version_dir = AddOriginalSource("thor");
  // An mlspaces package, a folder that is neither, and a source with a duplicate UID.
  fs::copy(package, assets / "objects" / "pkg", fs::copy_options::recursive);
  fs::create_directories(assets / "objects" / "junk");
  WriteTries(assets / "objects" / "hand",
             R"({"a.tar.zst": {"d": {"dup.xml": {}}}, "b.tar.zst": {"dup.xml": {}}})");

  const auto r = RunCli({"index-builtin"}, Env());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr("objects/thor: 12 assets in 4 archives indexed"));
  EXPECT_THAT(r.out, HasSubstr("objects/hand: 1 assets in 2 archives indexed"));
  EXPECT_THAT(r.out, HasSubstr("objects/pkg: already an mlspaces package, skipped"));
  EXPECT_THAT(r.out, HasSubstr("objects/junk: no"));
  EXPECT_THAT(r.err, HasSubstr("mlspaces: warning: objects/hand: duplicate UID dup: "
                               "b.tar.zst: dup.xml is ignored; a.tar.zst: d/dup.xml wins"));
  // Built through the link, into the cache version folder.
  EXPECT_TRUE(fs::exists(version_dir / std::string(kLegacyIndexDir) / std::string(kUidIndexFile)));
  EXPECT_FALSE(fs::exists(assets / "objects" / "pkg" / std::string(kLegacyIndexDir)));

  const auto loc = RunCli({"locate", "obj_1004"}, Env());
  ASSERT_EQ(loc.exit_code, 0) << loc.out << loc.err;
  EXPECT_THAT(loc.out, HasSubstr("library: thor\n"));
  EXPECT_THAT(loc.out, HasSubstr("archive: fixlib_00001.tar.zst\n"));
  EXPECT_THAT(loc.out,
              HasSubstr((assets / "objects" / "thor" / "obj_1004" / "obj_1004.xml").string()));
  EXPECT_THAT(loc.out, HasSubstr("shadows: pkg"));

  // Named sources, with the flag instead of the environment.
  const auto named = RunCli({"index-builtin", "thor", "--assets-dir", assets.string()},
                            "env -u MLSPACES_ASSETS_DIR ");
  ASSERT_EQ(named.exit_code, 0) << named.out << named.err;
  EXPECT_THAT(named.out, HasSubstr("objects/thor: 12 assets in 4 archives indexed"));
  EXPECT_THAT(named.out, Not(HasSubstr("hand")));

  for (const std::string bad : {"nosuch", "junk"}) {
    const auto e = RunCli({"index-builtin", "thor", bad}, Env());
    EXPECT_EQ(e.exit_code, 1) << e.out << e.err;
    EXPECT_THAT(e.err, HasSubstr("mlspaces: error: " + (assets / "objects" / bad).string()));
    EXPECT_TRUE(e.out.empty()) << e.out;  // checked before anything is built
  }
  const auto usage = RunCli({"index-builtin", "../x"}, Env());
  EXPECT_EQ(usage.exit_code, 2) << usage.err;
  const auto none = RunCli({"index-builtin", "--assets-dir", (tmp / "nowhere").string()});
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_THAT(none.err, HasSubstr("no objects folder"));
}

/// Objaverse's size: 129,000 archives of one asset each, ~9 files per archive.
TEST(LegacyIndex, ScalesToObjaverseSize) {
  size_t n = 129000;
  if (const char* env = std::getenv("MLSPACES_LEGACY_SCALE_ARCHIVES")) n = std::stoul(env);
  TempDir tmp;
  std::string json = "{";
  json.reserve(n * 330);
  char uid[40];
  for (size_t i = 0; i < n; ++i) {
    std::snprintf(uid, sizeof uid, "%016zx%016zx", static_cast<size_t>(i * 0x9e3779b97f4a7c15ULL),
                  i);
    const std::string u(uid);
    json += (i ? ",\"objaverse_" : "\"objaverse_") + u + ".tar.zst\":{\"" + u + "\":{\"" + u +
            ".xml\":{},\"" + u + ".json\":{},\"" + u +
            ".npz\":{},\"visual\":{\"mesh_0.obj\":{},"
            "\"mesh_1.obj\":{},\"texture_0.png\":{}},\"collision\":{\"col_0.obj\":{},"
            "\"col_1.obj\":{},\"col_2.obj\":{}}}}";
  }
  json += "}";
  WriteText(tmp / std::string(kTriesFile), Gzip(json, Z_BEST_SPEED));
  const auto start = std::chrono::steady_clock::now();
  const LegacyIndexReport report = BuildLegacyIndex(tmp.path(), "objaverse");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << "BuildLegacyIndex: " << n << " archives (" << json.size() / 1000000
            << " MB of JSON) in " << seconds << " s\n";
  RecordProperty("build_seconds", std::to_string(seconds));
  EXPECT_EQ(report.archives, n);
  EXPECT_EQ(report.assets, n);
  EXPECT_TRUE(report.warnings.empty());
  const auto lib = PackedLibrary::Open(report.index_dir, "objaverse", tmp.path());
  EXPECT_EQ(lib->size(), n);
  std::snprintf(uid, sizeof uid, "%016zx%016zx",
                static_cast<size_t>((n / 2) * 0x9e3779b97f4a7c15ULL), n / 2);
  const auto a = lib->Find(uid);
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->mjcf, std::string(uid) + "/" + uid + ".xml");
  EXPECT_EQ(lib->archives()[a->archive], "objaverse_" + std::string(uid) + ".tar.zst");
}

}  // namespace
}  // namespace mlspaces
