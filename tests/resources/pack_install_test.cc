// pack -> serve over HTTP -> install -> locate -> load grasps, and the install's fault
// tolerance: truncated transfers, flipped bytes, HTTP 500, the server gone, SIGKILLed
// installers and concurrent installers. Every fault is followed by a plain rerun that must
// complete with nothing corrupt and no manual clean-up.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <thread>

#include "http_test_server.h"
#include "library_fixture.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/resources/archive.h"
#include "mlspaces/resources/installer.h"
#include "mlspaces/resources/pack.h"
#include "mlspaces/resources/package.h"
#include "mlspaces/resources/sha256.h"
#include "test_util.h"

namespace mlspaces {
namespace {
namespace fs = std::filesystem;
using testing::ExpectError;
using testing::FixtureUid;
using ::testing::HasSubstr;
using testing::RunCli;
using testing::Slurp;
using testing::TempDir;

constexpr size_t kAssets = 24;

/// A packed fixture library ("fixlib", version "1", 3 assets per archive) under <tmp>/remote.
class PackInstallTest : public ::testing::Test {
 protected:
  void SetUp() override {
    library = tmp / "library";
    testing::MakeFixtureLibrary(library, kAssets);
    remote = tmp / "remote";
    PackOptions options;
    options.name = "fixlib";
    options.version = "1";
    options.assets_per_archive = 3;
    report = PackLibrary(library, remote, options);
    package = remote / "objects" / "fixlib" / "1";
    manifest = PackageManifest::Load(package / "mlspaces_package.json");
  }

  ResourceSettings Settings(const std::string& url) const {
    ResourceSettings s;
    s.cache_dir = tmp / "cache";
    s.assets_dir = tmp / "assets";
    s.remote_url = url;
    s.versions = BuiltinSourceVersions();
    s.versions["objects"]["fixlib"] = "1";
    return s;
  }

  /// The environment for CLI runs against `url`.
  std::string Env(const std::string& url) const {
    return "env MLSPACES_CACHE_DIR=" + testing::ShellQuote((tmp / "cache").string()) +
           " MLSPACES_ASSETS_DIR=" + testing::ShellQuote((tmp / "assets").string()) +
           " MLSPACES_REMOTE_URL=" + testing::ShellQuote(url) + " MLSPACES_PINNED_ASSETS_FILE= ";
  }

  /// Registry over the assets dir, and one over the unpacked library, for comparisons.
  Registry Installed() const {
    Registry::Options o;
    o.assets_dir = tmp / "assets";
    return Registry(o);
  }
  Registry Unpacked() const {
    Registry r;
    r.RegisterAssetLibrary("fixlib", library);
    r.RegisterGraspLibrary("fixlib", library, "fixlib");
    return r;
  }

  /// Every installed file matches the manifest, and the grasps of every installed UID equal
  /// the unpacked library's.
  void ExpectIntactInstall(size_t expect_archives) {
    Installer installer(Settings("file:///nonexistent"));
    size_t checked = 0;
    const auto problems = installer.Verify({}, false, &checked);
    for (const auto& p : problems) ADD_FAILURE() << p.ToString();
    size_t flags = 0;
    for (const PackageArchive& a : manifest.archives) {
      flags += fs::exists(tmp / "cache" / "objects" / "fixlib" / "1" / ExtractFlagName(a.name));
    }
    EXPECT_EQ(flags, expect_archives);
    EXPECT_GT(checked, 0u);
    // No temp, partial or staging files left behind.
    const fs::path dir = tmp / "cache" / "objects" / "fixlib" / "1";
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
      const std::string name = e.path().filename().string();
      EXPECT_EQ(name.find(".tmp."), std::string::npos) << e.path();
      EXPECT_EQ(name.find(".part"), std::string::npos) << e.path();
    }
    EXPECT_FALSE(fs::exists(dir / ".mlspaces" / "staging") &&
                 !fs::is_empty(dir / ".mlspaces" / "staging"));
  }

  TempDir tmp;
  fs::path library, remote, package;
  PackReport report;
  PackageManifest manifest;
};

TEST_F(PackInstallTest, PackWritesArchivesStoresAndManifests) {
  EXPECT_EQ(report.assets, kAssets);
  EXPECT_EQ(report.archives, 8u);
  EXPECT_EQ(manifest.name, "fixlib");
  EXPECT_EQ(manifest.version, "1");
  EXPECT_EQ(manifest.num_assets, kAssets);
  EXPECT_EQ(manifest.robots, (std::vector<std::string>{"droid", "rum"}));
  ASSERT_EQ(manifest.archives.size(), 8u);
  // Every file's size and SHA-256 are right.
  for (const PackageArchive& a : manifest.archives) {
    const FileDigest d = Sha256File(package / a.name);
    EXPECT_EQ(d.size, a.size);
    EXPECT_EQ(d.sha256, a.sha256);
    EXPECT_EQ(a.assets, 3u);
  }
  for (const auto& [file, info] : manifest.files) {
    EXPECT_EQ(Sha256File(package / file).sha256, info.sha256) << file;
  }
  // The first archive holds its assets' folders (meshes too), the shard and the listing, and
  // not the grasp NPZs (their poses are in the shard).
  const std::vector<std::string> members = ListTarZst(package / "fixlib_00000.tar.zst");
  EXPECT_THAT(members, ::testing::Contains("obj_1000/obj_1000.xml"));
  EXPECT_THAT(members, ::testing::Contains("obj_1000/meshes/part.obj"));
  EXPECT_THAT(members, ::testing::Contains("obj_1000/obj_1000.npz"));
  EXPECT_THAT(members, ::testing::Contains(".mlspaces/grasps/fixlib_00000.mlsg"));
  EXPECT_THAT(members, ::testing::Contains(".mlspaces/members/fixlib_00000.json"));
  EXPECT_THAT(members, ::testing::Not(::testing::Contains("obj_1000/droid/grasps.npz")));
  // The remote lists what it serves; the original's size manifest and tries load in Python.
  EXPECT_THAT(Slurp(remote / "mlspaces_sources.json"), HasSubstr("\"fixlib\": \"1\""));
  std::string out;
  ASSERT_EQ(testing::RunPython(tmp.path(), R"(
import gzip, json, sys
d = sys.argv[1]
sizes = json.load(open(d + '/mjthor_resource_file_to_size_mb.json'))
tries = json.load(gzip.open(d + '/mjthor_resources_combined_meta.json.gz'))
assert sorted(sizes) == sorted(tries), (sorted(sizes), sorted(tries))
print(len(sizes), sorted(tries['fixlib_00000.tar.zst']['obj_1000']))
)",
                               testing::ShellQuote(package.string()), &out),
            0);
  EXPECT_EQ(out, "8 ['meshes', 'obj_1000.json', 'obj_1000.npz', 'obj_1000.xml']\n");
}

TEST_F(PackInstallTest, PackIsDeterministicAndRefusesToOverwrite) {
  PackOptions options;
  options.name = "fixlib";
  options.version = "1";
  options.assets_per_archive = 3;
  options.threads = 1;  // other scheduling than the fixture's: same bytes
  PackLibrary(library, tmp / "remote2", options);
  for (const auto& e : fs::recursive_directory_iterator(package)) {
    if (!e.is_regular_file()) continue;
    const fs::path other =
        tmp / "remote2" / "objects" / "fixlib" / "1" / e.path().lexically_relative(package);
    EXPECT_EQ(Slurp(e.path()), Slurp(other)) << e.path();
  }
  ExpectError([&] { PackLibrary(library, remote, options); }, {"already exists", "--overwrite"});
  options.overwrite = true;
  EXPECT_NO_THROW(PackLibrary(library, remote, options));
  ExpectError([&] { PackLibrary(tmp / "nowhere", remote, options); },
              {"no assets_index.json", "index-assets"});
  options.name = "bad/name";
  EXPECT_THROW(PackLibrary(library, remote, options), UsageError);
}

TEST(PackUnitsTest, RootLevelAssetsAndNestedFoldersGoTogether) {
  TempDir tmp;
  const fs::path lib = tmp / "lib";
  auto asset = [&](const std::string& rel_dir, const std::string& uid) {
    const fs::path d = rel_dir.empty() ? lib : lib / rel_dir;
    testing::WriteText(d / (uid + ".xml"), "<mujoco model=\"" + uid + "\"/>\n");
    testing::WriteText(d / (uid + ".json"), testing::MinimalMetadata(uid));
  };
  asset("", "at_root");           // brings only its own files
  asset("outer", "outer");        // its folder and everything under it...
  asset("outer/inner", "inner");  // ...including a nested asset's folder
  testing::WriteText(lib / "outer" / "textures" / "t.png", "png");
  testing::WriteText(lib / "README.txt", "not an asset file");
  WriteAssetIndex(lib, AssetIndexOptions{});
  PackOptions options;
  options.name = "units";
  options.version = "1";
  options.assets_per_archive = 1;
  const PackReport report = PackLibrary(lib, tmp / "out", options);
  const fs::path pkg = tmp / "out" / "objects" / "units" / "1";
  // Units ordered by their first UID: at_root, inner+outer (one unit, 2 assets).
  ASSERT_EQ(report.archives, 2u);
  auto members = [&](const std::string& archive) {
    std::vector<std::string> out;
    for (const std::string& m : ListTarZst(pkg / archive)) {
      if (m.rfind(".mlspaces/", 0) != 0) out.push_back(m);
    }
    return out;
  };
  EXPECT_EQ(members("units_00000.tar.zst"),
            (std::vector<std::string>{"at_root.json", "at_root.xml"}));
  EXPECT_EQ(
      members("units_00001.tar.zst"),
      (std::vector<std::string>{"outer/inner/inner.json", "outer/inner/inner.xml",
                                "outer/outer.json", "outer/outer.xml", "outer/textures/t.png"}));
  const PackageManifest m = PackageManifest::Load(pkg / "mlspaces_package.json");
  EXPECT_EQ(m.archives[1].assets, 2u);
}

TEST(PackUnitsTest, LeftOutFilesAreWarningsNamingFileAndUid) {
  TempDir tmp;
  const fs::path lib = tmp / "lib";
  testing::WriteText(lib / "box" / "box.xml", "<mujoco model=\"box\"/>\n");
  testing::WriteText(lib / "box" / "box.json", testing::MinimalMetadata("box"));
  fs::create_symlink("box.json", lib / "box" / "link.txt");
  WriteAssetIndex(lib, AssetIndexOptions{});
  // A grasp library with grasps for a UID the asset index lacks.
  const fs::path grasps = tmp / "grasps";
  WriteNpz(grasps / "ghost" / "droid" / "grasps.npz",
           {{"transforms", NpyArray::FromDoubles({1, 4, 4}, std::vector<double>(16, 0.0))}});
  WriteGraspIndex(grasps, GraspIndexOptions{});
  PackOptions options;
  options.name = "warn";
  options.version = "1";
  options.grasp_dir = grasps;
  const PackReport report = PackLibrary(lib, tmp / "out", options);
  ASSERT_EQ(report.warnings.size(), 2u);
  const Diagnostic& ghost = report.warnings[0];  // found while reading the grasps, first
  EXPECT_EQ(ghost.path, (grasps / "ghost" / "droid" / "grasps.npz").string());
  EXPECT_EQ(ghost.uid, "ghost");
  EXPECT_EQ(ghost.severity, Severity::kWarning);
  EXPECT_EQ(ghost.ToString(), ghost.path +
                                  ": grasps for UID ghost, which is not in the asset index, "
                                  "not packed");
  const Diagnostic& link = report.warnings[1];
  EXPECT_EQ(link.path, (fs::absolute(lib) / "box" / "link.txt").string());
  EXPECT_EQ(link.uid, "");
  EXPECT_EQ(link.ToString(), link.path + ": symbolic link not packed");
}

TEST_F(PackInstallTest, ServeInstallLocateAndLoadGrasps) {
  testing::HttpTestServer server(remote);
  Installer installer(Settings(server.url()));
  const InstallPlan plan = installer.PlanUids({FixtureUid(4), FixtureUid(5)});
  ASSERT_EQ(plan.archives.size(), 1u);  // both in archive 1 (assets 3, 4, 5)
  EXPECT_EQ(plan.archives[0].archive, "fixlib_00001.tar.zst");
  EXPECT_EQ(plan.download_bytes, manifest.archives[1].size);
  installer.Install(plan);
  ExpectIntactInstall(1);

  // Lookups through the assets dir: the packed library answers, for installed and not.
  const Registry installed = Installed();
  const Registry unpacked = Unpacked();
  const auto loc = installed.Locate(FixtureUid(4));
  ASSERT_TRUE(loc);
  EXPECT_EQ(loc->library, "fixlib");
  EXPECT_EQ(loc->archive, "fixlib_00001.tar.zst");
  EXPECT_TRUE(loc->installed);
  EXPECT_EQ(loc->mjcf_path, tmp / "assets" / "objects" / "fixlib" / "obj_1004" / "obj_1004.xml");
  EXPECT_EQ(Slurp(loc->mjcf_path), Slurp(library / "obj_1004" / "obj_1004.xml"));
  const auto other = installed.Locate(FixtureUid(0));
  ASSERT_TRUE(other);
  EXPECT_FALSE(other->installed);
  EXPECT_FALSE(installed.Locate("obj_9999"));

  // Annotations and grasps equal the unpacked library's, draws included.
  for (int uid_i : {3, 4, 5}) {
    const std::string uid = FixtureUid(uid_i);
    auto a = installed.GetAnnotation(uid);
    auto b = unpacked.GetAnnotation(uid);
    ASSERT_TRUE(a && b);
    EXPECT_EQ(a->json, b->json);
    EXPECT_EQ(a->ToJson(), b->ToJson());
    for (size_t num : {2u, 50u}) {
      const std::vector<std::string> filter_a = {"fixlib/droid"}, filter_b = {"fixlib/droid"};
      GraspSet ga = installed.LoadGrasps({uid, "", filter_a}, num, 7);
      GraspSet gb = unpacked.LoadGrasps({uid, "", filter_b}, num, 7);
      EXPECT_EQ(ga.indices, gb.indices);
      ASSERT_EQ(ga.poses.size(), gb.poses.size());
      for (size_t i = 0; i < ga.poses.size(); ++i) EXPECT_EQ(ga.poses[i].m, gb.poses[i].m);
    }
    EXPECT_EQ(installed.HasValidGrasps({uid, "hinge"}, 4), uid_i % 3 == 0);
    EXPECT_EQ(installed.GraspLibrariesFor(uid), unpacked.GraspLibrariesFor(uid));
  }
  GraspSet joint = installed.LoadGrasps({FixtureUid(3), "hinge"});
  EXPECT_EQ(joint.poses.size(), 4u);
  // Grasps of a UID whose archive is not installed are not there yet.
  EXPECT_FALSE(installed.HasValidGrasps({FixtureUid(0)}));

  // The CLI reads the same install.
  const auto cli = RunCli({"locate", FixtureUid(0)}, Env(server.url()));
  EXPECT_EQ(cli.exit_code, 0) << cli.err;
  EXPECT_THAT(cli.out, HasSubstr("archive: fixlib_00000.tar.zst (not installed"));
  const auto grasps = RunCli({"grasps", FixtureUid(4), "--num", "2"}, Env(server.url()));
  EXPECT_EQ(grasps.exit_code, 0) << grasps.err;
  EXPECT_THAT(grasps.out, HasSubstr("library: fixlib/droid"));
  const auto meta = RunCli({"meta", FixtureUid(3)}, Env(server.url()));
  EXPECT_EQ(meta.exit_code, 0) << meta.err;
  EXPECT_THAT(meta.out, HasSubstr("\"category\": \"block\""));
  EXPECT_THAT(meta.out, HasSubstr("\"counts\": ["));
}

TEST_F(PackInstallTest, InstallLibraryWhereWithSizeEstimateAndVerify) {
  testing::HttpTestServer server(remote);
  const auto dry =
      RunCli({"install", "--library", "fixlib", "--where", "category=mug", "--dry-run"},
             Env(server.url()));
  ASSERT_EQ(dry.exit_code, 0) << dry.err;
  // 12 mugs (even i) spread over all 8 archives.
  EXPECT_THAT(dry.out, HasSubstr("12 assets in 8 archives to install"));
  const auto tagged =
      RunCli({"install", "--library", "fixlib", "--where", "tags=t1", "-q"}, Env(server.url()));
  ASSERT_EQ(tagged.exit_code, 0) << tagged.err;
  EXPECT_THAT(tagged.out, HasSubstr("8 assets in"));
  const auto all = RunCli({"install", "--library", "fixlib", "-q"}, Env(server.url()));
  ASSERT_EQ(all.exit_code, 0) << all.err;
  ExpectIntactInstall(8);
  const auto verify = RunCli({"verify"}, Env(server.url()));
  EXPECT_EQ(verify.exit_code, 0) << verify.out << verify.err;
  EXPECT_THAT(verify.out, HasSubstr(": ok"));
  // By name: the same files; a name that is no installed source is an error (it was "checked
  // 0 files: ok").
  const auto named = RunCli({"verify", "fixlib"}, Env(server.url()));
  EXPECT_EQ(named.exit_code, 0) << named.err;
  EXPECT_EQ(named.out, verify.out);
  const auto typo = RunCli({"verify", "fixlb"}, Env(server.url()));
  EXPECT_EQ(typo.exit_code, 1) << typo.out;
  EXPECT_THAT(typo.err, HasSubstr("no installed source named 'fixlb' (did you mean 'fixlib'? "
                                  "installed: fixlib)"));
  EXPECT_EQ(typo.err.find('\n'), typo.err.size() - 1) << typo.err;

  // Damage one installed file: verify names it; --repair unflags its archive; install again.
  const fs::path mesh =
      tmp / "cache" / "objects" / "fixlib" / "1" / "obj_1007" / "meshes" / "part.obj";
  fs::permissions(mesh, fs::perms::owner_write, fs::perm_options::add);
  testing::WriteText(mesh, "damaged");
  const auto bad = RunCli({"verify", "--repair"}, Env(server.url()));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_THAT(bad.out, HasSubstr("obj_1007/meshes/part.obj: size 7"));
  const auto again = RunCli({"install", FixtureUid(7), "-q"}, Env(server.url()));
  ASSERT_EQ(again.exit_code, 0) << again.err;
  ExpectIntactInstall(8);

  const auto unknown = RunCli({"install", "nope_uid"}, Env(server.url()));
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_THAT(unknown.err, HasSubstr("nope_uid not found in object sources ["));
  EXPECT_THAT(unknown.err, HasSubstr("fixlib"));
  const auto usage = RunCli({"install"}, Env(server.url()));
  EXPECT_EQ(usage.exit_code, 2);
}

TEST_F(PackInstallTest, FaultsThenAPlainRerunCompletes) {
  testing::HttpTestServer server(remote);
  const std::string a0 = "/objects/fixlib/1/fixlib_00000.tar.zst";
  const std::string a1 = "/objects/fixlib/1/fixlib_00001.tar.zst";
  const std::string a2 = "/objects/fixlib/1/fixlib_00002.tar.zst";
  const std::string idx = "/objects/fixlib/1/uid_index.mlsx";
  InstallOptions quick;
  quick.retries = 1;
  // Truncated transfer (resumed by the retry), one flipped byte (a checksum error: this run
  // fails), HTTP 500 (retried), and a store file cut short.
  server.SetFaults("{\"" + a0 +
                   "\": [{\"mode\": \"truncate\", \"after\": 100}],"
                   "\"" +
                   a1 +
                   "\": [{\"mode\": \"flip\", \"after\": 50}],"
                   "\"" +
                   a2 +
                   "\": [{\"mode\": \"500\"}],"
                   "\"" +
                   idx + "\": [{\"mode\": \"truncate\", \"after\": 10}]}");
  {
    Installer installer(Settings(server.url()), quick);
    const InstallPlan plan = installer.PlanUids({FixtureUid(0), FixtureUid(3), FixtureUid(6)});
    ExpectError([&] { installer.Install(plan); }, {"fixlib_00001.tar.zst"});
  }
  bool resumed = false;
  for (const std::string& line : server.LogLines()) {
    resumed |= line.find(a0) != std::string::npos && line.find("bytes=100-") != std::string::npos;
  }
  EXPECT_TRUE(resumed) << "the truncated download was not resumed with a Range request";
  {
    Installer installer(Settings(server.url()), quick);
    installer.Install(installer.PlanUids({FixtureUid(0), FixtureUid(3), FixtureUid(6)}));
  }
  ExpectIntactInstall(3);

  // The server gone in the middle of a transfer: an error; back again: the rerun completes.
  server.SetFaults(
      "{\"/objects/fixlib/1/fixlib_00003.tar.zst\": [{\"mode\": \"hang\", \"after\": 64}]}");
  // Killed once the hanging request has arrived (the server logs it before answering).
  std::thread killer([&] {
    testing::WaitUntil("the hanging request", [&] {
      for (const std::string& line : server.LogLines()) {
        if (line.find("fixlib_00003") != std::string::npos &&
            line.find("\"hang\"") != std::string::npos) {
          return true;
        }
      }
      return false;
    });
    server.Kill();
  });
  {
    Installer installer(Settings(server.url()), quick);
    const InstallPlan plan = installer.PlanUids({FixtureUid(9)});
    EXPECT_THROW(installer.Install(plan), Error);
  }
  killer.join();
  testing::HttpTestServer back(remote);
  {
    Installer installer(Settings(back.url()), quick);
    installer.Install(installer.PlanUids({FixtureUid(9)}));
  }
  ExpectIntactInstall(4);
}

// Installers SIGKILLed at counted steps (crash_point.h): a first install counts its durable
// steps (download chunks, files renamed into place, archives placed, flags, symlinks,
// manifests); then each trial kills an install after step N, N drawn over all of them, and
// kills the recovering rerun at a second drawn step as well. A plain rerun must then complete
// to an intact install. Where each kill lands depends on the work done, never on the clock.
TEST_F(PackInstallTest, KilledInstallersAtCountedStepsResumeToAnIntactInstall) {
  testing::HttpTestServer server(remote);
  const std::string env = Env(server.url());
  const testing::CrashPoints crash(tmp / "crash_counter");
  const std::vector<std::string> args = {"install", "--library", "fixlib", "-q", "-j", "2"};
  const auto first = RunCli(args, env + crash.Counting());
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const uint64_t steps = crash.Count();
  ExpectIntactInstall(8);
  // Per archive at least: its files renamed into place, "placed", its flag.
  ASSERT_GE(steps, 3 * manifest.archives.size());
  fs::remove_all(tmp / "cache");
  fs::remove_all(tmp / "assets");
  ASSERT_EQ(RunCli(args, env + crash.Counting()).exit_code, 0);
  ASSERT_EQ(crash.Count(), steps) << "the step count of a clean install must not vary";

  Rng rng(2026);
  int second_kills = 0;  // recovering reruns killed too (a drawn step past their work is fine)
  for (int trial = 0; trial < 16; ++trial) {
    fs::remove_all(tmp / "cache");
    fs::remove_all(tmp / "assets");
    const uint64_t n = 1 + rng.UniformInt(steps);
    const auto cut = RunCli(args, env + crash.KillAt(n));
    ASSERT_TRUE(cut.sigkilled) << "trial " << trial << ": step " << n << " of " << steps
                               << " did not kill (exit " << cut.exit_code << "): " << cut.err;
    EXPECT_THAT(cut.err, HasSubstr("crash point " + std::to_string(n) + " ("));
    const uint64_t m = 1 + rng.UniformInt(steps);
    const auto recovering = RunCli(args, env + crash.KillAt(m));
    if (recovering.sigkilled) {
      ++second_kills;
    } else {
      ASSERT_EQ(recovering.exit_code, 0) << "trial " << trial << ": " << recovering.err;
    }
    const auto rerun = RunCli({"install", "--library", "fixlib", "-q"}, env);
    ASSERT_EQ(rerun.exit_code, 0) << "trial " << trial << " (killed after step " << n << " of "
                                  << steps << ", then " << m << "): " << rerun.err;
    ExpectIntactInstall(8);
    if (HasFailure()) FAIL() << "trial " << trial << ": killed after step " << n << ", then " << m;
  }
  std::printf(
      "[kills] 16 of 16 installs killed inside the work (%llu steps); %d of 16 "
      "recovering reruns killed as well\n",
      static_cast<unsigned long long>(steps), second_kills);

  // A few kills from outside at unplanned moments, as a user's Ctrl-\ or a node failure would
  // send them. Whether they land inside the install depends on the machine's load, so it is
  // reported, not judged; the rerun must complete either way.
  int landed = 0;
  for (int trial = 0; trial < 3; ++trial) {
    fs::remove_all(tmp / "cache");
    fs::remove_all(tmp / "assets");
    const pid_t pid = testing::SpawnCli(args, env);
    ASSERT_GE(pid, 0);
    ::usleep(static_cast<useconds_t>(rng.Uniform(0.0, 0.2) * 1e6));
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    landed += WIFSIGNALED(status);
    const auto rerun = RunCli({"install", "--library", "fixlib", "-q"}, env);
    ASSERT_EQ(rerun.exit_code, 0) << "asynchronous trial " << trial << ": " << rerun.err;
    ExpectIntactInstall(8);
  }
  std::printf("[kills] %d of 3 asynchronous kills landed inside an install\n", landed);
}

// pack SIGKILLed after each drawn step (archives, stores, manifests, the rename that publishes
// the package): a rerun (with --overwrite, as the error of a pack killed after publishing
// asks) gives the same bytes as an uninterrupted pack, and no temp folder is left.
TEST_F(PackInstallTest, KilledPackAtCountedStepsRerunsToTheSameBytes) {
  const testing::CrashPoints crash(tmp / "crash_counter");
  auto args = [&](const fs::path& out) {
    return std::vector<std::string>{
        "pack", library.string(),       out.string(), "--name", "fixlib", "--version",
        "1",    "--assets-per-archive", "3",          "-q"};
  };
  const auto whole = RunCli(args(tmp / "whole"), crash.Counting());
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  const uint64_t steps = crash.Count();
  ASSERT_GE(steps, manifest.archives.size() + 3);
  std::map<std::string, std::string> expected;
  for (const std::string& f : testing::ListFiles(tmp / "whole")) {
    expected[f] = Slurp(tmp / "whole" / f);
  }
  Rng rng(7);
  for (int trial = 0; trial < 8; ++trial) {
    const fs::path out = tmp / ("cut" + std::to_string(trial));
    const uint64_t n = 1 + rng.UniformInt(steps);
    const auto cut = RunCli(args(out), crash.KillAt(n));
    ASSERT_TRUE(cut.sigkilled) << "step " << n << " of " << steps << ": " << cut.err;
    std::vector<std::string> again = args(out);
    again.push_back("--overwrite");
    const auto rerun = RunCli(again);
    ASSERT_EQ(rerun.exit_code, 0) << "killed after step " << n << ": " << rerun.err;
    std::map<std::string, std::string> got;
    for (const std::string& f : testing::ListFiles(out)) got[f] = Slurp(out / f);
    EXPECT_TRUE(got == expected) << "killed after step " << n << " of " << steps;
    for (const auto& [f, bytes] : got) {
      EXPECT_TRUE(expected.count(f) && expected[f] == bytes) << "differs or extra: " << f;
    }
  }
  std::printf("[kills] 8 of 8 packs killed inside the work (%llu steps)\n",
              static_cast<unsigned long long>(steps));
}

TEST_F(PackInstallTest, ConcurrentInstallersShareOneCache) {
  testing::HttpTestServer server(remote);
  const std::string env = Env(server.url());
  std::vector<pid_t> pids;
  for (int i = 0; i < 3; ++i) {
    const pid_t pid = testing::SpawnCli({"install", "--library", "fixlib", "-q"}, env);
    ASSERT_GE(pid, 0);
    pids.push_back(pid);
  }
  for (pid_t pid : pids) {
    int status = 0;
    ::waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }
  ExpectIntactInstall(8);
}

TEST_F(PackInstallTest, CliBadInputIsOneLineAndAnExitCode) {
  auto one_line = [](const testing::CliResult& r) {
    return std::count(r.err.begin(), r.err.end(), '\n') == 1;
  };
  const std::string env = Env("http://127.0.0.1:1");  // nothing listens on port 1
  auto r = RunCli({"pack", (tmp / "nowhere").string(), (tmp / "out").string()}, env);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_TRUE(one_line(r)) << r.err;
  EXPECT_THAT(r.err, HasSubstr("index-assets"));
  r = RunCli({"pack", library.string(), (tmp / "out").string(), "--name", "a b"}, env);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_TRUE(one_line(r)) << r.err;
  r = RunCli({"pack", library.string(), (tmp / "out").string(), "--assets-per-archive", "0"}, env);
  EXPECT_EQ(r.exit_code, 2);
  r = RunCli({"install", "--where", "category=mug"}, env);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--where needs --library"));
  r = RunCli({"install", "--library", "fixlib", "--where", "nonsense"}, env);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("KEY=VALUE"));
  // An unreachable remote: one line naming the URL, after the retries.
  r = RunCli({"install", FixtureUid(1), "--pins", (tmp / "pins.json").string()},
             env + "MLSPACES_PINNED_ASSETS_FILE= ");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("Could not find pinned assets file"));
  testing::WriteText(tmp / "pins.json", "{\"objects\": {\"fixlib\": \"1\"}}");
  r = RunCli({"install", FixtureUid(1), "--pins", (tmp / "pins.json").string()}, env);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_TRUE(one_line(r)) << r.err;
  EXPECT_THAT(r.err, HasSubstr("http://127.0.0.1:1/"));
  // A damaged manifest on the remote: one line naming it and the field.
  testing::HttpTestServer server(remote);
  fs::permissions(package / "mlspaces_package.json", fs::perms::owner_write, fs::perm_options::add);
  std::string text = Slurp(package / "mlspaces_package.json");
  text.replace(text.find("\"num_assets\": 24"), 16, "\"num_assets\": -1");
  testing::WriteText(package / "mlspaces_package.json", text);
  r = RunCli({"install", FixtureUid(1)}, Env(server.url()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_TRUE(one_line(r)) << r.err;
  EXPECT_THAT(r.err, HasSubstr("mlspaces_package.json: /num_assets: expected a whole number"));
}

TEST_F(PackInstallTest, SettingsAndPinsFromTheEnvironment) {
  const fs::path pins = tmp / "pins.json";
  testing::WriteText(pins, "{\"objects\": {\"fixlib\": \"1\", \"objaverse\": null}}");
  ::setenv("MLSPACES_CACHE_DIR", (tmp / "c").c_str(), 1);
  ::setenv("MLSPACES_ASSETS_DIR", (tmp / "a").c_str(), 1);
  ::setenv("MLSPACES_PINNED_ASSETS_FILE", pins.c_str(), 1);
  ::setenv("MLSPACES_REMOTE_URL", "http://127.0.0.1:9/x", 1);
  ResourceSettings s = ResourceSettings::FromEnvironment();
  EXPECT_EQ(s.cache_dir, tmp / "c");
  EXPECT_EQ(s.assets_dir, tmp / "a");
  EXPECT_EQ(s.Version("objects", "fixlib"), "1");
  EXPECT_EQ(s.Version("objects", "thor"), "20251117");
  EXPECT_FALSE(s.Version("objects", "objaverse"));
  EXPECT_EQ(s.Url("objects", "thor", "20251117", "a.tar.zst"),
            "http://127.0.0.1:9/x/objects/thor/20251117/a.tar.zst");
  EXPECT_EQ(ResourceSettings::FromEnvironment("http://other/").remote_url, "http://other/");
  testing::WriteText(pins, "{\"objects\": {\"fixlib\": 3}}");
  ExpectError([] { ResourceSettings::FromEnvironment(); }, {"pins.json", "/objects/fixlib"});
  ::setenv("MLSPACES_PINNED_ASSETS_FILE", (tmp / "missing.json").c_str(), 1);
  ExpectError([] { ResourceSettings::FromEnvironment(); }, {"Could not find pinned assets file"});
  ::unsetenv("MLSPACES_PINNED_ASSETS_FILE");
  ::setenv("MLSPACES_ASSETS_DIR", (tmp / "c" / "inside").c_str(), 1);
  ExpectError([] { ResourceSettings::FromEnvironment(); }, {"is inside cache dir"});
  ::unsetenv("MLSPACES_CACHE_DIR");
  ::unsetenv("MLSPACES_ASSETS_DIR");
  ::unsetenv("MLSPACES_REMOTE_URL");
}

}  // namespace
}  // namespace mlspaces
