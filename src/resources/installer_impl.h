// Installer::Impl, shared by installer.cc (packages, verify) and installer_molmo.cc
// (MolmoSpaces-format sources, scenes, the licence policy). Internal: not installed.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <tuple>

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/file_lock.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/parallel.h"
#include "mlspaces/library/annotation.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/resources/archive.h"
#include "mlspaces/resources/fetch.h"
#include "mlspaces/resources/installer.h"
#include "mlspaces/resources/molmo_remote.h"
#include "mlspaces/resources/sha256.h"

namespace mlspaces {
namespace fs = std::filesystem;

inline constexpr const char* kRemoteSourcesFile = "mlspaces_sources.json";

inline bool JsonValueMatches(const Json& v, const std::string& want) {
  if (v.is_array()) {
    for (const Json& e : v) {
      if (JsonValueMatches(e, want)) return true;
    }
    return false;
  }
  if (v.is_string()) return v.get<std::string>() == want;
  return v.dump() == want;
}

struct Installer::Impl {
  ResourceSettings settings;
  InstallOptions options;
  std::optional<SourceVersions> effective;  // built-ins, remote listing, pin file
  std::map<std::pair<std::string, std::string>, InstalledSource> sources;
  std::map<std::pair<std::string, std::string>, std::shared_ptr<const PackedLibrary>> libraries;
  std::set<std::pair<std::string, std::string>> not_packages;
  // MolmoSpaces-format sources (installer_molmo.cc).
  std::unique_ptr<MolmoSources> molmo;
  std::atomic<uint64_t> molmo_done{0};
  uint64_t molmo_total = 0;
  std::map<std::string, std::shared_ptr<const PackedLibrary>> molmo_libs;  // objects, by name
  std::unique_ptr<Registry> registry;
  bool all_set_up = false;

  MolmoSources& Molmo();
  /// Set-up of a MolmoSpaces-format source as an InstalledSource; nullptr when the remote
  /// serves neither format for it.
  const InstalledSource* SetupMolmo(const std::string& type, const std::string& name,
                                    const std::string& version);
  /// Setup, or nullptr (with a note when `note`) when the remote has neither format for the
  /// source or it is not pinned.
  const InstalledSource* TrySetup(const std::string& type, const std::string& name,
                                  bool note = true);
  /// The original's set-up of every pinned source: MolmoSpaces-format ones are set up and
  /// their EAGER archives, and the scene sources' base archives, join `plan`.
  void SetupAll(InstallPlan& plan, std::set<std::pair<const InstalledSource*, uint32_t>>& seen);
  /// `link` false: installed without PER_FILE links (the bulk install), unless another
  /// request adds the same archive with links.
  void AddMolmoArchive(InstallPlan& plan,
                       std::set<std::pair<const InstalledSource*, uint32_t>>& seen,
                       const InstalledSource& src, const std::string& archive, bool link = true);
  std::set<std::pair<const InstalledSource*, std::string>> unlinked;  // bulk-installed archives
  /// Where AddMolmoArchive records what a scene plan asks for (null: not recording).
  std::map<std::string, std::map<std::string, std::set<std::string>>>* record = nullptr;
  /// The UID index of a MolmoSpaces-format object source, or nullptr (objathor_metadata).
  std::shared_ptr<const PackedLibrary> MolmoLibrary(const InstalledSource& src);
  bool registry_has_annotations = false;
  /// The Registry (user libraries, installed sources), opened once.
  Registry& Libraries();
  /// Installs objathor_metadata now when annotations are needed; then (re)opens the Registry.
  Registry& Annotations();
  /// Dry runs never install: when objathor_metadata is not installed, its missing archives
  /// join `plan` (what a real run installs first), a note says so, and --where and the
  /// licence policy are not applied (annotations_unknown). Nothing to do for a real run.
  void PrepareAnnotations(InstallPlan& plan,
                          std::set<std::pair<const InstalledSource*, uint32_t>>& seen);
  bool annotations_unknown = false;
  /// Whether the licence policy lets `uid` in; notes it when not.
  bool Allowed(const std::string& uid, InstallPlan& plan);
  void InstallMolmo(const InstalledSource& src, const std::vector<std::string>& archives);
  /// An asset of a MolmoSpaces-format object source: its archive, then its grasp archives.
  void PlanMolmoAsset(InstallPlan& plan,
                      std::set<std::pair<const InstalledSource*, uint32_t>>& seen,
                      const InstalledSource& src, const PackedLibrary& lib,
                      const PackedAsset& asset);
  /// index_lookup("grasps", source, token) over the tokens of `file_name` (install_uid).
  void AddGraspArchives(InstallPlan& plan,
                        std::set<std::pair<const InstalledSource*, uint32_t>>& seen,
                        const std::string& grasp_source, const std::string& file_name);

  void Note(const std::string& text) const {
    if (options.note) options.note(text);
  }

  FetchOptions Fetch() const {
    FetchOptions f;
    f.retries = options.retries;
    return f;
  }

  /// Built-ins, then the pin file (which wins): no network. The remote's optional listing
  /// joins it only once FetchListing() ran (a source is missing from the cache or unknown).
  const SourceVersions& Versions() {
    if (effective) return *effective;
    SourceVersions v = BuiltinSourceVersions();
    if (!settings.pin_file.empty()) MergePinFile(v, settings.pin_file);
    effective = std::move(v);
    return *effective;
  }

  enum class Listing { kNotFetched, kMerged, kAbsent, kUnreachable };
  Listing listing = Listing::kNotFetched;
  std::string listing_error;  // why the listing could not be read (kUnreachable)

  /// Merges <remote>/mlspaces_sources.json into Versions() (the pin file still wins), once.
  /// The listing is optional: a remote without it, or one that cannot be reached or returns
  /// something else, leaves the versions as they are (noted when unreachable).
  /// @returns whether the listing was merged.
  bool FetchListing() {
    if (listing != Listing::kNotFetched) return listing == Listing::kMerged;
    Versions();
    const std::string url = JoinUrl(settings.remote_url, kRemoteSourcesFile);
    FetchOptions once = Fetch();
    once.retries = 0;  // optional: one try
    try {
      SourceVersions v = BuiltinSourceVersions();
      MergePinJson(v, FetchToString(url, once), url);
      if (!settings.pin_file.empty()) MergePinFile(v, settings.pin_file);
      effective = std::move(v);
      listing = Listing::kMerged;
      return true;
    } catch (const FetchError& e) {
      if (e.not_found()) {
        listing = Listing::kAbsent;  // no listing on this remote: fine
        return false;
      }
      listing_error = e.what();
    } catch (const Error& e) {
      listing_error = e.what();
    }
    listing = Listing::kUnreachable;
    return false;
  }

  /// The note for an unreachable listing, once, from a plan that succeeded (a failing one
  /// says only its own error, in one line).
  void NoteListing() {
    if (listing != Listing::kUnreachable || listing_noted) return;
    listing_noted = true;
    Note("the optional listing of published sources could not be read (" + listing_error +
         "); went on with the built-in and pinned versions");
  }
  bool listing_noted = false;

  /// Whether type/name at `version` is set up in the cache already (either format).
  bool SetUpInCache(const std::string& type, const std::string& name, const std::string& version) {
    const fs::path dir = settings.VersionDir(type, name, version);
    return IsFile(dir / std::string(kPackageManifestFile)) || Molmo().InCache(type, name, version);
  }

  std::string VersionOf(const std::string& type, const std::string& name) {
    const SourceVersions* known = &Versions();
    auto listed = [&] {
      auto t = known->find(type);
      return t != known->end() && t->second.count(name) != 0;
    };
    if (!listed()) {
      FetchListing();  // an unknown source: maybe a published one
      known = &Versions();
    }
    const SourceVersions& v = *known;
    auto t = v.find(type);
    if (t != v.end()) {
      auto s = t->second.find(name);
      if (s != t->second.end() && !s->second.empty()) return s->second;
      if (s != t->second.end()) {
        throw Error(type + "/" + name +
                    " has no pinned version: pin one in a pin file "
                    "(MLSPACES_PINNED_ASSETS_FILE or --pins)");
      }
    }
    throw Error("unknown source " + type + "/" + name +
                ": not in the built-in table, the pin file or " +
                JoinUrl(settings.remote_url, kRemoteSourcesFile) +
                (listing == Listing::kUnreachable ? " (unreachable: " + listing_error + ")" : ""));
  }

  void Link(const InstalledSource& src) {
    const fs::path link = settings.assets_dir / src.type / src.name;
    std::error_code ec;
    fs::create_directories(link.parent_path(), ec);
    if (ec) throw Error("cannot create folder: " + ec.message(), link.parent_path().string());
    RemoveDeadTempFiles(link.parent_path());  // symlinks of installers killed mid-rename
    RemoveDeadTempFiles(settings.assets_dir);
    const fs::file_status st = fs::symlink_status(link, ec);
    if (fs::exists(st) && !fs::is_symlink(st)) {
      throw Error("is not a symlink made by an installer; move it away and retry", link.string());
    }
    if (fs::is_symlink(st)) {
      const fs::path target = fs::read_symlink(link, ec);
      if (!ec && target == src.dir) return;
      Note("switching " + src.type + "/" + src.name + " from " + target.string() + " to version " +
           src.version);
    }
    const fs::path tmp = link.parent_path() / ("." + src.name + TempSuffix());
    fs::create_directory_symlink(src.dir, tmp, ec);
    if (ec) throw Error("cannot create symlink: " + ec.message(), tmp.string());
    fs::rename(tmp, link, ec);
    if (ec) {
      std::error_code ignored;
      fs::remove(tmp, ignored);
      throw Error("cannot rename symlink into place: " + ec.message(), link.string());
    }
    CrashPoint("assets-dir symlink renamed into place");
    // The install-side manifest, as the original keeps it: {type: {source: version}}.
    FileLock lock(settings.assets_dir / ".lock");
    const fs::path manifest = settings.assets_dir / kVersionsManifestFile;
    Json doc = ReadVersionsManifest(manifest);
    doc[src.type][src.name] = src.version;
    WriteFileAtomic(manifest, DumpJsonIndent4(doc));
  }

  const InstalledSource& Setup(const std::string& type, const std::string& name) {
    const auto key = std::make_pair(type, name);
    if (auto it = sources.find(key); it != sources.end()) return it->second;
    const std::string version = VersionOf(type, name);
    InstalledSource src;
    src.type = type;
    src.name = name;
    src.version = version;
    src.dir = settings.VersionDir(type, name, version);
    const fs::path manifest_path = src.dir / std::string(kPackageManifestFile);
    // A MolmoSpaces-format source: in the cache already, or no package manifest on the remote
    // (probed before anything is created in the cache, which the original would refuse).
    std::optional<std::string> probed;
    if (!IsFile(manifest_path)) {
      if (Molmo().InCache(type, name, version)) {
        if (const InstalledSource* m = SetupMolmo(type, name, version)) return *m;
      }
      const std::string url = settings.Url(type, name, version, std::string(kPackageManifestFile));
      try {
        probed = FetchToString(url, Fetch());
      } catch (const FetchError& e) {
        if (!e.not_found()) throw;
        if (const InstalledSource* m = SetupMolmo(type, name, version)) return *m;
        not_packages.insert(key);
        throw Error("neither an mlspaces package nor a MolmoSpaces-format source for " + type +
                        "/" + name + " " + version + " at " + url,
                    url);
      }
    }
    if (!IsFile(manifest_path)) {
      FileLock lock(src.dir / ".mlspaces" / "lock", [&](long pid) {
        Note("waiting for the installer with pid " + std::to_string(pid) + " (" + src.dir.string() +
             ")");
      });
      if (!IsFile(manifest_path)) {
        RemoveDeadTempFiles(src.dir);  // a set-up killed mid-write (nothing extracted yet)
        const std::string url =
            settings.Url(type, name, version, std::string(kPackageManifestFile));
        std::string text;
        try {
          text = probed ? *probed : FetchToString(url, Fetch());
        } catch (const FetchError& e) {
          if (!e.not_found()) throw;
          not_packages.insert(key);
          throw Error("no mlspaces package for " + type + "/" + name + " " + version + " at " +
                          url + " (sources in MolmoSpaces' own format are not installable yet)",
                      url);
        }
        const PackageManifest m = PackageManifest::Parse(text, url);
        if (m.name != name || m.version != version || m.data_type != type) {
          throw Error("manifest is for " + m.data_type + "/" + m.name + " " + m.version +
                          ", expected " + type + "/" + name + " " + version,
                      url);
        }
        for (const auto& [file, info] : m.files) {
          if (file.empty() || file.find('/') != std::string::npos || file[0] == '.') {
            throw Error("bad store file name '" + file + "'", url, "/files");
          }
          FetchFile(settings.Url(type, name, version, file), src.dir / file,
                    FetchExpect{info.size, info.sha256}, Fetch());
        }
        // The manifest goes last: its presence means the set-up is complete.
        WriteFileAtomic(manifest_path, text);
        RecordInCache(src);
      }
    }
    src.manifest = PackageManifest::Load(manifest_path);
    Link(src);
    return sources.emplace(key, std::move(src)).first->second;
  }

  /// The cache-side manifest {type: {source: [versions]}}.
  void RecordInCache(const InstalledSource& src) {
    FileLock lock(settings.cache_dir / ".lock");
    RemoveDeadTempFiles(settings.cache_dir);
    const fs::path manifest = settings.cache_dir / kVersionsManifestFile;
    Json doc = ReadVersionsManifest(manifest);
    Json& list = doc[src.type][src.name];
    if (!list.is_array()) list = Json::array();
    for (const Json& v : list) {
      if (v == src.version) return;
    }
    list.push_back(src.version);
    WriteFileAtomic(manifest, DumpJsonIndent4(doc));
  }

  std::shared_ptr<const PackedLibrary> Library(const std::string& type, const std::string& name) {
    const auto key = std::make_pair(type, name);
    if (auto it = libraries.find(key); it != libraries.end()) return it->second;
    const InstalledSource& src = Setup(type, name);
    auto lib = src.molmo != nullptr ? MolmoLibrary(src) : PackedLibrary::Open(src.dir, name);
    if (lib == nullptr) throw Error(type + "/" + name + " holds no assets", src.dir.string());
    libraries.emplace(key, lib);
    return lib;
  }

  void AddArchive(InstallPlan& plan, std::set<std::pair<const InstalledSource*, uint32_t>>& seen,
                  const InstalledSource& src, const PackedLibrary& lib, uint32_t archive) {
    if (!seen.insert({&src, archive}).second) return;
    const std::string& name = lib.archives()[archive];
    if (IsFile(src.dir / ExtractFlagName(name))) {
      ++plan.already_installed;
      return;
    }
    // Pack writes the manifest's archives in the UID index's order: archive i is entry i.
    const std::vector<PackageArchive>& list = src.manifest.archives;
    if (archive >= list.size() || list[archive].name != name) {
      throw Error("archive " + name + " of the UID index is not entry " + std::to_string(archive) +
                      " of the manifest (mismatched package files)",
                  (src.dir / std::string(kPackageManifestFile)).string());
    }
    const PackageArchive* a = &list[archive];
    plan.archives.push_back({&src, name, a->size, a->unpacked_bytes, archive});
    plan.download_bytes += a->size;
    plan.unpacked_bytes += a->unpacked_bytes;
  }

  /// Downloads, checks and extracts one archive and renames its files into place; the
  /// caller flushes and writes the flag. @returns false when the archive was already flagged.
  bool PlaceArchive(const InstalledSource& src, uint32_t index, std::atomic<uint64_t>& done,
                    uint64_t total) {
    const PackageArchive* a = &src.manifest.archives.at(index);
    const std::string& name = a->name;
    if (IsFile(src.dir / ExtractFlagName(name))) return false;
    const fs::path download = src.dir / ".mlspaces" / "downloads" / name;
    const fs::path staging = src.dir / ".mlspaces" / "staging" / ArchiveStem(name);
    FetchOptions f = Fetch();
    f.sync = false;  // a download lost in a crash fails its SHA-256 below and is fetched again
    uint64_t last = 0;
    if (options.progress) {
      f.progress = [&](uint64_t now, uint64_t) {
        if (now > last) done += now - last;
        last = now;
        options.progress(done.load(), total);
      };
    }
    if (!IsFile(download)) {
      FetchFile(settings.Url(src.type, src.name, src.version, name), download,
                FetchExpect{a->size, a->sha256}, f);
    } else if (Sha256File(download).sha256 != a->sha256) {
      RemovePath(download);  // a complete download that went bad on disk: fetch again
      FetchFile(settings.Url(src.type, src.name, src.version, name), download,
                FetchExpect{a->size, a->sha256}, f);
    }
    std::error_code ec;
    fs::remove_all(staging, ec);
    const ExtractReport extracted = ExtractTarZst(download, staging);
    for (const std::string& rel : extracted.files) {
      const fs::path target = src.dir / rel;
      fs::create_directories(target.parent_path(), ec);
      if (ec) throw Error("cannot create folder: " + ec.message(), target.parent_path().string());
      // A folder in the way (never from our packs) would make rename fail; say so.
      fs::rename(staging / rel, target, ec);
      if (ec) throw Error("cannot move into place: " + ec.message(), target.string());
      CrashPoint("installed file renamed into place");
    }
    // Clear the way before the flag: a kill after it must leave nothing behind to clean.
    fs::remove_all(staging, ec);
    fs::remove(download, ec);
    CrashPoint("archive placed");
    return true;
  }

  /// Flushes everything placed so far (one syncfs for many archives), then writes their
  /// flags. The flags are empty files: creating one is atomic by itself, and no temp file
  /// can be left over in the (possibly huge) version folder.
  void FlagArchives(const InstalledSource& src, const std::vector<uint32_t>& placed) {
    if (placed.empty()) return;
    SyncFileSystem(src.dir);
    for (uint32_t index : placed) {
      const fs::path flag = src.dir / ExtractFlagName(src.manifest.archives.at(index).name);
      const int fd = ::open(flag.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0444);
      if (fd < 0) throw Error(std::string("cannot create: ") + std::strerror(errno), flag.string());
      ::close(fd);
      CrashPoint("archive flag written");
    }
    FsyncPath(src.dir, true, src.dir.string());
  }

  void Install(const InstallPlan& plan) {
    // Archives are placed in batches by a pool of workers; each batch is flushed once and
    // then flagged, so a big install pays one syncfs per batch, not one per archive.
    constexpr size_t kBatch = 64;
    std::map<const InstalledSource*, std::vector<uint32_t>> by_source;  // archive indexes
    for (const auto& item : plan.archives) by_source[item.source].push_back(item.index);
    std::atomic<uint64_t> done{0};
    molmo_total = plan.download_bytes;
    molmo_done = 0;
    for (auto& entry : by_source) {
      // Named, not a structured binding: clang 14 (the fuzz build) cannot capture those.
      const InstalledSource* src = entry.first;
      std::vector<uint32_t>& indexes = entry.second;
      if (src->molmo != nullptr) {
        std::vector<std::string> names;
        for (const auto& item : plan.archives) {
          if (item.source == src) names.push_back(item.archive);
        }
        InstallMolmo(*src, names);
        continue;
      }
      FileLock lock(src->dir / ".mlspaces" / "lock", [&](long pid) {
        Note("waiting for the installer with pid " + std::to_string(pid) + " (" +
             src->dir.string() + ")");
      });
      // Under the lock no other installer works here: any staging folder is a dead one's.
      std::error_code ec;
      fs::remove_all(src->dir / ".mlspaces" / "staging", ec);
      for (size_t begin = 0; begin < indexes.size(); begin += kBatch) {
        const size_t end = std::min(indexes.size(), begin + kBatch);
        std::mutex mu;
        std::vector<uint32_t> placed;
        std::exception_ptr error;
        try {
          ParallelFor(end - begin, std::max(1, options.parallel_downloads), [&](size_t k) {
            if (PlaceArchive(*src, indexes[begin + k], done, plan.download_bytes)) {
              std::lock_guard<std::mutex> l(mu);
              placed.push_back(indexes[begin + k]);
            }
          });
        } catch (...) {
          error = std::current_exception();
        }
        FlagArchives(*src, placed);  // what is complete keeps its work, even on an error
        if (error) std::rethrow_exception(error);
      }
    }
  }
};

}  // namespace mlspaces
