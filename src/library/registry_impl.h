// Registry's private state (Registry::Impl) and its helpers, shared by the registry's source
// files: registry.cc (registration, asset lookups, annotations) and registry_grasps.cc (grasp
// lookups). Not installed.
#pragma once

#include "mlspaces/library/registry.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <mutex>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "annotation_internal.h"
#include "grasp_cache.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/library/grasp_index.h"
#include "mlspaces/library/package_layout.h"
#include "mlspaces/library/packed_store.h"

namespace mlspaces {

namespace registry_detail {
namespace fs = std::filesystem;

struct StringHash {
  using is_transparent = void;
  size_t operator()(std::string_view s) const noexcept { return std::hash<std::string_view>{}(s); }
};
template <class V>
using StringMap = std::unordered_map<std::string, V, StringHash, std::equal_to<>>;

constexpr std::string_view kThor = "thor";
constexpr std::string_view kObjaverse = "objaverse";
constexpr std::string_view kObjathorMetadata = "objathor_metadata";
constexpr std::string_view kDroid = "droid";
constexpr std::string_view kDroidObjaverse = "droid_objaverse";
inline bool IsBuiltinAssetLibrary(std::string_view name) {
  for (std::string_view b : kBuiltinAssetLibraries) {
    if (b == name) return true;
  }
  return false;
}

inline bool IsBuiltinGraspLibrary(std::string_view name) {
  for (std::string_view b : kBuiltinGraspLibraries) {
    if (b == name) return true;
  }
  return false;
}

/// Absolute, lexically normal, without a trailing separator.
inline fs::path MakeAbsolute(const fs::path& path) {
  fs::path out = fs::absolute(path).lexically_normal();
  if (!out.has_filename() && out.has_parent_path() && out != out.root_path()) {
    out = out.parent_path();
  }
  return out;
}

inline std::string QuotedList(const std::vector<std::string>& names) {
  std::string out = "[";
  for (size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += ", ";
    out += "'" + names[i] + "'";
  }
  return out + "]";
}

}  // namespace registry_detail

struct Registry::Impl {
  template <class V>
  using StringMap = registry_detail::StringMap<V>;
  /// Decoded grasp files (LoadGrasps), reused while a file is unchanged.
  GraspFileCache grasp_cache;
  /// One user asset library and its uid -> entry map.
  struct UserAssetLibrary {
    UserAssetLibrary() = default;
    UserAssetLibrary(const UserAssetLibrary&) = delete;
    UserAssetLibrary& operator=(const UserAssetLibrary&) = delete;
    ~UserAssetLibrary() {
      if (dir_fd >= 0) ::close(dir_fd);
    }
    std::string name;
    std::filesystem::path dir;
    /// O_PATH descriptor of `dir`, so annotation loads open files relative to it; -1 if the
    /// folder could not be opened (then full paths are used).
    int dir_fd = -1;
    AssetIndex index;
    StringMap<const AssetEntry*> uids;
    /// Each UID followed by its absolute MJCF path, back to back: the global map's keys and
    /// paths are views into it (never reallocated after registration).
    std::string arena;
  };
  /// The global uid -> first user library holding it. Everything Locate needs sits in the
  /// node (the MJCF path as one flat string), so a lookup touches few cache lines.
  struct UidRecord {
    uint32_t library = 0;    ///< index into user_libraries
    int32_t duplicate = -1;  ///< index into user_duplicates, or -1
    const AssetEntry* entry = nullptr;
    std::string_view mjcf;  ///< absolute; in the library's arena, right after the key
  };
  /// A built-in library's lazily scanned stem -> MJCF map.
  struct BuiltinScan {
    std::once_flag once;
    StringMap<std::filesystem::path> uids;
    std::vector<DuplicateUid> duplicates;  ///< stems seen twice in this library
  };
  /// A packed library and which of its archives are known to be installed: checked with
  /// one stat of the archive's extraction flag, and remembered once seen (an install only
  /// adds flags), so hot lookups make no system calls.
  struct PackedEntry {
    std::shared_ptr<const PackedLibrary> lib;
    std::unique_ptr<std::atomic<bool>[]> installed;
    bool Installed(uint32_t archive) const {
      if (installed[archive].load(std::memory_order_relaxed)) return true;
      if (!IsFile(lib->dir() / ExtractFlagName(lib->archives()[archive]))) return false;
      installed[archive].store(true, std::memory_order_relaxed);
      return true;
    }
  };
  struct GraspLibrary {
    GraspLibraryInfo info;
    const PackedLibrary* packed = nullptr;               ///< packed grasp library: its store
    const PackedEntry* packed_entry = nullptr;           ///< its installed-archive cache
    StringMap<std::filesystem::path> pickup;             ///< uid -> absolute path
    StringMap<StringMap<std::filesystem::path>> joints;  ///< uid -> joint -> absolute path
  };

  Options options;
  std::vector<std::unique_ptr<UserAssetLibrary>> user_libraries;
  std::unordered_map<std::string_view, UidRecord, registry_detail::StringHash, std::equal_to<>>
      uids;
  std::vector<DuplicateUid> user_duplicates;  ///< among user libraries, priority order
  StringMap<std::unique_ptr<GraspLibrary>> grasp_libraries;
  StringMap<std::vector<std::string>> grasp_lists;  ///< asset library -> grasp libraries
  uint64_t generation = 0;                          ///< bumped by every registration

  mutable BuiltinScan thor_scan, objaverse_scan;
  const BuiltinScan empty_scan;
  /// Packed libraries (assets dir and RegisterPackedLibrary), by name.
  StringMap<PackedEntry> packed;
  /// Built-in and packed sources in lookup order: thor, then alphabetically.
  struct Source {
    std::string name;
    const PackedLibrary* packed = nullptr;  ///< else a scanned built-in
    const PackedEntry* entry = nullptr;
  };
  std::vector<Source> sources;

  mutable std::mutex duplicates_mutex;
  mutable std::vector<DuplicateUid> all_duplicates;
  mutable uint64_t duplicates_generation = ~uint64_t{0};

  mutable std::mutex annotation_mutex;
  mutable StringMap<std::shared_ptr<const Annotation>> annotations;
  /// The converted objathor_metadata store (annotations only, asked first), or null.
  std::shared_ptr<const PackedLibrary> objathor;

  explicit Impl(Options opts) : options(std::move(opts)) {
    if (options.assets_dir) {
      options.assets_dir = registry_detail::MakeAbsolute(*options.assets_dir);
      for (auto [asset_lib, grasp_lib] :
           {std::pair{registry_detail::kThor, registry_detail::kDroid},
            std::pair{registry_detail::kObjaverse, registry_detail::kDroidObjaverse}}) {
        auto lib = std::make_unique<GraspLibrary>();
        lib->info.name = std::string(grasp_lib);
        lib->info.dir = *options.assets_dir / "grasps" / std::string(grasp_lib);
        lib->info.asset_library = std::string(asset_lib);
        lib->info.builtin = true;
        grasp_libraries.emplace(std::string(grasp_lib), std::move(lib));
        grasp_lists[std::string(asset_lib)].push_back(std::string(grasp_lib));
      }
      // Installed packages: <assets>/objects/<name> with a UID index (a handful of links,
      // not a scan of the assets).
      // A MolmoSpaces-format source (no stores of its own) counts once `mlspaces
      // index-builtin` has built its index into <source>/.mlspaces/index.
      std::vector<std::pair<std::filesystem::path, std::filesystem::path>>
          found;  // (store dir, package root)
      std::error_code ec;
      for (const auto& entry :
           std::filesystem::directory_iterator(*options.assets_dir / "objects", ec)) {
        const std::filesystem::path& root = entry.path();
        if (root.filename().string() ==
            registry_detail::kObjathorMetadata) {  // annotations only, no MJCFs
          const std::filesystem::path store = root / std::string(kLegacyIndexDir);
          if (IsFile(store / std::string(kUidIndexFile))) {
            objathor =
                PackedLibrary::Open(store, std::string(registry_detail::kObjathorMetadata), root);
          }
          continue;
        }
        if (IsFile(root / std::string(kUidIndexFile))) {
          found.emplace_back(root, root);
        } else if (IsFile(root / std::string(kLegacyIndexDir) / std::string(kUidIndexFile))) {
          found.emplace_back(root / std::string(kLegacyIndexDir), root);
        }
      }
      std::sort(found.begin(), found.end());
      for (const auto& [dir, root] : found) AddPacked(root.filename().string(), dir, root);
    }
    RebuildSources();
  }

  /// Opens a package and makes its grasp libraries "<name>/<robot>", ahead of any others
  /// serving the same name. @throws Error.
  void AddPacked(const std::string& name, const std::filesystem::path& dir,
                 const std::filesystem::path& root = {}) {
    PackedEntry entry;
    entry.lib = PackedLibrary::Open(dir, name, root);
    entry.installed = std::make_unique<std::atomic<bool>[]>(entry.lib->archives().size());
    const PackedLibrary* lib = entry.lib.get();
    auto [slot, inserted] = packed.emplace(name, std::move(entry));
    std::vector<std::string> names;
    for (const std::string& robot : lib->robots()) {
      auto g = std::make_unique<GraspLibrary>();
      g->info = {name + "/" + robot, robot, lib->dir(), name, true};
      g->packed = lib;
      g->packed_entry = &slot->second;
      names.push_back(g->info.name);
      grasp_libraries.emplace(g->info.name, std::move(g));
    }
    std::vector<std::string>& list = grasp_lists[name];
    list.insert(list.begin(), names.begin(), names.end());
  }

  void RebuildSources() {
    sources.clear();
    std::vector<std::string> names;
    if (options.assets_dir)
      names = {std::string(registry_detail::kThor), std::string(registry_detail::kObjaverse)};
    for (const auto& [name, lib] : packed) {
      if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    }
    std::sort(names.begin(), names.end(), [](const std::string& a, const std::string& b) {
      return std::make_pair(a != registry_detail::kThor, a) <
             std::make_pair(b != registry_detail::kThor, b);
    });
    for (const std::string& name : names) {
      auto it = packed.find(name);
      if (it == packed.end()) {
        sources.push_back({name, nullptr, nullptr});
      } else {
        sources.push_back({name, it->second.lib.get(), &it->second});
      }
    }
  }

  /// The MJCF path of a UID in one built-in or packed source, if it holds it.
  std::optional<std::filesystem::path> FindIn(const Source& src, std::string_view uid) const {
    if (src.packed != nullptr) {
      std::optional<PackedAsset> asset = src.packed->Find(uid);
      if (!asset) return std::nullopt;
      return src.packed->dir() / std::string(asset->mjcf);
    }
    const BuiltinScan* scan = Scan(src.name);
    auto it = scan->uids.find(uid);
    if (it == scan->uids.end()) return std::nullopt;
    return it->second;
  }

  const BuiltinScan* Scan(std::string_view library) const {
    if (!options.assets_dir) return &empty_scan;
    BuiltinScan& scan = library == registry_detail::kThor ? thor_scan : objaverse_scan;
    std::call_once(scan.once, [&] {
      ScanMjcfs(*options.assets_dir / "objects" / std::string(library), std::string(library), scan);
    });
    return &scan;
  }

  /// Collects <dir>/**/*.xml by stem. Sorted by path so the winner of a duplicated stem
  /// does not depend on directory order (the original lets the last file scanned win).
  static void ScanMjcfs(const std::filesystem::path& dir, const std::string& library,
                        BuiltinScan& scan) {
    std::vector<std::pair<std::string, std::filesystem::path>> found;  // (generic path, path)
    std::error_code ec;
    std::filesystem::recursive_directory_iterator it(
        dir, std::filesystem::directory_options::skip_permission_denied, ec);
    if (ec) return;  // not installed
    for (; it != std::filesystem::recursive_directory_iterator(); it.increment(ec)) {
      if (ec) break;
      const std::filesystem::path& p = it->path();
      if (p.extension() != ".xml") continue;
      std::error_code file_ec;
      if (it->is_directory(file_ec)) continue;
      found.emplace_back(p.generic_string(), p);
    }
    std::sort(found.begin(), found.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    StringMap<size_t> duplicate_of;
    for (auto& [generic, path] : found) {
      std::string stem = path.stem().string();
      auto [pos, inserted] = scan.uids.try_emplace(stem, path);
      if (inserted) continue;
      auto dup = duplicate_of.find(stem);
      if (dup == duplicate_of.end()) {
        duplicate_of.emplace(stem, scan.duplicates.size());
        scan.duplicates.push_back({stem, {library, library}, {pos->second, path}});
      } else {
        scan.duplicates[dup->second].libraries.push_back(library);
        scan.duplicates[dup->second].paths.push_back(path);
      }
    }
  }

  const UidRecord* FindUser(std::string_view uid) const {
    auto it = uids.find(uid);
    return it == uids.end() ? nullptr : &it->second;
  }

  /// The library a UID resolves to (empty if none), without building an AssetLocation.
  std::string_view LibraryOf(std::string_view uid) const {
    for (const Source& src : sources) {
      if (src.packed != nullptr ? src.packed->Find(uid).has_value()
                                : Scan(src.name)->uids.count(uid) != 0) {
        return src.name;
      }
    }
    if (const UidRecord* rec = FindUser(uid)) return user_libraries[rec->library]->name;
    return {};
  }

  /// Every library holding a UID, in priority order, with its MJCF path.
  void Holders(std::string_view uid, std::vector<std::string>& libraries,
               std::vector<std::filesystem::path>& paths) const {
    for (const Source& src : sources) {
      if (std::optional<std::filesystem::path> mjcf = FindIn(src, uid)) {
        libraries.push_back(src.name);
        paths.push_back(std::move(*mjcf));
      }
    }
    const UidRecord* rec = FindUser(uid);
    if (rec == nullptr) return;
    if (rec->duplicate < 0) {
      libraries.push_back(user_libraries[rec->library]->name);
      paths.emplace_back(rec->mjcf);
      return;
    }
    const DuplicateUid& dup = user_duplicates[static_cast<size_t>(rec->duplicate)];
    libraries.insert(libraries.end(), dup.libraries.begin(), dup.libraries.end());
    paths.insert(paths.end(), dup.paths.begin(), dup.paths.end());
  }

  bool IsAssetLibrary(std::string_view name) const {
    if (registry_detail::IsBuiltinAssetLibrary(name) || packed.count(name) != 0) return true;
    for (const auto& lib : user_libraries) {
      if (lib->name == name) return true;
    }
    return false;
  }

  std::vector<std::string> Walk(std::string_view uid, GraspLibraryFilter filter) const {
    std::vector<std::string> out;
    std::string_view library = LibraryOf(uid);
    if (library.empty()) return out;
    auto it = grasp_lists.find(library);
    if (it == grasp_lists.end()) return out;
    if (filter.empty()) return it->second;
    for (const std::string& name : filter) {
      if (std::find(it->second.begin(), it->second.end(), name) == it->second.end()) continue;
      if (std::find(out.begin(), out.end(), name) != out.end()) continue;
      out.push_back(name);
    }
    return out;
  }

  /// A packed grasp library's set for (uid, joint), when its shard is installed.
  std::optional<GraspFileLocation> PackedCandidate(const GraspLibrary& lib, std::string_view uid,
                                                   std::string_view joint) const {
    std::optional<PackedAsset> asset = lib.packed->Find(uid);
    if (!asset) return std::nullopt;
    std::optional<PackedGraspRef> ref = lib.packed->FindGrasps(*asset, lib.info.robot, joint);
    if (!ref) return std::nullopt;
    // Not installed: missing, as a built-in NPZ that is not installed yet.
    if (!lib.packed_entry->Installed(ref->archive)) {
      return std::nullopt;
    }
    return GraspFileLocation{lib.info.name, lib.packed->GraspShardPath(ref->archive), ref};
  }

  std::optional<std::filesystem::path> PickupCandidate(const GraspLibrary& lib,
                                                       std::string_view uid) const {
    if (lib.info.builtin) {
      std::string u(uid);
      return lib.info.dir / u / (u + "_grasps_filtered.npz");
    }
    auto it = lib.pickup.find(uid);
    if (it == lib.pickup.end()) return std::nullopt;
    return it->second;
  }

  std::optional<std::filesystem::path> JointCandidate(const GraspLibrary& lib, std::string_view uid,
                                                      std::string_view joint) const {
    if (lib.info.builtin) {
      return lib.info.dir / std::string(uid) / (std::string(joint) + "_grasps_filtered.npz");
    }
    auto it = lib.joints.find(uid);
    if (it == lib.joints.end()) return std::nullopt;
    auto jt = it->second.find(joint);
    if (jt == it->second.end()) return std::nullopt;
    return jt->second;
  }
};

}  // namespace mlspaces
