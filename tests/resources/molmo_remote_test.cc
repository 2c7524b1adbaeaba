// Installing from a MolmoSpaces-format remote (molmo_remote.h, installer.h): the remote is
// written by tests/fixtures/make_molmo_remote.py (Python tarfile + zstandard, as the
// original's bucket) and served on 127.0.0.1 or over file://; every expectation is read from
// its fixture.json, never hard-coded.
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/library/package_layout.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/resources/fetch.h"
#include "mlspaces/resources/installer.h"
#include "mlspaces/resources/molmo_remote.h"
#include "mlspaces/resources/sha256.h"
#include "resources/http_test_server.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using testing::CrashPoints;
using testing::ExpectError;
using ::testing::HasSubstr;
using testing::RunCli;
using testing::TempDir;

constexpr const char* kVersions = "mjthor_data_type_to_source_to_versions.json";

/// The remote, written once for the whole test program and removed when it exits.
struct Remote {
  TempDir dir;
  Json fx;
  fs::path root() const { return dir.path() / "out"; }
  fs::path remote() const { return root() / fx["remote_dir"].get<std::string>(); }
  fs::path pins() const { return root() / fx["pins_file"].get<std::string>(); }
};

const Remote& TheRemote() {
  // Destroyed at exit, which removes the folder (the forked servers exec or _exit).
  static const std::unique_ptr<Remote> r = [] {
    auto remote = std::make_unique<Remote>();
    const auto run = testing::RunProgram(
        MLSPACES_PYTHON, {std::string(MLSPACES_SOURCE_DIR) + "/tests/fixtures/make_molmo_remote.py",
                          (remote->dir.path() / "out").string(), "--corrupt"});
    if (run.exit_code != 0) {
      ADD_FAILURE() << "make_molmo_remote.py failed: " << run.err;
      std::abort();
    }
    remote->fx = ParseJsonFile(remote->root() / "fixture.json");
    return remote;
  }();
  return *r;
}

class MolmoRemoteTest : public ::testing::Test {
 protected:
  const Remote& remote = TheRemote();
  const Json& fx = remote.fx;
  TempDir tmp;

  ResourceSettings Settings(const std::string& url) const {
    ResourceSettings s;
    s.cache_dir = tmp / "cache";
    s.assets_dir = tmp / "assets";
    s.remote_url = url;
    s.pin_file = remote.pins();
    s.versions = BuiltinSourceVersions();
    MergePinFile(s.versions, s.pin_file);
    return s;
  }
  static InstallOptions Quick(int retries = 1) {
    InstallOptions o;
    o.retries = retries;
    o.parallel_downloads = 2;
    return o;
  }
  std::string FileRemote() const { return FileUrl(remote.remote()); }
  /// Shell words for CLI runs on this test's dirs.
  std::string Env() const {
    return "env MLSPACES_CACHE_DIR=" + (tmp / "cache").string() +
           " MLSPACES_ASSETS_DIR=" + (tmp / "assets").string() +
           " MLSPACES_PINNED_ASSETS_FILE=" + remote.pins().string() + " ";
  }
  fs::path VersionDir(const std::string& type, const std::string& source) const {
    return tmp / "cache" / type / source / fx["versions"][type][source].get<std::string>();
  }
  const Json& ArchiveInfo(const std::string& type, const std::string& source,
                          const std::string& archive) const {
    return fx["sources"][type][source]["archives"][archive];
  }
  /// Whether an archive is flagged, and then every file of it is in place with the
  /// generator's SHA-256 (a flagged archive is never half there).
  bool Installed(const std::string& type, const std::string& source,
                 const std::string& archive) const {
    const fs::path dir = VersionDir(type, source);
    if (!IsFile(dir / ExtractFlagName(archive))) return false;
    const Json& info = ArchiveInfo(type, source, archive);
    for (const auto& [file, sha] : info["file_sha256"].items()) {
      EXPECT_TRUE(IsFile(dir / file)) << type << "/" << source << ": " << file;
      if (IsFile(dir / file)) {
        EXPECT_EQ(Sha256File(dir / file).sha256, sha.get<std::string>()) << file;
      }
    }
    return true;
  }
  /// Every flagged archive of every source is complete (Installed checks each file).
  void ExpectNothingHalfInstalled() const {
    for (const auto& [type, sources] : fx["sources"].items()) {
      for (const auto& [source, info] : sources.items()) {
        for (const auto& [archive, a] : info["archives"].items()) Installed(type, source, archive);
      }
    }
  }
  std::string SceneUid(size_t i) const {
    return fx["scenes"]["ithor"]["FloorPlan1"]["objaverse_uids"][i].get<std::string>();
  }
};

// =============================================================================================
// The pure parts

TEST(MolmoIndexTest, TokensAndIndexesFollowTheOriginalsRules) {
  EXPECT_THAT(SplitQueryTokens("objaverse_ab12.tar.zst"),
              ::testing::ElementsAre("objaverse", "ab12", "tar", "zst"));
  EXPECT_THAT(SplitQueryTokens("__a//b. c__"), ::testing::ElementsAre("a", "b", "c"));
  EXPECT_THAT(NumericTokens("ithor_FloorPlan-3_12x7"), ::testing::ElementsAre("-3", "12", "7"));
  const std::vector<std::string> names = {"droid_Bowl.tar.zst", "droid_Bowl_Mug.tar.zst",
                                          "droid_Fridge.tar.zst", "droid.tar.zst"};
  const ArchiveIndex sub(ArchiveIndexKind::kSubstring, names);
  EXPECT_THAT(sub.QueryToken("Bowl"),
              ::testing::ElementsAre("droid_Bowl.tar.zst", "droid_Bowl_Mug.tar.zst"));
  EXPECT_TRUE(sub.QueryToken("tar").empty()) << ".tar.zst is dropped before splitting";
  // "Bowl" is ambiguous (2 archives > max 1): ignored; "Fridge" is not.
  EXPECT_THAT(sub.Candidates("Bowl/Fridge_1.xml"), ::testing::ElementsAre("droid_Fridge.tar.zst"));
  EXPECT_THAT(sub.Candidates("Bowl/x.xml", 2),
              ::testing::ElementsAre("droid_Bowl.tar.zst", "droid_Bowl_Mug.tar.zst"));
  const std::vector<std::string> scenes = {"ithor_FloorPlan1.tar.zst", "ithor_FloorPlan2.tar.zst",
                                           "ithor_base.tar.zst"};
  const ArchiveIndex num(ArchiveIndexKind::kNumeric, scenes);
  EXPECT_THAT(num.QueryToken("2"), ::testing::ElementsAre("ithor_FloorPlan2.tar.zst"));
  EXPECT_THAT(num.Unindexed(scenes), ::testing::ElementsAre("ithor_base.tar.zst"));
  EXPECT_THAT(ArchiveIndex().Unindexed(scenes), ::testing::ElementsAreArray(scenes));
  const SourceBehavior thor = ResolveSourceBehavior("objects", "thor");
  EXPECT_EQ(thor.mode, InstallMode::kEager);
  EXPECT_EQ(ResolveSourceBehavior("objects", "objaverse").mode, InstallMode::kOnDemand);
  EXPECT_EQ(ResolveSourceBehavior("scenes", "ithor").link, LinkStrategy::kPerFile);
  EXPECT_EQ(ResolveSourceBehavior("robots", "franka_droid").mode, InstallMode::kEager);
  ExpectError([] { ResolveSourceBehavior("weights", "x"); }, {"weights"});
}

TEST_F(MolmoRemoteTest, TriesOfEverySourceReadAsTheGeneratorWroteThem) {
  for (const auto& [type, sources] : fx["sources"].items()) {
    for (const auto& [source, info] : sources.items()) {
      const fs::path dir = remote.root() / info["dir"].get<std::string>();
      const SourceTries tries = ReadTries(dir / "mjthor_resources_combined_meta.json.gz");
      ASSERT_EQ(tries.archives.size(), info["archives"].size()) << type << "/" << source;
      for (const auto& [archive, a] : info["archives"].items()) {
        const auto index = tries.Find(archive);
        ASSERT_TRUE(index) << archive;
        std::vector<std::string> want = a["files"].get<std::vector<std::string>>();
        std::sort(want.begin(), want.end());
        EXPECT_EQ(tries.files[*index], want) << archive;
        for (const std::string& f : want) EXPECT_EQ(tries.ArchiveOf(f), index) << f;
      }
    }
  }
}

// =============================================================================================
// Installing

TEST_F(MolmoRemoteTest, InstallUidOverHttpSetsUpEverySourceAsTheOriginal) {
  testing::HttpTestServer server(remote.root());
  const std::string uid = SceneUid(0);
  const Json& obj = fx["objects"]["objaverse"][uid];
  {
    Installer installer(Settings(server.url() + "/remote"), Quick());
    const InstallPlan plan = installer.PlanUids({uid});
    EXPECT_EQ(plan.assets, 1u);
    installer.Install(plan);
  }
  // Both versions manifests, every pinned source.
  const Json cache_manifest = ParseJsonFile(tmp / "cache" / kVersions);
  const Json install_manifest = ParseJsonFile(tmp / "assets" / kVersions);
  for (const auto& [type, sources] : fx["versions"].items()) {
    for (const auto& [source, version] : sources.items()) {
      EXPECT_EQ(install_manifest[type][source], version) << type << "/" << source;
      EXPECT_THAT(cache_manifest[type][source].get<std::vector<std::string>>(),
                  ::testing::Contains(version.get<std::string>()));
    }
  }
  // Links, and what EAGER and ON_DEMAND mean.
  for (const auto& [type, sources] : fx["sources"].items()) {
    for (const auto& [source, info] : sources.items()) {
      const fs::path link = tmp / "assets" / type / source;
      if (info["link"] == "global") {
        ASSERT_TRUE(fs::is_symlink(link)) << link;
        EXPECT_EQ(fs::read_symlink(link), fs::absolute(VersionDir(type, source)));
      } else {
        ASSERT_TRUE(fs::is_directory(link) && !fs::is_symlink(link)) << link;
      }
      for (const auto& [archive, a] : info["archives"].items()) {
        const bool want = info["install"] == "eager" || type == "scenes" ||
                          archive == obj["archive"] ||
                          archive == fx["grasps"]["droid_objaverse"][uid]["archive"];
        EXPECT_EQ(Installed(type, source, archive), want)
            << type << "/" << source << " " << archive;
        if (want && info["link"] == "per_file") {
          EXPECT_TRUE(IsFile(link / ("." + archive + "_complete_links"))) << archive;
          for (const auto& f : a["files"]) {
            const fs::path p = link / f.get<std::string>();
            EXPECT_TRUE(fs::is_symlink(p)) << p;
            EXPECT_EQ(fs::read_symlink(p),
                      fs::absolute(VersionDir(type, source)) / f.get<std::string>());
          }
        }
      }
    }
  }
  // Lookups through our UID index: the MJCF and the grasps through the install link.
  Registry registry(Registry::Options{tmp / "assets"});
  const auto where = registry.Locate(uid);
  ASSERT_TRUE(where);
  EXPECT_EQ(where->library, "objaverse");
  EXPECT_EQ(where->mjcf_path,
            tmp / "assets" / "objects" / "objaverse" / obj["mjcf"].get<std::string>());
  EXPECT_TRUE(IsFile(where->mjcf_path));
  const auto grasps = registry.FindGraspFile(GraspQuery{uid, "", {}});
  ASSERT_TRUE(grasps);
  EXPECT_TRUE(IsFile(grasps->path)) << grasps->path;
  // Our record of every installed file: verify passes.
  Installer again(Settings(server.url() + "/remote"), Quick());
  size_t checked = 0;
  EXPECT_TRUE(again.Verify({}, false, &checked).empty());
  EXPECT_GT(checked, 10u);
  // Installed already: a second plan downloads nothing.
  EXPECT_TRUE(again.PlanUids({uid}).archives.empty());
}

TEST_F(MolmoRemoteTest, SceneByNumberAndByPathOverFileUrlBringsItsObjectsAndGrasps) {
  const Json& scene = fx["scenes"]["ithor"]["FloorPlan1"];
  Installer installer(Settings(FileRemote()), Quick());
  SceneRequest request;
  installer.Install(installer.PlanScene(std::to_string(scene["index"].get<int>()), &request));
  EXPECT_EQ(request.source, "ithor");
  EXPECT_THAT(request.files, ::testing::Contains(scene["xml"].get<std::string>()));
  const InstallPlan contents = installer.PlanSceneContents(request);
  installer.Install(contents);
  for (const auto& [source, archives] : scene["object_archives"].items()) {
    for (const auto& a : archives) EXPECT_TRUE(Installed("objects", source, a)) << a;
  }
  for (const auto& [source, archives] : scene["grasp_archives"].items()) {
    for (const auto& a : archives) EXPECT_TRUE(Installed("grasps", source, a)) << a;
  }
  // Every ../objects/... reference of the scene resolves inside the install tree.
  for (const auto& ref : scene["references"]) {
    const fs::path p = tmp / "assets" / "objects" / ref["source"].get<std::string>() /
                       ref["path"].get<std::string>();
    EXPECT_TRUE(IsFile(p)) << p;
  }
  // The other scene by path; objaverse archives it does not reference stay out.
  const Json& scene2 = fx["scenes"]["ithor"]["FloorPlan2"];
  SceneRequest request2;
  installer.Install(installer.PlanScene("ithor/" + scene2["xml"].get<std::string>(), &request2));
  EXPECT_THAT(request2.files, ::testing::ElementsAre(scene2["xml"].get<std::string>()));
  installer.Install(installer.PlanSceneContents(request2));
  for (const auto& a : scene2["object_archives"]["objaverse"]) {
    EXPECT_TRUE(Installed("objects", "objaverse", a)) << a;
  }
  std::set<std::string> referenced;
  for (const Json* s : {&scene, &scene2}) {
    for (const auto& a : (*s)["object_archives"]["objaverse"]) referenced.insert(a);
  }
  for (const auto& [archive, a] : fx["sources"]["objects"]["objaverse"]["archives"].items()) {
    if (referenced.count(archive) == 0) {
      EXPECT_FALSE(Installed("objects", "objaverse", archive)) << archive;
    }
  }
  ExpectError([&] { installer.PlanScene("4242", nullptr); }, {"no scene 4242", "ithor"});
  ExpectError([&] { installer.PlanScene("ithor/NoSuchPlan.xml", nullptr); },
              {"no scene 'ithor/NoSuchPlan.xml'"});
  ExpectError([&] { installer.PlanUids({"no_such_uid_x"}); },
              {"no_such_uid_x not found in object sources"});
}

TEST_F(MolmoRemoteTest, LibraryAndSourcePlans) {
  Installer installer(Settings(FileRemote()), Quick());
  const InstallPlan all = installer.PlanLibrary("objaverse", {});
  EXPECT_EQ(all.assets, fx["objects"]["objaverse"].size());
  std::set<std::string> planned;
  for (const auto& item : all.archives) planned.insert(item.archive);
  for (const auto& [uid, info] : fx["objects"]["objaverse"].items()) {
    EXPECT_EQ(planned.count(info["archive"].get<std::string>()), 1u) << uid;
  }
  installer.Install(installer.PlanLibrary("robots/franka_droid", {}));
  EXPECT_TRUE(Installed("robots", "franka_droid", "franka_droid_model.tar.zst"));
}

TEST_F(MolmoRemoteTest, WhereFiltersAndTheLicencePolicyReadTheObjathorAnnotations) {
  const Json& objaverse = fx["objects"]["objaverse"];
  const std::string category = objaverse[SceneUid(0)]["category"].get<std::string>();
  size_t same = 0;
  for (const auto& [uid, info] : objaverse.items()) same += info["category"] == category;
  {
    Installer installer(Settings(FileRemote()), Quick());
    const InstallPlan plan = installer.PlanLibrary("objaverse", {{"category", category}});
    EXPECT_EQ(plan.assets, same);
    for (const auto& item : plan.archives) {
      if (item.source->name != "objaverse") continue;
      EXPECT_EQ(item.archive, objaverse[SceneUid(0)]["archive"]) << "only the " << category;
    }
  }
  InstallOptions options = Quick();
  options.license_policy = LicensePolicy::kCommercialSafe;
  std::vector<std::string> notes;
  options.note = [&](const std::string& text) { notes.push_back(text); };
  Installer installer(Settings(FileRemote()), options);
  const InstallPlan plan = installer.PlanLibrary("objaverse", {});
  const std::vector<std::string> nc =
      fx["objathor_metadata"]["non_commercial"].get<std::vector<std::string>>();
  ASSERT_FALSE(nc.empty());
  EXPECT_EQ(plan.left_out, nc.size());
  EXPECT_EQ(plan.assets, objaverse.size() - nc.size());
  for (const std::string& uid : nc) {
    for (const auto& item : plan.archives) {
      EXPECT_NE(item.archive, objaverse[uid]["archive"]) << uid << " is non-commercial";
    }
    EXPECT_TRUE(std::any_of(notes.begin(), notes.end(), [&](const std::string& n) {
      return n.find(uid) != std::string::npos && n.find("commercial_safe") != std::string::npos;
    })) << uid;
  }
}

TEST_F(MolmoRemoteTest, DryRunsInstallNothingAndSayWhatTheAnnotationsNeed) {
  const Json& objaverse = fx["objects"]["objaverse"];
  const std::string category = objaverse[SceneUid(0)]["category"].get<std::string>();
  const fs::path objathor = VersionDir("objects", "objathor_metadata");
  auto nothing_extracted = [&] {
    for (const auto& [archive, a] :
         fx["sources"]["objects"]["objathor_metadata"]["archives"].items()) {
      EXPECT_FALSE(IsFile(objathor / ExtractFlagName(archive))) << archive;
    }
    for (const auto& [archive, a] : fx["sources"]["objects"]["objaverse"]["archives"].items()) {
      EXPECT_FALSE(Installed("objects", "objaverse", archive)) << archive;
    }
  };
  const auto where = RunCli({"install", "--remote", FileRemote(), "--dry-run", "--library",
                             "objaverse", "--where", "category=" + category},
                            Env());
  EXPECT_EQ(where.exit_code, 0) << where.err;
  EXPECT_THAT(where.err, HasSubstr("objects/objathor_metadata, which is not installed"));
  EXPECT_THAT(where.out, ::testing::StartsWith(std::to_string(objaverse.size()) + " assets in"));
  nothing_extracted();
  const auto policy = RunCli({"install", "--remote", FileRemote(), "--dry-run", "--license-policy",
                              "commercial_safe", SceneUid(0)},
                             Env());
  EXPECT_EQ(policy.exit_code, 0) << policy.err;
  EXPECT_THAT(policy.err, HasSubstr("objects/objathor_metadata, which is not installed"));
  nothing_extracted();
  // Installed annotations are read, not installed again: the filter applies in a dry run.
  Installer installer(Settings(FileRemote()), Quick());
  installer.Install(installer.PlanSource("objects", "objathor_metadata"));
  size_t same = 0;
  for (const auto& [uid, info] : objaverse.items()) same += info["category"] == category;
  const auto filtered = RunCli({"install", "--remote", FileRemote(), "--dry-run", "--library",
                                "objaverse", "--where", "category=" + category},
                               Env());
  EXPECT_EQ(filtered.exit_code, 0) << filtered.err;
  EXPECT_THAT(filtered.out, ::testing::StartsWith(std::to_string(same) + " assets in"));
  EXPECT_THAT(filtered.err, ::testing::Not(HasSubstr("not installed")));
}

// =============================================================================================
// Guarantees

TEST_F(MolmoRemoteTest, ResumesAKilledDownloadAndReportsAConnectionThatStops) {
  testing::HttpTestServer server(remote.root());
  const std::string uid = SceneUid(1);
  const std::string archive = fx["objects"]["objaverse"][uid]["archive"].get<std::string>();
  const std::string path = "/remote/objects/objaverse/" +
                           fx["versions"]["objects"]["objaverse"].get<std::string>() + "/" +
                           archive;
  {  // Set up everything else first, so the fault hits only the archive.
    Installer installer(Settings(server.url() + "/remote"), Quick());
    installer.Install(installer.PlanUids({"Bowl_1"}));
  }
  server.SetFaults("{\"" + path + "\": [{\"mode\": \"truncate\", \"after\": 100}]}");
  {
    Installer installer(Settings(server.url() + "/remote"), Quick(0));
    const InstallPlan plan = installer.PlanUids({uid});
    ExpectError([&] { installer.Install(plan); }, {archive, server.url()});
  }
  EXPECT_FALSE(Installed("objects", "objaverse", archive));
  const fs::path part =
      VersionDir("objects", "objaverse") / ".mlspaces" / "downloads" / (archive + ".part");
  EXPECT_TRUE(IsFile(part)) << "the partial download is kept for a resume";
  {
    Installer installer(Settings(server.url() + "/remote"), Quick(0));
    installer.Install(installer.PlanUids({uid}));
  }
  EXPECT_TRUE(Installed("objects", "objaverse", archive));
  bool resumed = false;
  for (const std::string& line : server.LogLines()) {
    resumed |=
        line.find(archive) != std::string::npos && line.find("bytes=100-") != std::string::npos;
  }
  EXPECT_TRUE(resumed) << "not resumed with a Range request";
  EXPECT_FALSE(IsFile(part));
}

TEST_F(MolmoRemoteTest, BadArchivesManifestsAndTriesAreOneLineErrorsLeavingNothingInstalled) {
  // The remote with one damaged file at a time, as fixture.json "corrupt" lists them.
  for (const Json& c : fx["corrupt"]["cases"]) {
    SCOPED_TRACE(c["what"].get<std::string>());
    TempDir bad;
    fs::copy(remote.remote(), bad / "remote", fs::copy_options::recursive);
    const std::string rel = c["file"].get<std::string>().substr(
        fx["corrupt"]["remote_dir"].get<std::string>().size() + 1);
    fs::copy_file(remote.root() / c["file"].get<std::string>(), bad / "remote" / rel,
                  fs::copy_options::overwrite_existing);
    TempDir dirs;
    ResourceSettings s = Settings(FileUrl(bad / "remote"));
    s.cache_dir = dirs / "cache";
    s.assets_dir = dirs / "assets";
    const std::string url = JoinUrl(s.remote_url, rel);
    const fs::path version_dir = dirs / "cache" / c["type"].get<std::string>() /
                                 c["source"].get<std::string>() / c["version"].get<std::string>();
    Installer installer(s, Quick(0));
    if (c.contains("archive")) {
      const std::string archive = c["archive"].get<std::string>();
      const InstallPlan plan = installer.PlanUids({c["uid"].get<std::string>()});
      ExpectError([&] { installer.Install(plan); }, {url, archive});
      EXPECT_FALSE(IsFile(version_dir / ExtractFlagName(archive)));
      for (const auto& f : fx["objects"]["objaverse"][c["uid"].get<std::string>()]["files"]) {
        EXPECT_FALSE(fs::exists(fs::symlink_status(version_dir / f.get<std::string>())))
            << f << " of a rejected archive is in place";
      }
      const fs::path staging = version_dir / ".mlspaces" / "staging";
      EXPECT_TRUE(!fs::exists(staging) || fs::is_empty(staging)) << "staging left behind";
    } else {
      ExpectError([&] { installer.PlanUids({"Bowl_1"}); }, {url});
      const Json manifest = [&] {
        try {
          return ParseJsonFile(dirs / "assets" / kVersions);
        } catch (const Error&) {
          return Json::object();
        }
      }();
      EXPECT_FALSE(manifest.contains(c["type"].get<std::string>()) &&
                   manifest[c["type"].get<std::string>()].contains(c["source"].get<std::string>()));
      EXPECT_FALSE(IsFile(version_dir / rel.substr(rel.rfind('/') + 1)))
          << "a rejected manifest or tries file is in place";
    }
  }
  // An HTML page where an archive should be.
  TempDir html;
  fs::copy(remote.remote(), html / "remote", fs::copy_options::recursive);
  const std::string uid = SceneUid(0);
  const std::string archive = fx["objects"]["objaverse"][uid]["archive"].get<std::string>();
  const std::string rel = "objects/objaverse/" +
                          fx["versions"]["objects"]["objaverse"].get<std::string>() + "/" + archive;
  testing::WriteText(html / "remote" / rel, "<!DOCTYPE html><html><body>Not here</body></html>\n");
  Installer installer(Settings(FileUrl(html / "remote")), Quick(0));
  const InstallPlan plan = installer.PlanUids({uid});
  ExpectError([&] { installer.Install(plan); }, {rel, archive, "not a .tar.zst"});
  EXPECT_FALSE(Installed("objects", "objaverse", archive));
}

TEST_F(MolmoRemoteTest, KillNineAtAnyStepLeavesNothingHalfInstalled) {
  const std::vector<std::string> args = {"install", "--remote", FileRemote(),
                                         "--quiet", "--scene",  "1"};
  const CrashPoints crash(tmp / "counter");
  const auto counted = RunCli(args, crash.Counting() + Env());
  ASSERT_EQ(counted.exit_code, 0) << counted.err;
  const uint64_t steps = crash.Count();
  ASSERT_GE(steps, 20u);
  std::mt19937_64 rng(28);
  std::set<uint64_t> points = {1, steps / 2, steps};
  while (points.size() < 7) points.insert(1 + rng() % steps);
  for (uint64_t n : points) {
    SCOPED_TRACE("killed after step " + std::to_string(n) + " of " + std::to_string(steps));
    fs::remove_all(tmp / "cache");  // 0444 files in 0755 folders: removable
    fs::remove_all(tmp / "assets");
    const auto cut = RunCli(args, crash.KillAt(n) + Env());
    EXPECT_TRUE(cut.sigkilled) << cut.exit_code << " " << cut.err;
    ExpectNothingHalfInstalled();
    const auto rerun = RunCli(args, Env());
    ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
    const auto verify = RunCli({"verify"}, Env() + "MLSPACES_REMOTE_URL=" + FileRemote() + " ");
    EXPECT_EQ(verify.exit_code, 0) << verify.out << verify.err;
    for (const auto& [source, archives] :
         fx["scenes"]["ithor"]["FloorPlan1"]["object_archives"].items()) {
      for (const auto& a : archives) EXPECT_TRUE(Installed("objects", source, a)) << a;
    }
  }
}

TEST_F(MolmoRemoteTest, TwoConcurrentInstallersOnOneCache) {
  const std::vector<std::string> args = {"install", "--remote", FileRemote(),
                                         "--quiet", "--scene",  "1"};
  const pid_t a = testing::SpawnCli(args, Env(), tmp / "a.err");
  const pid_t b = testing::SpawnCli(args, Env(), tmp / "b.err");
  for (pid_t pid : {a, b}) {
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
        << testing::Slurp(tmp / "a.err") << testing::Slurp(tmp / "b.err");
  }
  for (const auto& [source, archives] :
       fx["scenes"]["ithor"]["FloorPlan1"]["object_archives"].items()) {
    for (const auto& arc : archives) EXPECT_TRUE(Installed("objects", source, arc)) << arc;
  }
  const auto verify = RunCli({"verify"}, Env() + "MLSPACES_REMOTE_URL=" + FileRemote() + " ");
  EXPECT_EQ(verify.exit_code, 0) << verify.out << verify.err;
}

TEST_F(MolmoRemoteTest, VerifyFindsTamperingAndRepairReinstalls) {
  const std::string uid = SceneUid(0);
  const Json& obj = fx["objects"]["objaverse"][uid];
  {
    Installer installer(Settings(FileRemote()), Quick());
    installer.Install(installer.PlanUids({uid}));
  }
  const fs::path file = VersionDir("objects", "objaverse") / obj["mjcf"].get<std::string>();
  fs::permissions(file, fs::perms::owner_write, fs::perm_options::add);
  { std::ofstream(file, std::ios::app) << "<!-- tampered -->"; }
  const auto r = RunCli({"verify"}, Env() + "MLSPACES_REMOTE_URL=" + FileRemote() + " ");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.out, HasSubstr(file.string()));
  const auto repair =
      RunCli({"verify", "--repair"}, Env() + "MLSPACES_REMOTE_URL=" + FileRemote() + " ");
  EXPECT_EQ(repair.exit_code, 1);
  EXPECT_THAT(repair.out, HasSubstr("will be installed again"));
  EXPECT_FALSE(IsFile(VersionDir("objects", "objaverse") /
                      ExtractFlagName(obj["archive"].get<std::string>())));
  const auto again = RunCli({"install", "--remote", FileRemote(), "--quiet", uid}, Env());
  EXPECT_EQ(again.exit_code, 0) << again.err;
  EXPECT_TRUE(Installed("objects", "objaverse", obj["archive"].get<std::string>()));
  EXPECT_EQ(RunCli({"verify"}, Env() + "MLSPACES_REMOTE_URL=" + FileRemote() + " ").exit_code, 0);
}

/// A URL on 127.0.0.1 whose port nothing listens on (bound, then closed): every fetch fails.
std::string DeadRemote() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof(addr);
  EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  EXPECT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len), 0);
  ::close(fd);
  return "http://127.0.0.1:" + std::to_string(ntohs(addr.sin_port)) + "/remote";
}

/// Sets an environment variable for one scope.
struct ScopedEnv {
  std::string name;
  ScopedEnv(std::string n, const char* value) : name(std::move(n)) {
    ::setenv(name.c_str(), value, 1);
  }
  ~ScopedEnv() { ::unsetenv(name.c_str()); }
};

TEST_F(MolmoRemoteTest, ACompleteCacheNeedsNoNetworkAndTheListingIsOptional) {
  const std::string uid = SceneUid(0);
  const std::string index = std::to_string(fx["scenes"]["ithor"]["FloorPlan1"]["index"].get<int>());
  {
    Installer online(Settings(FileRemote()), Quick());
    online.Install(online.PlanUids({uid}));
    SceneRequest request;
    online.Install(online.PlanScene(index, &request));
    online.Install(online.PlanSceneContents(request));
    online.Install(online.PlanLibrary("robots/franka_droid", {}));
  }
  const std::string dead = DeadRemote();
  std::vector<std::string> notes;
  InstallOptions o = Quick();
  o.note = [&](const std::string& n) { notes.push_back(n); };
  Installer offline(Settings(dead), o);
  // Installed already: every plan is made from the cache, and installing it is a no-op.
  const InstallPlan again = offline.PlanUids({uid});
  EXPECT_TRUE(again.archives.empty());
  EXPECT_GT(again.already_installed, 0u);
  offline.Install(again);
  SceneRequest request;
  const InstallPlan scene = offline.PlanScene(index, &request);
  EXPECT_TRUE(scene.archives.empty());
  EXPECT_TRUE(offline.PlanSceneContents(request).archives.empty());
  EXPECT_TRUE(offline.PlanLibrary("robots/franka_droid", {}).archives.empty());
  for (const std::string& n : notes) EXPECT_THAT(n, ::testing::Not(HasSubstr("listing"))) << n;
  // Planning an archive not installed yet needs only the cached tries; fetching it fails,
  // naming the URL, and leaves nothing behind.
  std::string other;
  for (const auto& [u, info] : fx["objects"]["objaverse"].items()) {
    if (info["archive"] != fx["objects"]["objaverse"][uid]["archive"] &&
        !Installed("objects", "objaverse", info["archive"].get<std::string>())) {
      other = u;
    }
  }
  ASSERT_FALSE(other.empty());
  const InstallPlan missing = offline.PlanUids({other});
  ASSERT_FALSE(missing.archives.empty());
  ExpectError([&] { offline.Install(missing); }, {dead});
  ExpectNothingHalfInstalled();
  // An unknown UID asks for the optional listing: unreachable, it is a note; the error is
  // the UID's.
  ExpectError([&] { offline.PlanUids({"no_such_uid_z"}); },
              {"no_such_uid_z not found in object sources", "listing", "mlspaces_sources.json"});
  // Once read in vain, a plan that succeeds says so in a note.
  EXPECT_TRUE(offline.PlanUids({uid}).archives.empty());
  ASSERT_FALSE(notes.empty());
  EXPECT_THAT(notes.back(), HasSubstr("mlspaces_sources.json"));
  // The CLI: installing what is installed succeeds with the dead remote.
  const auto cli = RunCli({"install", "--remote", dead, uid}, Env());
  EXPECT_EQ(cli.exit_code, 0) << cli.err;
  const auto cli_scene = RunCli({"install", "--remote", dead, "--scene", index}, Env());
  EXPECT_EQ(cli_scene.exit_code, 0) << cli_scene.err;
  // A source missing from the cache: the listing is tried, then the source's own fetch fails:
  // one line, exit 1.
  fs::remove_all(tmp / "cache" / "robots");
  const auto gone = RunCli({"install", "--remote", dead, uid}, Env());
  EXPECT_EQ(gone.exit_code, 1) << gone.err;
  EXPECT_EQ(std::count(gone.err.begin(), gone.err.end(), '\n'), 1) << gone.err;
  EXPECT_THAT(gone.err, HasSubstr("127.0.0.1"));
}

TEST_F(MolmoRemoteTest, BulkSetUpInstallsEverySceneUnlinkedAndAllObjectsAndGrasps) {
  const std::string uid = SceneUid(0);
  {
    ScopedEnv bulk("MLSPACES_DOWNLOAD_EXTRACT_ALL_SCENES_OBJECTS_GRASPS", "True");
    {
      ScopedEnv child("_IN_MULTIPROCESSING_CHILD", "1");  // a child: post_setup's default
      ResourceSettings s = Settings(FileRemote());
      s.cache_dir = tmp / "child_cache";
      s.assets_dir = tmp / "child_assets";
      Installer installer(s, Quick());
      installer.Install(installer.PlanUids({uid}));
      const fs::path dir = s.cache_dir / "objects" / "objaverse" /
                           fx["versions"]["objects"]["objaverse"].get<std::string>();
      for (const auto& [archive, a] : fx["sources"]["objects"]["objaverse"]["archives"].items()) {
        EXPECT_EQ(IsFile(dir / ExtractFlagName(archive)),
                  archive == fx["objects"]["objaverse"][uid]["archive"])
            << archive;
      }
    }
    Installer installer(Settings(FileRemote()), Quick());
    installer.Install(installer.PlanUids({uid}));
  }
  for (const auto& [type, sources] : fx["sources"].items()) {
    for (const auto& [source, info] : sources.items()) {
      for (const auto& [archive, a] : info["archives"].items()) {
        const bool bulk = type == "scenes" || type == "objects" || type == "grasps";
        if (!bulk && info["install"] != "eager") continue;
        EXPECT_TRUE(Installed(type, source, archive)) << type << "/" << source << " " << archive;
      }
    }
  }
  // Scene archives without links, except what the scene request then asks for.
  const Json& scene = fx["scenes"]["ithor"]["FloorPlan1"];
  const fs::path scenes = tmp / "assets" / "scenes" / "ithor";
  for (const auto& [archive, a] : fx["sources"]["scenes"]["ithor"]["archives"].items()) {
    EXPECT_FALSE(IsFile(scenes / ("." + archive + "_complete_links"))) << archive;
  }
  EXPECT_FALSE(fs::exists(scenes / scene["xml"].get<std::string>()));
  Installer installer(Settings(FileRemote()), Quick());
  SceneRequest request;
  const InstallPlan plan = installer.PlanScene(std::to_string(scene["index"].get<int>()), &request);
  EXPECT_TRUE(plan.archives.empty());
  EXPECT_TRUE(fs::is_symlink(scenes / scene["xml"].get<std::string>()));
  ExpectError(
      [&] {
        ScopedEnv bad("MLSPACES_DOWNLOAD_EXTRACT_ALL_SCENES_OBJECTS_GRASPS", "maybe");
        Installer(Settings(FileRemote()), Quick()).PlanUids({uid});
      },
      {"MLSPACES_DOWNLOAD_EXTRACT_ALL_SCENES_OBJECTS_GRASPS='maybe'"});
}

TEST_F(MolmoRemoteTest, CliErrorsAreOneLineWithExitOne) {
  const auto unknown = RunCli({"install", "--remote", FileRemote(), "no_such_uid_y"}, Env());
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_THAT(unknown.err, HasSubstr("no_such_uid_y not found in object sources"));
  EXPECT_EQ(std::count(unknown.err.begin(), unknown.err.end(), '\n'), 1) << unknown.err;
  const auto scene = RunCli({"install", "--remote", FileRemote(), "--scene", "4343"}, Env());
  EXPECT_EQ(scene.exit_code, 1);
  EXPECT_THAT(scene.err, HasSubstr("no scene 4343"));
  const auto usage =
      RunCli({"install", "--remote", FileRemote(), "--license-policy", "nc", SceneUid(0)}, Env());
  EXPECT_EQ(usage.exit_code, 2) << usage.err;
}

}  // namespace
}  // namespace mlspaces
