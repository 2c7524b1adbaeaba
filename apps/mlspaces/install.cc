// mlspaces install / verify: packaged libraries into the cache and the assets dir.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/progress.h"
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
  std::vector<std::string> where;
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

int RunInstall(const InstallFlags& flags) {
  if (!flags.where.empty() && flags.library.empty()) {
    throw UsageError("--where needs --library");
  }
  if (flags.uids.empty() == flags.library.empty()) {
    throw UsageError("give UIDs or --library NAME (not both)");
  }
  std::vector<WhereFilter> where;
  for (const std::string& w : flags.where) where.push_back(WhereFilter::Parse(w));
  InstallOptions options;
  options.parallel_downloads = flags.jobs;
  options.note = [](const std::string& text) {
    std::fprintf(stderr, "mlspaces: %s\n", text.c_str());
  };
  std::unique_ptr<ProgressBar> bar;
  options.progress = [&](uint64_t done, uint64_t total) {
    if (bar) bar->Update(static_cast<size_t>(done / 1000), Mb(done) + " of " + Mb(total));
  };
  Installer installer(flags.remote.Settings(), options);
  const InstallPlan plan = flags.library.empty() ? installer.PlanUids(flags.uids)
                                                 : installer.PlanLibrary(flags.library, where);
  std::printf(
      "%zu assets in %zu archives to install: %s to download (%s unpacked); "
      "%zu archives already installed\n",
      plan.assets, plan.archives.size(), Mb(plan.download_bytes).c_str(),
      Mb(plan.unpacked_bytes).c_str(), plan.already_installed);
  std::fflush(stdout);
  if (flags.dry_run || plan.archives.empty()) return 0;
  bar = std::make_unique<ProgressBar>("install", static_cast<size_t>(plan.download_bytes / 1000),
                                      !flags.quiet);
  installer.Install(plan);
  bar->Finish();
  std::printf("installed %zu archives into %s\n", plan.archives.size(),
              installer.settings().cache_dir.c_str());
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
      "Download, verify and install packaged assets (with their grasps) by UID, or "
      "a whole library (--library NAME [--where KEY=VALUE])");
  sub->add_option("UID", flags->uids, "Asset UIDs");
  sub->add_option("--library", flags->library, "Install a whole library (source name)");
  sub->add_option("--where", flags->where,
                  "With --library: only assets whose annotation field KEY (or JSON pointer) "
                  "equals VALUE (repeatable: all must match)")
      ->allow_extra_args(false);
  sub->add_flag("--dry-run", flags->dry_run, "Print the size estimate only");
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
