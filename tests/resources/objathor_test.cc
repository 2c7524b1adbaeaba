// objathor metadata: the original's LMDB and source files (written by the project's Python
// with pickle, numpy, lmdb and zstandard) converted into our stores, the annotation union in
// the Registry and `mlspaces meta`, and damaged inputs: count mismatch, missing sentinel,
// truncated zstd, a hostile pickle and corrupt LMDB pages.
#include "mlspaces/resources/objathor.h"

#include "library_fixture.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/library/clip_store.h"
#include "mlspaces/library/package_layout.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/resources/packed_store_writer.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::RunCli;
using ::mlspaces::testing::ShellQuote;
using ::mlspaces::testing::Slurp;
using ::mlspaces::testing::TempDir;
using ::testing::HasSubstr;

class ObjathorTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    ASSERT_EQ(0, testing::RunPython(dir_->path(),
                                    Slurp(std::string(MLSPACES_TESTDATA_DIR) + "/make_objathor.py"),
                                    ShellQuote((dir_->path() / "out").string()) + " " +
                                        ShellQuote(MLSPACES_SOURCE_DIR)));
    expected_ = new Json(ParseJsonFile(dir_->path() / "out" / "expected.json"));
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete expected_;
  }
  static fs::path Assets(const std::string& name) { return dir_->path() / "out" / name / "assets"; }
  static fs::path IndexDir(const std::string& name) {
    return Assets(name) / "objects" / "objathor_metadata" / std::string(kLegacyIndexDir);
  }
  /// The error converting a case gives ("" if none).
  static std::string ConvertError(const std::string& name) {
    try {
      EnsureObjathorStore(Assets(name));
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
      return e.what();
    }
    return "";
  }
  void ExpectAllAnnotations(const std::string& name) {
    Registry::Options options;
    options.assets_dir = Assets(name);
    const Registry registry(options);
    ASSERT_NE(registry.objathor_store(), nullptr);
    std::vector<std::string> uids;
    for (const auto& [uid, value] : expected_->items()) {
      std::shared_ptr<const Annotation> a = registry.GetAnnotation(uid);
      ASSERT_NE(a, nullptr) << uid;
      EXPECT_EQ(a->library, "objathor_metadata");
      EXPECT_EQ(a->ToJson(), value) << uid;  // ordered: the dict, then the CLIP arrays
      ASSERT_NE(a->FindArray("/clip_img_features"), nullptr);
      EXPECT_EQ(a->FindArray("/clip_img_features")->dtype, DType::kF2);
      uids.push_back(uid);
    }
    std::vector<std::string> got = registry.annotated_uids();
    std::sort(uids.begin(), uids.end());
    EXPECT_EQ(got, uids);
    EXPECT_EQ(registry.GetAnnotation("not_a_uid"), nullptr);
    const auto clip = ClipStore::Open(IndexDir(name) / std::string(kClipStoreFileName));
    EXPECT_EQ(clip->size(), uids.size());
    EXPECT_EQ(clip->views(), 3u);
    EXPECT_EQ(clip->dim(), 768u);
  }

  static TempDir* dir_;
  static Json* expected_;
};
TempDir* ObjathorTest::dir_ = nullptr;
Json* ObjathorTest::expected_ = nullptr;

TEST_F(ObjathorTest, ConvertsTheOriginalLmdbOnceAndDeterministically) {
  std::optional<ObjathorReport> report = EnsureObjathorStore(Assets("lmdb"));
  ASSERT_TRUE(report);
  EXPECT_TRUE(report->converted);
  EXPECT_THAT(report->from, HasSubstr("lmdb "));
  EXPECT_EQ(report->annotations, 4u);
  EXPECT_EQ(report->clip_features, 4u);
  // Written into the cache version dir, reached through the GLOBAL link.
  EXPECT_TRUE(fs::exists(dir_->path() / "out/lmdb/cache/objects/objathor_metadata/20260129" /
                         std::string(kLegacyIndexDir) / std::string(kUidIndexFile)));
  ExpectAllAnnotations("lmdb");
  const std::string index = Slurp(IndexDir("lmdb") / std::string(kUidIndexFile));
  const std::string meta = Slurp(IndexDir("lmdb") / std::string(kMetadataStoreFile));
  const std::string clip = Slurp(IndexDir("lmdb") / std::string(kClipStoreFileName));
  EXPECT_FALSE(EnsureObjathorStore(Assets("lmdb"))->converted);
  const ObjathorReport again = ConvertObjathor(*FindObjathor(Assets("lmdb")));
  EXPECT_TRUE(again.converted);
  EXPECT_EQ(Slurp(IndexDir("lmdb") / std::string(kUidIndexFile)), index);
  EXPECT_EQ(Slurp(IndexDir("lmdb") / std::string(kMetadataStoreFile)), meta);
  EXPECT_EQ(Slurp(IndexDir("lmdb") / std::string(kClipStoreFileName)), clip);
}

TEST_F(ObjathorTest, BuildsFromTheSourceFilesWithoutAnLmdb) {
  std::optional<ObjathorReport> report = EnsureObjathorStore(Assets("src"));
  ASSERT_TRUE(report);
  EXPECT_THAT(report->from, HasSubstr("source files "));
  EXPECT_EQ(report->annotations, 4u);
  ExpectAllAnnotations("src");
}

TEST_F(ObjathorTest, AStaleOrForeignStoreIsConvertedAgain) {
  // What an older index-builtin left: a whole but empty store made from the tries, no marker.
  fs::remove_all(IndexDir("src"));
  fs::create_directories(IndexDir("src"));
  PackedStoreWriter empty(IndexDir("src"), "objathor_metadata", {"objathor_metadata"});
  empty.Finish();
  ClipStoreWriter(IndexDir("src") / std::string(kClipStoreFileName), 3, 768).Finish();
  std::optional<ObjathorReport> report = EnsureObjathorStore(Assets("src"));
  ASSERT_TRUE(report);
  EXPECT_TRUE(report->converted);
  EXPECT_EQ(report->annotations, 4u);
  ExpectAllAnnotations("src");
  const Json marker = ParseJsonFile(IndexDir("src") / "objathor_source.json");
  EXPECT_EQ(marker["kind"], "source files");
  EXPECT_EQ(marker["from"].size(), 2u);
  EXPECT_FALSE(EnsureObjathorStore(Assets("src"))->converted);
  // A source file changed since (a new mtime): converted again.
  const fs::path pkl = Assets("src") / "objects/objathor_metadata/clip_features.pkl";
  fs::last_write_time(pkl, fs::last_write_time(pkl) + std::chrono::seconds(5));
  EXPECT_TRUE(EnsureObjathorStore(Assets("src"))->converted);
  EXPECT_FALSE(EnsureObjathorStore(Assets("src"))->converted);
  // A marker of another store format: converted again.
  Json other = ParseJsonFile(IndexDir("src") / "objathor_source.json");
  other["format"] = 0;
  WriteFileAtomic(IndexDir("src") / "objathor_source.json", other.dump());
  EXPECT_TRUE(EnsureObjathorStore(Assets("src"))->converted);
}

TEST_F(ObjathorTest, UnionAnswersObjathorFirstThenUserLibraries) {
  ASSERT_TRUE(EnsureObjathorStore(Assets("lmdb")));
  TempDir user;
  testing::MakeFixtureLibrary(user.path(), 2);  // obj_1000 (also in objathor), obj_1001
  Registry::Options options;
  options.assets_dir = Assets("lmdb");
  Registry registry(options);
  registry.RegisterAssetLibrary("mine", user.path());
  EXPECT_EQ(registry.GetAnnotation("obj_1000")->library, "objathor_metadata");
  EXPECT_EQ(registry.GetAnnotation("obj_1000")->json["category"], "Block");
  EXPECT_EQ(registry.GetAnnotation("obj_1001")->library, "mine");
  const std::vector<std::string> uids = registry.annotated_uids();
  EXPECT_EQ(std::count(uids.begin(), uids.end(), "obj_1000"), 1);
  EXPECT_EQ(uids.back(), "obj_1001");
  // Without the objathor store, the user library answers as before.
  Registry plain;
  plain.RegisterAssetLibrary("mine", user.path());
  EXPECT_EQ(plain.GetAnnotation("obj_1000")->library, "mine");
  // The explicit API opens a store from anywhere.
  plain.RegisterObjathorStore(IndexDir("lmdb"));
  EXPECT_EQ(plain.GetAnnotation("obj_1000")->library, "objathor_metadata");
}

TEST_F(ObjathorTest, DamagedInputsAreOneLineErrorsAndWriteNothing) {
  EXPECT_THAT(ConvertError("mismatch"), HasSubstr("# clip entries 3 != # annotation entries 4"));
  EXPECT_THAT(ConvertError("nosentinel"), HasSubstr("__LMDBMap__dump_complete__"));
  const std::string truncated = ConvertError("truncated");
  EXPECT_THAT(truncated, HasSubstr("data.mdb: Mug_1: zstd"));
  const std::string hostile = ConvertError("hostile");
  EXPECT_THAT(hostile, HasSubstr("data.mdb: obj_1000: pickle: global posix.system is not allowed"));
  EXPECT_FALSE(fs::exists(dir_->path() / "out" / "pwned"));
  const std::string corrupt = ConvertError("corrupt");
  EXPECT_THAT(corrupt, HasSubstr("data.mdb"));
  for (const char* name : {"mismatch", "nosentinel", "truncated", "hostile", "corrupt"}) {
    EXPECT_FALSE(fs::exists(IndexDir(name))) << name;
    // Only the lock file is left beside where the index would be.
    for (const auto& e : fs::directory_iterator(IndexDir(name).parent_path())) {
      EXPECT_EQ(e.path().filename(), "objathor.lock") << name;
    }
  }
}

TEST_F(ObjathorTest, MetaConvertsOnFirstUseAndPrintsTheUnion) {
  const std::string env = "env MLSPACES_ASSETS_DIR=" + ShellQuote(Assets("src").string()) + " ";
  fs::remove_all(IndexDir("src"));
  testing::CliResult r = RunCli({"meta", "0a1b2c3d4e"}, env);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("objathor metadata: 4 annotations converted"));
  EXPECT_EQ(ParseJson(r.out, "stdout"), (*expected_)["0a1b2c3d4e"]);
  r = RunCli({"meta", "Mug_1"}, env);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");  // warm: nothing converted
  EXPECT_EQ(ParseJson(r.out, "stdout"), (*expected_)["Mug_1"]);
  r = RunCli({"meta", "obj_1000"},
             "env MLSPACES_ASSETS_DIR=" + ShellQuote(Assets("hostile").string()) + " ");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("global posix.system is not allowed"));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

}  // namespace
}  // namespace mlspaces
