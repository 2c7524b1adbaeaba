// Setting up and installing MolmoSpaces-format sources (molmo_remote.h), in the tree the
// original's resource manager makes:
//   <cache>/mjthor_data_type_to_source_to_versions.json       {type: {source: [versions]}}
//   <cache>/<type>/<source>/<version>/
//     mjthor_resource_file_to_size_mb.json, mjthor_resources_combined_meta.json.gz
//     .<archive '/'->'__'>_complete_extract                    one flag per extracted archive
//     <extracted files>                                          read-only
//     .mlspaces/index/                                           our UID index (object sources)
//     .mlspaces/members/<archive>.json                           our SHA-256 of its files
//     .mlspaces/downloads/<archive>[.part], .mlspaces/staging/   work in flight
//   <assets>/mjthor_data_type_to_source_to_versions.json      {type: {source: version}}
//   <assets>/<type>/<source> -> <cache>/...                      GLOBAL
//   <assets>/<type>/<source>/<file> -> <cache>/.../<file>        PER_FILE, + _complete_links
// Every writing step runs under flock on <assets>/.lock and <cache>/.lock (in that order, as
// the original takes them). A killed installer leaves at most a .part file (resumed), a
// staging folder (deleted under the lock) and files of an unflagged archive (placed again).
#define ZSTD_STATIC_LINKING_ONLY
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <optional>
#include <set>

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/file_lock.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/parallel.h"
#include "mlspaces/library/package_layout.h"
#include "mlspaces/resources/archive.h"
#include "mlspaces/resources/fetch.h"
#include "mlspaces/resources/legacy_source.h"
#include "mlspaces/resources/molmo_remote.h"
#include "mlspaces/resources/package.h"
#include "mlspaces/resources/sha256.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

/// '/' -> "__", as the original's flags name archives.
std::string Flat(const std::string& archive) {
  std::string flat;
  for (char c : archive) flat += c == '/' ? std::string("__") : std::string(1, c);
  return flat;
}

std::string LinkFlagName(const std::string& archive) {
  return "." + Flat(archive) + "_complete_links";
}

/// The original writes json.dump(indent=2); any JSON reads back the same.
void WriteManifest(const fs::path& file, const Json& doc) { WriteFileAtomic(file, doc.dump(2)); }

/// Checks every zstd frame of a file: the frame headers and block structure (libzstd), and
/// counts frames that carry no content checksum. The data checksums themselves are verified
/// while extracting. @throws Error naming `origin` for a file that is not zstd or is cut.
size_t ZstdFramesWithoutChecksum(const fs::path& file, const std::string& origin, size_t* frames) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(Errno("cannot open"), file.string());
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    ::close(fd);
    throw Error(Errno("cannot stat"), file.string());
  }
  const size_t size = static_cast<size_t>(st.st_size);
  if (size == 0) {
    ::close(fd);
    throw Error("empty file, not a .tar.zst archive", origin);
  }
  void* map = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
  ::close(fd);
  if (map == MAP_FAILED) throw Error(Errno("cannot map"), file.string());
  struct Unmap {
    void* p;
    size_t n;
    ~Unmap() { ::munmap(p, n); }
  } unmap{map, size};
  const auto* data = static_cast<const char*>(map);
  size_t pos = 0, without = 0, count = 0;
  while (pos < size) {
    ZSTD_frameHeader fh{};
    const size_t hr = ZSTD_getFrameHeader(&fh, data + pos, size - pos);
    if (ZSTD_isError(hr)) {
      throw Error(std::string("not a .tar.zst archive: bad zstd frame header at byte ") +
                      std::to_string(pos) + " (" + ZSTD_getErrorName(hr) + ")",
                  origin);
    }
    if (hr != 0) {
      throw Error("not a .tar.zst archive: zstd frame header cut at byte " + std::to_string(pos),
                  origin);
    }
    const size_t n = ZSTD_findFrameCompressedSize(data + pos, size - pos);
    if (ZSTD_isError(n)) {
      throw Error(std::string("damaged or truncated zstd frame at byte ") + std::to_string(pos) +
                      " (" + ZSTD_getErrorName(n) + ")",
                  origin);
    }
    if (fh.frameType == ZSTD_frame) {
      ++count;
      if (fh.checksumFlag == 0) ++without;
    }
    pos += n;
  }
  if (count == 0) throw Error("not a .tar.zst archive: no zstd data frame", origin);
  if (frames != nullptr) *frames = count;
  return without;
}

bool EnvBool(const char* name, bool fallback) {
  const char* v = std::getenv(name);
  if (v == nullptr) return fallback;
  std::string s(v);
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  s.erase(0, s.find_first_not_of(" \t"));
  s.erase(s.find_last_not_of(" \t") + 1);
  if (s == "yes" || s == "true" || s == "t" || s == "y" || s == "1") return true;
  if (s == "no" || s == "false" || s == "f" || s == "n" || s == "0") return false;
  throw UsageError(std::string(name) + "='" + v + "' is not a boolean (true/false, yes/no, 1/0)");
}

}  // namespace

Json ReadVersionsManifest(const fs::path& file) {
  if (!IsFile(file)) return Json::object();
  try {
    Json doc = ParseJsonFile(file);
    return doc.is_object() ? doc : Json::object();
  } catch (const Error&) {
    return Json::object();
  }
}

bool MolmoSource::Extracted(const std::string& archive) const {
  return IsFile(dir / ExtractFlagName(archive));
}

uint64_t MolmoSource::SizeBytes(const std::string& archive) const {
  auto it = size_mb.find(archive);
  return it == size_mb.end() ? 0 : static_cast<uint64_t>(it->second * 1e6);
}

fs::path MolmoMemberListPath(const fs::path& version_dir, const std::string& archive) {
  return version_dir / ".mlspaces" / "members" / (Flat(archive) + ".json");
}

struct MolmoSources::Impl {
  const ResourceSettings& settings;
  Options options;
  fs::path cache, assets;  // absolute
  bool cache_lock = true;
  std::map<std::pair<std::string, std::string>, std::unique_ptr<MolmoSource>> sources;

  Impl(const ResourceSettings& s, Options o) : settings(s), options(std::move(o)) {
    cache = fs::absolute(settings.cache_dir).lexically_normal();
    assets = fs::absolute(settings.assets_dir).lexically_normal();
    cache_lock = EnvBool("MLSPACES_CACHE_LOCK", true);
  }

  void Note(const std::string& text) const {
    if (options.note) options.note(text);
  }

  /// Both locks, install dir first (the original's order). Without MLSPACES_CACHE_LOCK only
  /// the install dir's.
  struct Locks {
    std::unique_ptr<FileLock> assets, cache;
  };
  Locks Hold() const {
    Locks l;
    auto waiting = [this](const fs::path& file) {
      return [this, file](long pid) {
        Note("waiting for the installer with pid " + std::to_string(pid) + " (" + file.string() +
             ")");
      };
    };
    CreateDirectories(assets);
    l.assets = std::make_unique<FileLock>(assets / ".lock", waiting(assets / ".lock"));
    if (cache_lock) {
      CreateDirectories(cache);
      l.cache = std::make_unique<FileLock>(cache / ".lock", waiting(cache / ".lock"));
    }
    return l;
  }

  FetchOptions Fetch() const {
    FetchOptions f;
    f.retries = options.retries;
    return f;
  }

  bool InCache(const std::string& type, const std::string& name, const std::string& version) const {
    const fs::path dir = settings.VersionDir(type, name, version);
    return IsFile(dir / std::string(kSizeManifestFile)) && IsFile(dir / std::string(kTriesFile)) &&
           !IsFile(dir / std::string(kPackageManifestFile));
  }

  // --- manifests (locks held) ---------------------------------------------------------------

  void RecordCache(const MolmoSource& s) {
    if (!cache_lock) return;  // the original leaves the cache manifest alone then too
    const fs::path file = cache / kVersionsManifestFile;
    Json doc = ReadVersionsManifest(file);
    Json& list = doc[s.type][s.name];
    if (!list.is_array()) list = Json::array();
    for (const Json& v : list) {
      if (v == s.version) return;
    }
    list.push_back(s.version);
    WriteManifest(file, doc);
    CrashPoint("cache versions manifest written");
  }

  void RecordInstall(const MolmoSource& s, bool installed) {
    const fs::path file = assets / kVersionsManifestFile;
    Json doc = ReadVersionsManifest(file);
    Json want = installed ? Json(s.version) : Json(nullptr);
    if (doc.contains(s.type) && doc[s.type].is_object() && doc[s.type].contains(s.name) &&
        doc[s.type][s.name] == want) {
      return;
    }
    doc[s.type][s.name] = want;
    WriteManifest(file, doc);
    CrashPoint("install versions manifest written");
  }

  bool CacheListed(const MolmoSource& s) const {
    const Json doc = ReadVersionsManifest(cache / kVersionsManifestFile);
    const Json* list = nullptr;
    if (doc.contains(s.type) && doc[s.type].is_object() && doc[s.type].contains(s.name)) {
      list = &doc[s.type][s.name];
    }
    if (list == nullptr || !list->is_array()) return false;
    return std::find(list->begin(), list->end(), Json(s.version)) != list->end();
  }

  // --- links (locks held) -------------------------------------------------------------------

  /// Makes `link` a symlink to `target`, replacing whatever symlink is there (temp + rename).
  static void PlaceSymlink(const fs::path& target, const fs::path& link, bool directory) {
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(link, ec);
    if (fs::is_symlink(st) && fs::read_symlink(link, ec) == target) return;
    if (fs::exists(st) && !fs::is_symlink(st)) {
      throw Error("is in the way of a link into the cache (not a symlink); move it away and retry",
                  link.string());
    }
    const fs::path tmp = link.parent_path() / ("." + link.filename().string() + TempSuffix());
    if (directory) {
      fs::create_directory_symlink(target, tmp, ec);
    } else {
      fs::create_symlink(target, tmp, ec);
    }
    if (ec) throw Error("cannot create symlink: " + ec.message(), tmp.string());
    RenamePath(tmp, link);
  }

  void LinkSource(const MolmoSource& s) {
    CreateDirectories(s.install.parent_path());
    RemoveDeadTempFiles(s.install.parent_path());
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(s.install, ec);
    const Json installed = [&] {
      const Json doc = ReadVersionsManifest(assets / kVersionsManifestFile);
      if (doc.contains(s.type) && doc[s.type].is_object() && doc[s.type].contains(s.name)) {
        return doc[s.type][s.name];
      }
      return Json(nullptr);
    }();
    if (s.behavior.link == LinkStrategy::kGlobal) {
      if (fs::is_symlink(st)) {
        const fs::path target = fs::read_symlink(s.install, ec);
        if (target != s.dir) {
          if (!options.force_install) {
            throw Error("Version mismatch for " + s.type + "/" + s.name + ": installed=" +
                            target.filename().string() + ", requested=" + s.version +
                            ". Set MLSPACES_FORCE_INSTALL=true to overwrite.",
                        s.install.string());
          }
          Note("switching " + s.type + "/" + s.name + " from " + target.string() + " to version " +
               s.version);
          RecordInstall(s, false);
        }
      } else if (fs::is_directory(st)) {
        if (!options.force_install) {
          throw Error("Version mismatch for " + s.type + "/" + s.name +
                          ": a folder is installed, requested=" + s.version +
                          ". Set MLSPACES_FORCE_INSTALL=true to overwrite.",
                      s.install.string());
        }
        RecordInstall(s, false);
        RemoveAll(s.install);
      }
      PlaceSymlink(s.dir, s.install, true);
      CrashPoint("source link placed");
      return;
    }
    // PER_FILE: a real folder of file links.
    if (fs::is_symlink(st)) {
      if (!options.force_install) {
        throw Error("Version mismatch for " + s.type + "/" + s.name +
                        ": a link is installed, requested=" + s.version +
                        ". Set MLSPACES_FORCE_INSTALL=true to overwrite.",
                    s.install.string());
      }
      RecordInstall(s, false);
      RemovePath(s.install);
    } else if (fs::is_directory(st) && installed != Json(s.version)) {
      // Another version's folder (or one whose set-up never finished: links of another
      // version would remain). Our links all point into one version dir: check one file.
      const fs::path probe = s.install / std::string(kTriesFile);
      const fs::path target =
          fs::is_symlink(fs::symlink_status(probe, ec)) ? fs::read_symlink(probe, ec) : fs::path();
      if (target.empty() || target.parent_path() != s.dir) {
        if (!installed.is_null() && !options.force_install) {
          throw Error("Version mismatch for " + s.type + "/" + s.name +
                          ": installed=" + installed.dump() + ", requested=" + s.version +
                          ". Set MLSPACES_FORCE_INSTALL=true to overwrite.",
                      s.install.string());
        }
        RecordInstall(s, false);
        RemoveAll(s.install);
      }
    }
    CreateDirectories(s.install);
    for (const std::string& file : {std::string(kSizeManifestFile), std::string(kTriesFile)}) {
      PlaceSymlink(s.dir / file, s.install / file, false);
    }
    CrashPoint("source folder linked");
  }

  void LinkArchives(const MolmoSource& s, const std::vector<std::string>& archives) {
    if (s.behavior.link != LinkStrategy::kPerFile) return;
    for (const std::string& archive : archives) {
      const fs::path flag = s.install / LinkFlagName(archive);
      if (IsFile(flag)) continue;
      const auto index = s.tries.Find(archive);
      if (!index) continue;  // no trie: nothing to link (as the original)
      for (const std::string& file : s.tries.files[*index]) {
        const fs::path link = s.install / file;
        CreateDirectories(link.parent_path());
        PlaceSymlink(s.dir / file, link, false);
      }
      WriteFileAtomic(flag, "", /*sync=*/false);
      CrashPoint("archive links flagged");
    }
  }

  /// An EAGER source with every archive flagged: linked and recorded as the original's
  /// set-up leaves it.
  void CompleteEager(const MolmoSource& s) {
    for (const std::string& a : s.tries.archives) {
      if (!s.Extracted(a)) return;
    }
    for (const auto& [a, mb] : s.size_mb) {
      if (!s.Extracted(a)) return;
    }
    LinkArchives(s, s.tries.archives);
    RecordCache(s);
    RecordInstall(s, true);
  }

  // --- set-up --------------------------------------------------------------------------------

  /// Downloads one set-up file into `staging` and checks it with `check` (a bad one is
  /// deleted). @returns false on 404 when `optional`.
  bool FetchChecked(const MolmoSource& s, const std::string& file, const fs::path& staging,
                    const std::function<void(const std::string&, const std::string&)>& check,
                    bool optional) {
    const std::string url = settings.Url(s.type, s.name, s.version, file);
    const fs::path download = staging / file;
    try {
      FetchFile(url, download, {}, Fetch());
    } catch (const FetchError& e) {
      if (optional && e.not_found()) return false;
      throw;
    }
    try {
      check(ReadFile(download), url);
    } catch (const Error&) {
      RemovePath(download);
      throw;
    }
    return true;
  }

  const MolmoSource* Setup(const std::string& type, const std::string& name,
                           const std::string& version) {
    const auto key = std::make_pair(type, name);
    if (auto it = sources.find(key); it != sources.end()) return it->second.get();
    auto s = std::make_unique<MolmoSource>();
    s->type = type;
    s->name = name;
    s->version = version;
    s->behavior = ResolveSourceBehavior(type, name);
    s->dir = fs::absolute(settings.VersionDir(type, name, version)).lexically_normal();
    s->install = assets / type / name;
    const fs::path size_file = s->dir / std::string(kSizeManifestFile);
    const fs::path tries_file = s->dir / std::string(kTriesFile);
    Locks locks = Hold();
    if (!IsFile(size_file) || !IsFile(tries_file)) {
      if (!cache_lock) {
        throw Error("MLSPACES_CACHE_LOCK is false, so the cache must be pre-populated, but " +
                        type + "/" + name + " " + version + " is not in it",
                    s->dir.string());
      }
      // Both files are downloaded and checked outside the version dir, which is created
      // only once they passed (the original refuses a version dir its manifest does not
      // list); then the tries go in first, the size manifest last.
      const fs::path staging =
          cache / ".mlspaces" / "setup" / (type + "__" + name + "__" + version);
      if (!FetchChecked(
              *s, std::string(kSizeManifestFile), staging,
              [](const std::string& text, const std::string& url) { ParseSizeManifest(text, url); },
              true)) {
        RemoveAll(staging);
        return nullptr;
      }
      FetchChecked(
          *s, std::string(kTriesFile), staging,
          [](const std::string& bytes, const std::string& url) { ParseTries(bytes, url); }, false);
      CreateDirectories(s->dir);
      for (const std::string& file : {std::string(kTriesFile), std::string(kSizeManifestFile)}) {
        RenamePath(staging / file, s->dir / file);
        CrashPoint("source manifest renamed into place");
      }
      RemoveAll(staging);
    }
    s->size_mb = ParseSizeManifest(ReadFile(size_file), size_file.string());
    s->tries = ReadTries(tries_file);
    s->index = ArchiveIndex(s->behavior.index, s->tries.archives);
    if (type == "objects" && name != "objathor_metadata" &&
        !IsFile(s->dir / std::string(kLegacyIndexDir) / std::string(kUidIndexFile))) {
      const LegacyIndexReport report = BuildLegacyIndex(s->dir, name);
      if (!report.warnings.empty()) {
        Note("objects/" + name + ": " + std::to_string(report.warnings.size()) +
             " files not indexed; first: " + LegacyWarningLine(report.warnings.front()));
      }
      CrashPoint("uid index built");
    }
    LinkSource(*s);
    if (s->behavior.mode == InstallMode::kOnDemand) {
      RecordCache(*s);
      RecordInstall(*s, true);
    } else {
      CompleteEager(*s);
    }
    return sources.emplace(key, std::move(s)).first->second.get();
  }

  // --- archives ------------------------------------------------------------------------------

  /// Downloads, checks and extracts one archive, records its member listing and renames its
  /// files into place; the caller flushes and flags. @returns false when already flagged.
  bool PlaceArchive(const MolmoSource& s, const std::string& archive) {
    if (s.Extracted(archive)) return false;
    if (archive.size() < 8 || archive.compare(archive.size() - 8, 8, ".tar.zst") != 0) {
      throw Error("Unknown archive extension (expected .tar.zst)", s.dir.string(), archive);
    }
    const std::string url = settings.Url(s.type, s.name, s.version, archive);
    const fs::path download = s.dir / ".mlspaces" / "downloads" / Flat(archive);
    const fs::path staging = s.dir / ".mlspaces" / "staging" / Flat(archive);
    FetchOptions f = Fetch();
    f.sync = false;  // re-checked below; a download lost in a crash fails its checks
    uint64_t last = 0;
    if (options.progress) {
      f.progress = [&](uint64_t now, uint64_t) {
        if (now > last) options.progress(now - last);
        last = now;
      };
    }
    if (!IsFile(download)) FetchFile(url, download, {}, f);
    ExtractReport extracted;
    try {
      size_t frames = 0;
      const size_t without = ZstdFramesWithoutChecksum(download, url, &frames);
      if (without > 0) {
        Note(s.type + "/" + s.name + ": " + archive + ": " + std::to_string(without) + " of " +
             std::to_string(frames) +
             " zstd frames carry no content checksum (checked by their tar structure only)");
      }
      RemoveAll(staging);
      extracted = ExtractTarZst(download, staging);
    } catch (const Error& e) {
      std::error_code ec;
      fs::remove_all(staging, ec);
      fs::remove(download, ec);  // a bad complete download: fetch it afresh next time
      throw Error(e.message() + (e.field().empty() ? "" : " (member " + e.field() + ")"), url,
                  archive);
    }
    Json files = Json::object();
    for (const std::string& rel : extracted.files) {
      std::error_code ec;
      if (fs::is_symlink(fs::symlink_status(staging / rel, ec))) continue;
      const FileDigest d = Sha256File(staging / rel);
      files[rel] = Json{{"size", d.size}, {"sha256", d.sha256}};
    }
    Json listing = Json::object();
    listing["archive"] = archive;
    listing["files"] = std::move(files);
    WriteFileAtomic(MolmoMemberListPath(s.dir, archive), listing.dump(1), /*sync=*/false);
    for (const std::string& rel : extracted.files) {
      const fs::path target = s.dir / rel;
      CreateDirectories(target.parent_path());
      RenamePath(staging / rel, target);
      CrashPoint("installed file renamed into place");
    }
    RemoveAll(staging);
    RemovePath(download);
    CrashPoint("archive placed");
    return true;
  }

  void Install(const MolmoSource& s, const std::vector<std::string>& wanted, bool link) {
    std::vector<std::string> archives;
    for (const std::string& a : std::set<std::string>(wanted.begin(), wanted.end())) {
      if (s.size_mb.count(a) == 0 && !s.tries.Find(a)) {
        throw Error("Unknown package " + a + " (not in the size manifest or the tries)",
                    (s.dir / std::string(kSizeManifestFile)).string(), a);
      }
      archives.push_back(a);
    }
    Locks locks = Hold();
    std::vector<std::string> todo;
    for (const std::string& a : archives) {
      if (!s.Extracted(a)) todo.push_back(a);
    }
    if (!todo.empty() && !cache_lock) {
      throw Error("MLSPACES_CACHE_LOCK is false, so the cache must be pre-populated, but " +
                      todo.front() + " is not extracted",
                  s.dir.string());
    }
    // Under the lock no other installer works here: staging folders are dead ones'.
    RemoveAll(s.dir / ".mlspaces" / "staging");
    constexpr size_t kBatch = 64;
    for (size_t begin = 0; begin < todo.size(); begin += kBatch) {
      const size_t end = std::min(todo.size(), begin + kBatch);
      std::mutex mu;
      std::vector<std::string> placed;
      std::exception_ptr error;
      try {
        ParallelFor(end - begin, std::max(1, options.parallel_downloads), [&](size_t k) {
          if (PlaceArchive(s, todo[begin + k])) {
            std::lock_guard<std::mutex> l(mu);
            placed.push_back(todo[begin + k]);
          }
        });
      } catch (...) {
        error = std::current_exception();
      }
      if (!placed.empty()) {
        SyncFileSystem(s.dir);
        for (const std::string& a : placed) {
          const fs::path flag = s.dir / ExtractFlagName(a);
          const int fd = ::open(flag.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0444);
          if (fd < 0) throw Error(Errno("cannot create"), flag.string());
          ::close(fd);
          CrashPoint("archive flag written");
        }
        FsyncPath(s.dir, true, s.dir.string());
      }
      if (error) std::rethrow_exception(error);
    }
    if (link) LinkArchives(s, archives);
    if (s.behavior.mode == InstallMode::kEager) CompleteEager(s);
  }

  // --- verify --------------------------------------------------------------------------------

  std::vector<Diagnostic> Verify(const std::vector<std::string>& names, bool repair,
                                 size_t* files_checked) {
    std::vector<Diagnostic> problems;
    size_t checked = 0;
    const Json doc = ReadVersionsManifest(assets / kVersionsManifestFile);
    for (auto t = doc.begin(); t != doc.end(); ++t) {
      if (!t->is_object()) continue;
      for (auto src = t->begin(); src != t->end(); ++src) {
        if (!src->is_string()) continue;
        if (!names.empty() && std::find(names.begin(), names.end(), src.key()) == names.end()) {
          continue;
        }
        const fs::path dir = settings.VersionDir(t.key(), src.key(), src->get<std::string>());
        if (IsFile(dir / std::string(kPackageManifestFile))) continue;  // a package
        const fs::path members = dir / ".mlspaces" / "members";
        std::error_code ec;
        if (!fs::is_directory(members, ec)) continue;
        for (const fs::path& listing_path : ListFolder(members)) {
          if (listing_path.extension() != ".json") continue;
          Json listing;
          try {
            listing = ParseJsonFile(listing_path);
          } catch (const Error& e) {
            problems.push_back({listing_path.string(), "", e.message()});
            continue;
          }
          if (!listing.is_object() || !listing.contains("archive") ||
              !listing["archive"].is_string() || !listing.contains("files") ||
              !listing["files"].is_object()) {
            problems.push_back({listing_path.string(), "", "not a member listing"});
            continue;
          }
          const std::string archive = listing["archive"].get<std::string>();
          const fs::path flag = dir / ExtractFlagName(archive);
          if (!IsFile(flag)) continue;  // not installed (or being reinstalled)
          bool good = true;
          for (auto f = listing["files"].begin(); f != listing["files"].end(); ++f) {
            ++checked;
            const fs::path file = dir / f.key();
            const Json& info = *f;
            if (!info.is_object() || !info.contains("size") || !info.contains("sha256")) {
              problems.push_back({listing_path.string(), f.key(), "bad entry"});
              good = false;
              continue;
            }
            if (!IsFile(file)) {
              problems.push_back({file.string(), "", "missing"});
              good = false;
              continue;
            }
            const FileDigest d = Sha256File(file);
            if (d.size != info["size"].get<uint64_t>()) {
              problems.push_back({file.string(), "",
                                  "size " + std::to_string(d.size) + ", expected " +
                                      std::to_string(info["size"].get<uint64_t>())});
              good = false;
            } else if (d.sha256 != info["sha256"].get<std::string>()) {
              problems.push_back({file.string(), "",
                                  "SHA-256 " + d.sha256 + ", expected " +
                                      info["sha256"].get<std::string>() +
                                      " (recorded when installed)"});
              good = false;
            }
          }
          if (!good && repair) {
            Locks locks = Hold();
            fs::remove(flag, ec);
            problems.back().message += " (archive " + archive + " will be installed again)";
          }
        }
      }
    }
    if (files_checked != nullptr) *files_checked += checked;
    return problems;
  }
};

MolmoSources::MolmoSources(const ResourceSettings& settings, Options options)
    : impl_(std::make_unique<Impl>(settings, std::move(options))) {}
MolmoSources::~MolmoSources() = default;

bool MolmoSources::InCache(const std::string& type, const std::string& name,
                           const std::string& version) const {
  return impl_->InCache(type, name, version);
}

const MolmoSource* MolmoSources::Setup(const std::string& type, const std::string& name,
                                       const std::string& version) {
  return impl_->Setup(type, name, version);
}

void MolmoSources::Install(const MolmoSource& source, const std::vector<std::string>& archives,
                           bool link) {
  impl_->Install(source, archives, link);
}

void MolmoSources::LinkArchives(const MolmoSource& source,
                                const std::vector<std::string>& archives) {
  Impl::Locks locks = impl_->Hold();
  impl_->LinkArchives(source, archives);
}

std::vector<Diagnostic> MolmoSources::Verify(const std::vector<std::string>& names, bool repair,
                                             size_t* files_checked) {
  return impl_->Verify(names, repair, files_checked);
}

}  // namespace mlspaces
