// MolmoSpaces-format sources: what the original's resource manager (molmospaces-resources
// 0.0.2, spec 7) serves and installs, read and written the same way so that the original
// reads an mlspaces-made install and mlspaces reads the original's.
//
//   <remote>/<type>/<source>/<version>/mjthor_resource_file_to_size_mb.json   {archive: MB}
//   <remote>/<type>/<source>/<version>/mjthor_resources_combined_meta.json.gz {archive: trie}
//   <remote>/<type>/<source>/<version>/<archive>.tar.zst
//
// This header holds the pure parts (per-source behaviour, archive indexes, the tries reader)
// and MolmoSources, which sets such sources up in the cache and installs their archives;
// Installer (installer.h) uses it for every source that is not an mlspaces package. The
// layout, guarantees and differences from the original: docs/resources.md
// ("MolmoSpaces-format sources").
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "mlspaces/core/diagnostics.h"
#include "mlspaces/core/json.h"
#include "mlspaces/resources/sources.h"

namespace mlspaces {

// =============================================================================================
// Per-source behaviour (the original's behaviors.py)

/// How a source appears in the install dir: one dir symlink into the cache version dir
/// (GLOBAL), or a real dir whose files are symlinks into it (PER_FILE; scenes and robots, so
/// that a scene's ../objects/... references resolve inside the install tree).
enum class LinkStrategy { kGlobal, kPerFile };
/// When archives are extracted: all at set-up (EAGER) or one at a time when asked (ON_DEMAND).
enum class InstallMode { kEager, kOnDemand };
/// Which archive index a source has: tokens of [./_\s]+ (Substring), integers -?\d+ (Numeric).
enum class ArchiveIndexKind { kNone, kSubstring, kNumeric };

struct MLSPACES_API SourceBehavior {
  LinkStrategy link = LinkStrategy::kGlobal;
  InstallMode mode = InstallMode::kEager;
  ArchiveIndexKind index = ArchiveIndexKind::kNone;
};

/// The behaviour of <type>/<source>: the data type's default (objects, grasps: GLOBAL
/// ON_DEMAND Substring; scenes: PER_FILE ON_DEMAND Numeric; robots: PER_FILE EAGER;
/// test_data, benchmarks, textures: GLOBAL EAGER) with the original's overrides
/// (objects/thor, objects/objathor_metadata, grasps/droid, grasps/rum EAGER;
/// robots/humans_rocketbox ON_DEMAND Substring). @throws Error for an unknown data type.
MLSPACES_API SourceBehavior ResolveSourceBehavior(const std::string& type,
                                                  const std::string& source);

// =============================================================================================
// Archive indexes (the original's indexing.py)

/// Non-empty pieces of `text` split on runs of '.', '/', '_' and white space.
MLSPACES_API std::vector<std::string> SplitQueryTokens(std::string_view text);
/// The integers (-?\d+) in `text`, in order, as written.
MLSPACES_API std::vector<std::string> NumericTokens(std::string_view text);

/// token -> archives. Substring tokens come from the name without ".tar.zst"; numeric ones
/// from the whole name. A plain value; copies own their data.
class MLSPACES_API ArchiveIndex {
 public:
  ArchiveIndex() = default;  ///< kNone: every query answers nothing
  ArchiveIndex(ArchiveIndexKind kind, std::span<const std::string> archives);

  ArchiveIndexKind kind() const { return kind_; }
  /// The archives holding `token`, sorted (empty for an unknown token or kNone).
  std::vector<std::string> QueryToken(std::string_view token) const;
  /// Union of the buckets of the query's tokens that hold at most `max_returns` archives
  /// (more: the token is ambiguous and ignored), sorted.
  std::vector<std::string> Candidates(std::string_view query, size_t max_returns = 1) const;
  /// The archives of `archives` that no token covers, sorted (all of them for kNone).
  std::vector<std::string> Unindexed(std::span<const std::string> archives) const;

 private:
  ArchiveIndexKind kind_ = ArchiveIndexKind::kNone;
  std::vector<std::string> names_;
  std::unordered_map<std::string, std::vector<uint32_t>> buckets_;  // sorted, unique
};

// =============================================================================================
// Tries (mjthor_resources_combined_meta.json.gz)

/// A tries file read: every archive with its file paths. Keys holding '/'-joined runs of
/// components are split, so the paths are the same whether or not the writer compacted.
struct MLSPACES_API SourceTries {
  std::vector<std::string> archives;                ///< sorted bytewise
  std::vector<std::vector<std::string>> files;      ///< per archive: leaf paths, sorted
  std::unordered_map<std::string, uint32_t> owner;  ///< leaf path -> first archive holding it

  /// Index of an archive name, or nullopt.
  std::optional<uint32_t> Find(std::string_view archive) const;
  /// The archive holding a file (a path relative to the source root), or nullopt. O(1).
  std::optional<uint32_t> ArchiveOf(std::string_view path) const;
};

/// The first '/'-separated component of a path inside a source that is empty, ".", ".." or
/// holds a NUL (such a path could leave the source folder), or nullopt when all are fine.
/// Tries keys and archive names are checked with it.
MLSPACES_API std::optional<std::string_view> BadPathComponent(std::string_view path);
/// The versions manifest of both dirs: {type: {source: [versions]}} in the cache,
/// {type: {source: version or null}} in the assets (install) dir.
inline constexpr std::string_view kVersionsManifestFile =
    "mjthor_data_type_to_source_to_versions.json";
/// Reads a versions manifest as an object; a missing, unreadable or malformed one reads as {}
/// (the caller rewrites it from what is installed).
MLSPACES_API Json ReadVersionsManifest(const std::filesystem::path& file);
/// Inflates gzip bytes (concatenated members allowed). @throws Error naming `origin` for a
/// missing magic, truncation, corruption, trailing bytes or more than 8 GiB inflated.
MLSPACES_API std::string InflateGzip(const std::string& data, const std::string& origin);
/// Reads gzip JSON {archive: trie}. A trie is nested objects whose keys are path components
/// or '/'-joined runs of them; {} is a file. @throws Error naming `origin` and the JSON
/// pointer for bad gzip/JSON, non-object nodes, empty or '.'/'..' components, or empty
/// archive names.
MLSPACES_API SourceTries ParseTries(const std::string& gzip_bytes, const std::string& origin);
/// ParseTries of a file. @throws Error naming the file.
MLSPACES_API SourceTries ReadTries(const std::filesystem::path& file);

/// The remote size manifest {archive: size in MB}. @throws Error naming `origin` for text
/// that is not a JSON object of non-negative numbers (an HTML page, say).
MLSPACES_API std::map<std::string, double> ParseSizeManifest(const std::string& text,
                                                             const std::string& origin);

// =============================================================================================
// Scenes

/// One file a scene MJCF refers to outside its own source: <assets>/objects/<source>/<path>.
struct MLSPACES_API SceneObjectRef {
  std::string source;  ///< object source, e.g. "objaverse"
  std::string path;    ///< relative to the source root
};

/// The `file` attributes of mesh, texture, material, hfield and skin elements under <asset>
/// of `scene_xml` that start with "../", resolved lexically against the scene file's folder
/// inside `assets_dir` (`scene_xml` must lie under it), that land in <assets>/objects/<src>/.
/// Sorted, unique. @throws Error naming the file for unreadable or malformed XML.
MLSPACES_API std::vector<SceneObjectRef> FindSceneObjectRefs(
    const std::filesystem::path& scene_xml, const std::filesystem::path& assets_dir);

// =============================================================================================
// Sources in the cache

/// One MolmoSpaces-format source set up in the cache (manifests and tries downloaded).
struct MLSPACES_API MolmoSource {
  std::string type, name, version;
  SourceBehavior behavior;
  std::filesystem::path dir;              ///< <cache>/<type>/<name>/<version>
  std::filesystem::path install;          ///< <assets>/<type>/<name>
  std::map<std::string, double> size_mb;  ///< the remote size manifest
  SourceTries tries;
  ArchiveIndex index;

  /// Whether `archive`'s `.<archive>_complete_extract` flag is in the version dir.
  bool Extracted(const std::string& archive) const;
  /// Download size estimate of an archive (MB of the size manifest, as bytes).
  uint64_t SizeBytes(const std::string& archive) const;
};

/// Our record of an archive installed from such a source (the remote publishes no
/// checksums): <version dir>/.mlspaces/members/<archive with '/' -> '__'>.json,
/// {path: {"size": N, "sha256": hex}} of every file it placed.
MLSPACES_API std::filesystem::path MolmoMemberListPath(const std::filesystem::path& version_dir,
                                                       const std::string& archive);

/// Sets up and installs MolmoSpaces-format sources. Takes <assets>/.lock then <cache>/.lock
/// (flock, the files the original's filelock uses) around every step that writes, so it
/// excludes other mlspaces installers and the original alike. One thread at a time.
/// Lifetimes: the settings and options given must outlive it; MolmoSource references it
/// returns live as long as it does.
class MLSPACES_API MolmoSources {
 public:
  struct Options {
    std::function<void(const std::string&)> note;  ///< may be empty
    std::function<void(uint64_t)> progress;        ///< bytes downloaded; may be empty
    int parallel_downloads = 4;
    int retries = 3;
    bool force_install = true;  ///< MLSPACES_FORCE_INSTALL: replace another installed version
  };
  MolmoSources(const ResourceSettings& settings, Options options);
  ~MolmoSources();

  /// Whether the cache already holds <type>/<name>/<version> as a MolmoSpaces-format source
  /// (size manifest and tries there), so no network is needed to set it up.
  bool InCache(const std::string& type, const std::string& name, const std::string& version) const;

  /// Sets a source up (once per object): downloads the size manifest and the tries into the
  /// version dir (checked, then renamed into place), builds our UID index for object sources
  /// (.mlspaces/index), links <assets>/<type>/<name> (GLOBAL link or PER_FILE dir) and, for
  /// ON_DEMAND sources, records the version in both versions manifests (EAGER sources are
  /// recorded once all their archives are installed: CompleteEager).
  /// @returns nullptr when neither the cache nor the remote has the size manifest (404).
  /// @throws Error naming the URL/file (HTML instead of JSON, damaged tries, a version
  /// mismatch without force_install).
  const MolmoSource* Setup(const std::string& type, const std::string& name,
                           const std::string& version);

  /// Downloads, checks (zstd frame checksums, tar structure) and extracts `archives` of
  /// `source` (those not flagged yet), renames their files into place, records their member
  /// listings, flags them; PER_FILE sources get their links. Then, for an EAGER source with
  /// every archive flagged, records it in both versions manifests. `link` false leaves the
  /// PER_FILE links out (MLSPACES_DOWNLOAD_EXTRACT_ALL_SCENES_OBJECTS_GRASPS' bulk install).
  /// @throws Error naming the URL/archive; what completed before keeps its flags.
  void Install(const MolmoSource& source, const std::vector<std::string>& archives,
               bool link = true);

  /// Links the archives' files into a PER_FILE install dir (flag .<archive>_complete_links).
  void LinkArchives(const MolmoSource& source, const std::vector<std::string>& archives);

  /// Re-hashes the files of every flagged archive that has a member listing, in every
  /// MolmoSpaces-format source the install dir's versions manifest names (or only `names`).
  /// With `repair`, archives with a bad file lose their extraction flag.
  std::vector<Diagnostic> Verify(const std::vector<std::string>& names, bool repair,
                                 size_t* files_checked);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlspaces
