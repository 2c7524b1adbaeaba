// Installing packages into the cache and linking them into the assets dir (spec 7.4, with
// checksums, resumable downloads and crash-safe extraction added).
//
// Cache layout per source version (shared with the original's resource manager):
//   <cache>/<type>/<name>/<version>/
//     mlspaces_package.json uid_index.mlsx metadata.mlsm   set-up files (manifest last)
//     .<archive>_complete_extract                           one flag per installed archive
//     <extracted files>                                     read-only
//     .mlspaces/lock                                        flock of installers
//     .mlspaces/downloads/<archive>[.part]                  downloads in flight
//     .mlspaces/staging/<archive stem>/                     extraction in flight
// A killed installer leaves at most a .part file (resumed next time) and a staging folder
// (deleted next time, under the lock); the flag is written only after every file of the
// archive has been renamed into place and flushed, so a flagged archive is complete.
#include "mlspaces/resources/installer.h"

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
#include "mlspaces/resources/archive.h"
#include "mlspaces/resources/fetch.h"
#include "mlspaces/resources/sha256.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

constexpr const char* kRemoteSourcesFile = "mlspaces_sources.json";
constexpr const char* kInstallManifest = "mjthor_data_type_to_source_to_versions.json";

/// One of the original's small version manifests as an object; a missing, unreadable or
/// malformed one reads as {} (the caller rewrites it from what is installed).
Json ReadVersionManifest(const fs::path& file) {
  if (!IsFile(file)) return Json::object();
  try {
    Json doc = ParseJsonFile(file);
    return doc.is_object() ? doc : Json::object();
  } catch (const Error&) {
    return Json::object();
  }
}

bool JsonValueMatches(const Json& v, const std::string& want) {
  if (v.is_array()) {
    for (const Json& e : v) {
      if (JsonValueMatches(e, want)) return true;
    }
    return false;
  }
  if (v.is_string()) return v.get<std::string>() == want;
  return v.dump() == want;
}

}  // namespace

WhereFilter WhereFilter::Parse(const std::string& flag) {
  const size_t eq = flag.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw UsageError("--where expects KEY=VALUE (KEY a field or a JSON pointer), got '" + flag +
                     "'");
  }
  return WhereFilter{flag.substr(0, eq), flag.substr(eq + 1)};
}

struct Installer::Impl {
  ResourceSettings settings;
  InstallOptions options;
  std::optional<SourceVersions> effective;  // built-ins, remote listing, pin file
  std::map<std::pair<std::string, std::string>, InstalledSource> sources;
  std::map<std::pair<std::string, std::string>, std::shared_ptr<const PackedLibrary>> libraries;
  std::set<std::pair<std::string, std::string>> not_packages;

  void Note(const std::string& text) const {
    if (options.note) options.note(text);
  }

  FetchOptions Fetch() const {
    FetchOptions f;
    f.retries = options.retries;
    return f;
  }

  /// Built-ins, then what the remote says it serves, then the pin file (which wins).
  const SourceVersions& Versions() {
    if (effective) return *effective;
    SourceVersions v = BuiltinSourceVersions();
    const std::string url = JoinUrl(settings.remote_url, kRemoteSourcesFile);
    try {
      MergePinJson(v, FetchToString(url, Fetch()), url);
    } catch (const FetchError& e) {
      if (!e.not_found()) throw;  // no listing on this remote: fine
    }
    if (!settings.pin_file.empty()) MergePinFile(v, settings.pin_file);
    effective = std::move(v);
    return *effective;
  }

  std::string VersionOf(const std::string& type, const std::string& name) {
    const SourceVersions& v = Versions();
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
                JoinUrl(settings.remote_url, kRemoteSourcesFile));
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
    const fs::path manifest = settings.assets_dir / kInstallManifest;
    Json doc = ReadVersionManifest(manifest);
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
          text = FetchToString(url, Fetch());
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
    const fs::path manifest = settings.cache_dir / kInstallManifest;
    Json doc = ReadVersionManifest(manifest);
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
    auto lib = PackedLibrary::Open(src.dir, name);
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
    for (auto& entry : by_source) {
      // Named, not a structured binding: clang 14 (the fuzz build) cannot capture those.
      const InstalledSource* src = entry.first;
      std::vector<uint32_t>& indexes = entry.second;
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

Installer::Installer(ResourceSettings settings, InstallOptions options)
    : impl_(std::make_unique<Impl>()) {
  impl_->settings = std::move(settings);
  impl_->options = std::move(options);
}
Installer::~Installer() = default;

const ResourceSettings& Installer::settings() const { return impl_->settings; }

const InstalledSource& Installer::Setup(const std::string& type, const std::string& name) {
  return impl_->Setup(type, name);
}

std::shared_ptr<const PackedLibrary> Installer::Library(const std::string& type,
                                                        const std::string& name) {
  return impl_->Library(type, name);
}

InstallPlan Installer::PlanUids(const std::vector<std::string>& uids) {
  Impl& impl = *impl_;
  // The original's order: thor, then the other object sources alphabetically.
  std::vector<std::string> order;
  const SourceVersions& versions = impl.Versions();
  if (auto t = versions.find("objects"); t != versions.end()) {
    if (t->second.count("thor") != 0) order.push_back("thor");
    for (const auto& [name, version] : t->second) {
      if (name != "thor") order.push_back(name);
    }
  }
  std::vector<std::pair<const InstalledSource*, std::shared_ptr<const PackedLibrary>>> libs;
  std::string skipped;
  for (const std::string& name : order) {
    const auto key = std::make_pair(std::string("objects"), name);
    if (impl.not_packages.count(key) != 0) continue;
    const SourceVersions& v = impl.Versions();
    if (v.at("objects").at(name).empty()) continue;  // unpinned: nothing to look in
    try {
      auto lib = impl.Library("objects", name);
      libs.emplace_back(&impl.sources.at(key), lib);
    } catch (const Error& e) {
      if (impl.not_packages.count(key) == 0) throw;
      skipped += (skipped.empty() ? "" : ", ") + name;
    }
  }
  if (!skipped.empty()) {
    impl.Note("not searched (no mlspaces package on " + impl.settings.remote_url +
              "; MolmoSpaces-format sources are not installable yet): " + skipped);
  }
  InstallPlan plan;
  std::set<std::pair<const InstalledSource*, uint32_t>> seen;
  for (const std::string& uid : uids) {
    bool found = false;
    for (const auto& [src, lib] : libs) {
      if (auto asset = lib->Find(uid)) {
        impl.AddArchive(plan, seen, *src, *lib, asset->archive);
        ++plan.assets;
        found = true;
        break;
      }
    }
    if (!found) {
      std::string list;
      for (const std::string& name : order) list += (list.empty() ? "" : ", ") + name;
      throw Error(uid + " not found in object sources [" + list + "]", "", "", uid);
    }
  }
  std::sort(plan.archives.begin(), plan.archives.end(), [](const auto& a, const auto& b) {
    return std::tie(a.source->name, a.archive) < std::tie(b.source->name, b.archive);
  });
  return plan;
}

InstallPlan Installer::PlanLibrary(const std::string& name, const std::vector<WhereFilter>& where) {
  Impl& impl = *impl_;
  auto lib = impl.Library("objects", name);
  const InstalledSource& src = impl.sources.at({"objects", name});
  InstallPlan plan;
  std::set<std::pair<const InstalledSource*, uint32_t>> seen;
  for (size_t i = 0; i < lib->size(); ++i) {
    const PackedAsset asset = lib->At(i);
    if (!where.empty()) {
      auto annotation = lib->LoadAnnotation(asset);
      if (!annotation) continue;
      bool all = true;
      for (const WhereFilter& f : where) {
        const Json* value = nullptr;
        if (!f.key.empty() && f.key[0] == '/') {
          const Json::json_pointer ptr(f.key);
          if (annotation->json.contains(ptr)) value = &annotation->json.at(ptr);
        } else if (auto it = annotation->json.find(f.key); it != annotation->json.end()) {
          value = &*it;
        }
        if (value == nullptr || !JsonValueMatches(*value, f.value)) {
          all = false;
          break;
        }
      }
      if (!all) continue;
    }
    impl.AddArchive(plan, seen, src, *lib, asset.archive);
    ++plan.assets;
  }
  std::sort(plan.archives.begin(), plan.archives.end(),
            [](const auto& a, const auto& b) { return a.archive < b.archive; });
  return plan;
}

void Installer::Install(const InstallPlan& plan) { impl_->Install(plan); }

std::vector<Installer::Problem> Installer::Verify(const std::vector<std::string>& names,
                                                  bool repair, size_t* files_checked) {
  Impl& impl = *impl_;
  std::vector<Problem> problems;
  size_t checked = 0;
  std::error_code ec;
  for (const auto& [type, srcs] : impl.Versions()) {
    (void)srcs;
    const fs::path type_dir = impl.settings.assets_dir / type;
    if (!fs::is_directory(type_dir, ec)) continue;
    std::vector<fs::path> links;
    for (const auto& entry : fs::directory_iterator(type_dir, ec)) {
      if (!entry.is_symlink()) continue;
      const std::string name = entry.path().filename().string();
      if (!names.empty() && std::find(names.begin(), names.end(), name) == names.end()) continue;
      links.push_back(entry.path());
    }
    std::sort(links.begin(), links.end());
    for (const fs::path& link : links) {
      const fs::path dir = fs::read_symlink(link, ec);
      const fs::path manifest_path = dir / std::string(kPackageManifestFile);
      if (!IsFile(manifest_path)) continue;  // not an mlspaces package
      PackageManifest m;
      try {
        m = PackageManifest::Load(manifest_path);
      } catch (const Error& e) {
        problems.push_back({manifest_path.string(), "", e.message()});
        continue;
      }
      auto check = [&](const fs::path& file, uint64_t size, const std::string& sha) {
        ++checked;
        if (!IsFile(file)) {
          problems.push_back({file.string(), "", "missing"});
          return false;
        }
        const FileDigest d = Sha256File(file);
        if (d.size != size) {
          problems.push_back(
              {file.string(), "",
               "size " + std::to_string(d.size) + ", expected " + std::to_string(size)});
          return false;
        }
        if (d.sha256 != sha) {
          problems.push_back({file.string(), "", "SHA-256 " + d.sha256 + ", expected " + sha});
          return false;
        }
        return true;
      };
      for (const auto& [file, info] : m.files) check(dir / file, info.size, info.sha256);
      for (const PackageArchive& a : m.archives) {
        const fs::path flag = dir / ExtractFlagName(a.name);
        if (!IsFile(flag)) continue;
        bool good = true;
        const fs::path listing_path = dir / a.members_file;
        ++checked;
        std::string listing_text;
        if (!IsFile(listing_path)) {
          problems.push_back({listing_path.string(), "", "missing"});
          good = false;
        } else if (listing_text = ReadFile(listing_path);
                   Sha256Hex(listing_text) != a.members_sha256) {
          problems.push_back(
              {listing_path.string(), "", "SHA-256 differs from the manifest's members_sha256"});
          good = false;
        } else {
          const FlatJson listing = ParseFlatJson(listing_text, listing_path.string());
          for (const auto& [rel, info] : listing.items()) {
            if (!info.is_object() || !info.contains("size") || !info.contains("sha256")) {
              problems.push_back({listing_path.string(), "", "bad entry for " + rel});
              good = false;
              continue;
            }
            good &=
                check(dir / rel, info["size"].get<uint64_t>(), info["sha256"].get<std::string>());
          }
        }
        if (!good && repair) {
          fs::remove(flag, ec);
          problems.back().message += " (archive " + a.name + " will be installed again)";
        }
      }
    }
  }
  if (files_checked != nullptr) *files_checked = checked;
  return problems;
}

}  // namespace mlspaces
