// mlspaces install / verify: packaged libraries and MolmoSpaces-format sources into the cache
// and the assets dir.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/progress.h"
#include "mlspaces/library/license_policy.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/resources/installer.h"

namespace mlspaces::cli {
namespace {

struct RemoteFlags {
  std::string remote;
  std::string pins;
  void AddTo(CLI::App& app) {
    app.add_option("--remote", remote,
                   "Base URL of the packages (http://, https://, file:// or a folder); "
                   "default MLSPACES_REMOTE_URL, else the MolmoSpaces bucket");
    app.add_option("--pins", pins,
                   "JSON pin file {type: {source: version}} (default MLSPACES_PINNED_ASSETS_FILE)");
  }
  ResourceSettings Settings() const { return ResourceSettings::FromEnvironment(remote, pins); }
};

struct InstallFlags {
  std::vector<std::string> uids;
  std::string library;
  std::string scene;
  std::string license_policy;
  std::vector<std::string> where;
  LibraryFlags libraries;
  bool dry_run = false;
  bool quiet = false;
  int jobs = 4;
  RemoteFlags remote;
};

std::string Mb(uint64_t bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f MB", bytes / 1e6);
  return buf;
}

void PrintPlan(const InstallPlan& plan) {
  std::printf(
      "%zu assets in %zu archives to install: %s to download (%s unpacked); "
      "%zu archives already installed",
      plan.assets, plan.archives.size(), Mb(plan.download_bytes).c_str(),
      Mb(plan.unpacked_bytes).c_str(), plan.already_installed);
  if (plan.left_out > 0) std::printf("; %zu left out by the licence policy", plan.left_out);
  if (plan.user_assets > 0) std::printf("; %zu in user libraries", plan.user_assets);
  std::printf("\n");
  std::fflush(stdout);
}

int RunInstall(const InstallFlags& flags) {
  if (!flags.where.empty() && flags.library.empty()) {
    throw UsageError("--where needs --library");
  }
  const int given = !flags.uids.empty() + !flags.library.empty() + !flags.scene.empty();
  if (given != 1) throw UsageError("give UIDs, --library NAME or --scene PATH_OR_INDEX (one)");
  std::vector<WhereFilter> where;
  for (const std::string& w : flags.where) where.push_back(WhereFilter::Parse(w));
  InstallOptions options;
  options.parallel_downloads = flags.jobs;
  options.dry_run = flags.dry_run;
  options.note = [](const std::string& text) {
    std::fprintf(stderr, "mlspaces: %s\n", text.c_str());
  };
  options.license_policy = ResolveLicensePolicy(
      flags.license_policy.empty() ? std::nullopt
                                   : std::optional<LicensePolicy>(ParseLicensePolicy(
                                         flags.license_policy, "--license-policy")));
  const LibraryFlags libraries = flags.libraries;
  options.open_registry = [libraries] { return libraries.Build(); };
  std::unique_ptr<ProgressBar> bar;
  options.progress = [&](uint64_t done, uint64_t total) {
    if (bar) bar->Update(static_cast<size_t>(done / 1000), Mb(done) + " of " + Mb(total));
  };
  Installer installer(flags.remote.Settings(), options);
  auto run = [&](const InstallPlan& plan) {
    PrintPlan(plan);
    if (flags.dry_run || plan.archives.empty()) return;
    bar = std::make_unique<ProgressBar>("install", static_cast<size_t>(plan.download_bytes / 1000),
                                        !flags.quiet);
    installer.Install(plan);
    bar->Finish();
    bar.reset();
    std::printf("installed %zu archives into %s\n", plan.archives.size(),
                installer.settings().cache_dir.c_str());
    std::fflush(stdout);
  };
  if (!flags.scene.empty()) {
    // The scene archive first: what it references is read from the installed scene.
    SceneRequest request;
    const InstallPlan scene = installer.PlanScene(flags.scene, &request);
    std::printf("scene %s in scenes/%s: ", flags.scene.c_str(), request.source.c_str());
    run(scene);
    if (flags.dry_run && !scene.archives.empty()) {
      std::printf("(dry run: the scene's objects and grasps are planned once it is installed)\n");
      return 0;
    }
    std::printf("objects and grasps of the scene: ");
    run(installer.PlanSceneContents(request));
    return 0;
  }
  run(flags.library.empty() ? installer.PlanUids(flags.uids)
                            : installer.PlanLibrary(flags.library, where));
  return 0;
}

struct VerifyFlags {
  std::vector<std::string> names;
  bool repair = false;
  RemoteFlags remote;
};

int RunVerify(const VerifyFlags& flags) {
  Installer installer(flags.remote.Settings());
  size_t checked = 0;
  const auto problems = installer.Verify(flags.names, flags.repair, &checked);
  for (const auto& p : problems) std::printf("%s\n", p.ToString().c_str());
  if (problems.empty()) {
    std::printf("checked %zu files: ok\n", checked);
    return 0;
  }
  std::printf("checked %zu files: %zu problems%s\n", checked, problems.size(),
              flags.repair ? " (run mlspaces install again to repair)" : "");
  return 1;
}

}  // namespace

void AddInstall(CLI::App& app, Action& action) {
  auto flags = std::make_shared<InstallFlags>();
  CLI::App* sub = app.add_subcommand(
      "install",
      "Download, verify and install assets (with their grasps) by UID, a whole library "
      "(--library NAME [--where KEY=VALUE]) or a scene with its objects and grasps (--scene), "
      "from mlspaces packages or MolmoSpaces-format remotes");
  sub->add_option("UID", flags->uids, "Asset UIDs");
  sub->add_option("--library", flags->library,
                  "Install a whole library (object source name), or every archive of a source "
                  "of another data type: TYPE/NAME (robots/franka_droid)");
  sub->add_option("--scene", flags->scene,
                  "Install a scene, then the objects and grasps it references: a path inside a "
                  "scene source (or under <assets>/scenes), or a scene number (N, or SOURCE:N)");
  sub->add_option("--license-policy", flags->license_policy,
                  "all or commercial_safe: leave out non-commercial (by-nc, by-nc-sa) assets "
                  "with a note (default MLSPACES_LICENSE_POLICY, else all)");
  flags->libraries.AddTo(*sub);
  sub->add_option("--where", flags->where,
                  "With --library: only assets whose annotation field KEY (or JSON pointer) "
                  "equals VALUE (repeatable: all must match)")
      ->allow_extra_args(false);
  sub->add_flag("--dry-run", flags->dry_run,
                "Print the size estimate only; nothing is installed (sources are set up: "
                "manifests and tries)");
  sub->add_option("-j,--jobs", flags->jobs, "Parallel downloads (default 4)")
      ->check(PositiveInteger());
  sub->add_flag("-q,--quiet", flags->quiet, "No progress bar");
  flags->remote.AddTo(*sub);
  sub->callback([&action, flags] { action = [flags] { return RunInstall(*flags); }; });

  auto vflags = std::make_shared<VerifyFlags>();
  CLI::App* vsub = app.add_subcommand(
      "verify", "Re-check installed package files against their manifests (SHA-256)");
  vsub->add_option("NAME", vflags->names, "Sources to check (default: all installed)");
  vsub->add_flag("--repair", vflags->repair,
                 "Mark archives with bad files for reinstallation by the next install");
  vflags->remote.AddTo(*vsub);
  vsub->callback([&action, vflags] { action = [vflags] { return RunVerify(*vflags); }; });
}

}  // namespace mlspaces::cli
