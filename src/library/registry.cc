// The registry of asset and grasp libraries (spec sections 5, 6.1, 8.3, 8.4, 9).
//
// Layout of the lookup structures:
// - every user asset library owns an unordered_map uid -> (entry, absolute MJCF path), built
//   once at registration;
// - one global map uid -> first user library holding it (plus the duplicate record, if any),
//   so Locate is one hash lookup for user UIDs;
// - built-in thor/objaverse are scanned once, lazily, into their own maps.
// Registration builds everything into temporaries and commits at the end (transactional).
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
namespace fs = std::filesystem;

namespace {

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
bool IsBuiltinAssetLibrary(std::string_view name) {
  for (std::string_view b : kBuiltinAssetLibraries) {
    if (b == name) return true;
  }
  return false;
}

bool IsBuiltinGraspLibrary(std::string_view name) {
  for (std::string_view b : kBuiltinGraspLibraries) {
    if (b == name) return true;
  }
  return false;
}

/// Absolute, lexically normal, without a trailing separator.
fs::path MakeAbsolute(const fs::path& path) {
  fs::path out = fs::absolute(path).lexically_normal();
  if (!out.has_filename() && out.has_parent_path() && out != out.root_path()) {
    out = out.parent_path();
  }
  return out;
}

std::string QuotedList(const std::vector<std::string>& names) {
  std::string out = "[";
  for (size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += ", ";
    out += "'" + names[i] + "'";
  }
  return out + "]";
}

}  // namespace

// ---------------------------------------------------------------------------------------------

struct Registry::Impl {
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
    fs::path dir;
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
    StringMap<fs::path> uids;
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
    const PackedLibrary* packed = nullptr;      ///< packed grasp library: its store
    const PackedEntry* packed_entry = nullptr;  ///< its installed-archive cache
    StringMap<fs::path> pickup;                 ///< uid -> absolute path
    StringMap<StringMap<fs::path>> joints;      ///< uid -> joint -> absolute path
  };

  Options options;
  std::vector<std::unique_ptr<UserAssetLibrary>> user_libraries;
  std::unordered_map<std::string_view, UidRecord, StringHash, std::equal_to<>> uids;
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
      options.assets_dir = MakeAbsolute(*options.assets_dir);
      for (auto [asset_lib, grasp_lib] :
           {std::pair{kThor, kDroid}, std::pair{kObjaverse, kDroidObjaverse}}) {
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
      std::vector<std::pair<fs::path, fs::path>> found;  // (store dir, package root)
      std::error_code ec;
      for (const auto& entry : fs::directory_iterator(*options.assets_dir / "objects", ec)) {
        const fs::path& root = entry.path();
        if (root.filename().string() == kObjathorMetadata) {  // annotations only, no MJCFs
          const fs::path store = root / std::string(kLegacyIndexDir);
          if (IsFile(store / std::string(kUidIndexFile))) {
            objathor = PackedLibrary::Open(store, std::string(kObjathorMetadata), root);
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
  void AddPacked(const std::string& name, const fs::path& dir, const fs::path& root = {}) {
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
    if (options.assets_dir) names = {std::string(kThor), std::string(kObjaverse)};
    for (const auto& [name, lib] : packed) {
      if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    }
    std::sort(names.begin(), names.end(), [](const std::string& a, const std::string& b) {
      return std::make_pair(a != kThor, a) < std::make_pair(b != kThor, b);
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
  std::optional<fs::path> FindIn(const Source& src, std::string_view uid) const {
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
    BuiltinScan& scan = library == kThor ? thor_scan : objaverse_scan;
    std::call_once(scan.once, [&] {
      ScanMjcfs(*options.assets_dir / "objects" / std::string(library), std::string(library), scan);
    });
    return &scan;
  }

  /// Collects <dir>/**/*.xml by stem. Sorted by path so the winner of a duplicated stem
  /// does not depend on directory order (the original lets the last file scanned win).
  static void ScanMjcfs(const fs::path& dir, const std::string& library, BuiltinScan& scan) {
    std::vector<std::pair<std::string, fs::path>> found;  // (generic path, path)
    std::error_code ec;
    fs::recursive_directory_iterator it(dir, fs::directory_options::skip_permission_denied, ec);
    if (ec) return;  // not installed
    for (; it != fs::recursive_directory_iterator(); it.increment(ec)) {
      if (ec) break;
      const fs::path& p = it->path();
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
               std::vector<fs::path>& paths) const {
    for (const Source& src : sources) {
      if (std::optional<fs::path> mjcf = FindIn(src, uid)) {
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
    if (IsBuiltinAssetLibrary(name) || packed.count(name) != 0) return true;
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

  std::optional<fs::path> PickupCandidate(const GraspLibrary& lib, std::string_view uid) const {
    if (lib.info.builtin) {
      std::string u(uid);
      return lib.info.dir / u / (u + "_grasps_filtered.npz");
    }
    auto it = lib.pickup.find(uid);
    if (it == lib.pickup.end()) return std::nullopt;
    return it->second;
  }

  std::optional<fs::path> JointCandidate(const GraspLibrary& lib, std::string_view uid,
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

// ---------------------------------------------------------------------------------------------

Registry::Registry() : Registry(Options{}) {}
Registry::Registry(Options options) : impl_(std::make_unique<Impl>(std::move(options))) {}
Registry::~Registry() = default;
Registry::Registry(Registry&&) noexcept = default;
Registry& Registry::operator=(Registry&&) noexcept = default;

void Registry::RegisterAssetLibrary(const std::string& name, const fs::path& dir) {
  Impl& impl = *impl_;
  if (name.empty()) throw UsageError("User library name must not be empty");
  if (name.find('/') != std::string::npos) {
    throw UsageError("User library " + name + " must not contain slashes");
  }
  for (const auto& lib : impl.user_libraries) {
    if (lib->name == name) throw Error("User library " + name + " already registered");
  }
  if (IsBuiltinAssetLibrary(name)) {
    throw Error("User library " + name + " name conflicts with a built-in object source");
  }
  if (impl.packed.count(name) != 0) {
    throw Error("User library " + name + " name conflicts with an installed packed library");
  }
  const fs::path root = MakeAbsolute(dir);
  const fs::path index_file = root / "assets_index.json";
  if (!IsFile(index_file)) {
    throw Error("User library " + name + " has no assets_index.json (no such file)",
                index_file.string());
  }

  // Build the new library and the global-map changes into temporaries.
  auto lib = std::make_unique<Impl::UserAssetLibrary>();
  lib->name = name;
  lib->dir = root;
  lib->index = AssetIndex::Load(index_file);
  lib->dir_fd = ::open(root.c_str(), O_PATH | O_DIRECTORY | O_CLOEXEC);
  lib->uids.reserve(lib->index.entries.size());
  std::vector<std::string> mjcfs;
  mjcfs.reserve(lib->index.entries.size());
  size_t arena_size = 0;
  for (const auto& [uid, entry] : lib->index.entries) {
    lib->uids.emplace(uid, &entry);
    mjcfs.push_back((root / entry.object_path).string());
    arena_size += uid.size() + mjcfs.back().size();
  }
  lib->arena.reserve(arena_size);
  struct Placed {
    std::string_view uid, mjcf;
    const AssetEntry* entry;
  };
  std::vector<Placed> placed;
  placed.reserve(mjcfs.size());
  {
    size_t i = 0;
    for (const auto& [uid, entry] : lib->index.entries) {
      const size_t at = lib->arena.size();
      lib->arena += uid;
      lib->arena += mjcfs[i++];
      const std::string_view view(lib->arena);
      placed.push_back({view.substr(at, uid.size()), view.substr(at + uid.size()), &entry});
    }
  }
  const uint32_t lib_index = static_cast<uint32_t>(impl.user_libraries.size());
  struct Shadowed {
    const Placed* placed;
    Impl::UidRecord* existing;
  };
  std::vector<const Placed*> fresh;
  std::vector<Shadowed> shadowed;
  for (const Placed& p : placed) {
    auto it = impl.uids.find(p.uid);
    if (it == impl.uids.end()) {
      fresh.push_back(&p);
    } else {
      shadowed.push_back({&p, &it->second});
    }
  }
  // New duplicates are appended in UID order, so duplicates() is deterministic.
  std::sort(shadowed.begin(), shadowed.end(),
            [](const Shadowed& a, const Shadowed& b) { return a.placed->uid < b.placed->uid; });
  std::vector<DuplicateUid> duplicates = impl.user_duplicates;
  std::vector<std::pair<Impl::UidRecord*, int32_t>> new_dup_index;
  for (const Shadowed& s : shadowed) {
    if (s.existing->duplicate >= 0) {
      DuplicateUid& dup = duplicates[static_cast<size_t>(s.existing->duplicate)];
      dup.libraries.push_back(name);
      dup.paths.emplace_back(s.placed->mjcf);
    } else {
      const Impl::UserAssetLibrary& first = *impl.user_libraries[s.existing->library];
      new_dup_index.emplace_back(s.existing, static_cast<int32_t>(duplicates.size()));
      duplicates.push_back({std::string(s.placed->uid),
                            {first.name, name},
                            {fs::path(s.existing->mjcf), fs::path(s.placed->mjcf)}});
    }
  }
  impl.uids.reserve(impl.uids.size() + fresh.size());

  // Commit (nothing below throws but bad_alloc).
  for (auto& [existing, index] : new_dup_index) existing->duplicate = index;
  for (const Placed* p : fresh) {
    impl.uids.emplace(p->uid, Impl::UidRecord{lib_index, -1, p->entry, p->mjcf});
  }
  impl.user_duplicates = std::move(duplicates);
  impl.user_libraries.push_back(std::move(lib));
  ++impl.generation;
}

std::vector<std::string> Registry::RegisterGraspLibrary(const std::string& root_name,
                                                        const fs::path& dir,
                                                        const std::string& asset_library) {
  Impl& impl = *impl_;
  if (root_name.empty()) throw UsageError("User grasp library name must not be empty");
  if (root_name.find('/') != std::string::npos) {
    throw UsageError("User grasp library " + root_name + " must not contain slashes");
  }
  const fs::path root = MakeAbsolute(dir);
  const fs::path index_file = root / "grasps_index.json";
  if (!IsFile(index_file)) {
    throw Error("User grasp library " + root_name + " has no grasps_index.json (no such file)",
                index_file.string());
  }
  if (!impl.IsAssetLibrary(asset_library)) {
    throw Error("Object library " + asset_library + " not found");
  }
  const GraspIndex index = GraspIndex::Load(index_file);

  std::vector<std::unique_ptr<Impl::GraspLibrary>> libs;
  std::vector<std::string> names;
  for (const std::string& robot : index.robots()) {  // sorted: deterministic priority
    std::string name = root_name + "/" + robot;
    if (impl.grasp_libraries.find(name) != impl.grasp_libraries.end()) {
      throw Error("User grasp library " + name + " already registered");
    }
    if (IsBuiltinGraspLibrary(name)) {
      throw Error("User grasp library " + name + " name conflicts with a built-in grasp source");
    }
    auto lib = std::make_unique<Impl::GraspLibrary>();
    lib->info = {name, robot, root, asset_library, false};
    if (auto it = index.grasp_paths.find(robot); it != index.grasp_paths.end()) {
      lib->pickup.reserve(it->second.size());
      for (const auto& [uid, rel] : it->second) lib->pickup.emplace(uid, root / rel);
    }
    if (auto it = index.articulated_grasp_paths.find(robot);
        it != index.articulated_grasp_paths.end()) {
      lib->joints.reserve(it->second.size());
      for (const auto& [uid, joints] : it->second) {
        StringMap<fs::path>& out = lib->joints[uid];
        for (const auto& [joint, rel] : joints) out.emplace(joint, root / rel);
      }
    }
    names.push_back(std::move(name));
    libs.push_back(std::move(lib));
  }
  std::vector<std::string> list = names;
  if (auto it = impl.grasp_lists.find(asset_library); it != impl.grasp_lists.end()) {
    list.insert(list.end(), it->second.begin(), it->second.end());
  }

  // Commit.
  for (auto& lib : libs) {
    std::string key = lib->info.name;
    impl.grasp_libraries.emplace(std::move(key), std::move(lib));
  }
  impl.grasp_lists[asset_library] = std::move(list);
  ++impl.generation;
  return names;
}

void Registry::RegisterPackedLibrary(const std::string& name, const fs::path& dir) {
  Impl& impl = *impl_;
  if (name.empty() || name.find('/') != std::string::npos) {
    throw UsageError("Packed library name '" + name + "' must be non-empty, without slashes");
  }
  if (impl.IsAssetLibrary(name)) throw Error("Asset library " + name + " already registered");
  impl.AddPacked(name, MakeAbsolute(dir));
  impl.RebuildSources();
  ++impl.generation;
}

std::shared_ptr<const PackedLibrary> Registry::FindPackedLibrary(std::string_view name) const {
  auto it = impl_->packed.find(name);
  return it == impl_->packed.end() ? nullptr : it->second.lib;
}

std::vector<std::string> Registry::asset_libraries() const {
  std::vector<std::string> out;
  for (const Impl::Source& src : impl_->sources) out.push_back(src.name);
  if (impl_->options.assets_dir && impl_->packed.count(kObjathorMetadata) == 0) {
    out.push_back(std::string(kObjathorMetadata));
  }
  for (const auto& lib : impl_->user_libraries) out.push_back(lib->name);
  return out;
}

std::vector<std::string> Registry::grasp_libraries_of(const std::string& asset_library) const {
  auto it = impl_->grasp_lists.find(asset_library);
  return it == impl_->grasp_lists.end() ? std::vector<std::string>{} : it->second;
}

const GraspLibraryInfo* Registry::FindGraspLibrary(std::string_view name) const {
  auto it = impl_->grasp_libraries.find(name);
  return it == impl_->grasp_libraries.end() ? nullptr : &it->second->info;
}

const std::vector<DuplicateUid>& Registry::duplicates() const {
  const Impl& impl = *impl_;
  std::lock_guard<std::mutex> lock(impl.duplicates_mutex);
  if (impl.duplicates_generation == impl.generation) return impl.all_duplicates;
  std::vector<DuplicateUid> out;
  if (!impl.sources.empty()) {
    // Stems found twice inside one scanned library.
    for (const Impl::Source& src : impl.sources) {
      if (src.packed != nullptr) continue;
      const Impl::BuiltinScan* scan = impl.Scan(src.name);
      out.insert(out.end(), scan->duplicates.begin(), scan->duplicates.end());
    }
    // UIDs held by several libraries: every UID of every source but the largest packed one
    // (a UID shared with it is found from the other side), then the user UIDs.
    const PackedLibrary* largest = nullptr;
    for (const Impl::Source& src : impl.sources) {
      if (src.packed != nullptr && (largest == nullptr || src.packed->size() > largest->size())) {
        largest = src.packed;
      }
    }
    std::unordered_map<std::string, bool> seen;
    auto add_if_shared = [&](std::string_view uid) {
      if (!seen.emplace(std::string(uid), true).second) return;
      DuplicateUid dup{std::string(uid), {}, {}};
      impl.Holders(uid, dup.libraries, dup.paths);
      if (dup.libraries.size() > 1) out.push_back(std::move(dup));
    };
    for (const Impl::Source& src : impl.sources) {
      if (src.packed == largest && largest != nullptr) continue;
      if (src.packed != nullptr) {
        for (size_t i = 0; i < src.packed->size(); ++i) add_if_shared(src.packed->At(i).uid);
      } else {
        for (const auto& [uid, path] : impl.Scan(src.name)->uids) add_if_shared(uid);
      }
    }
    for (const auto& [uid, rec] : impl.uids) add_if_shared(uid);
  } else {
    out = impl.user_duplicates;
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const DuplicateUid& a, const DuplicateUid& b) { return a.uid < b.uid; });
  impl.all_duplicates = std::move(out);
  impl.duplicates_generation = impl.generation;
  return impl.all_duplicates;
}

size_t Registry::num_uids() const { return impl_->uids.size(); }

std::vector<std::string> Registry::user_uids() const {
  std::vector<std::string> out;
  out.reserve(impl_->uids.size());
  for (size_t i = 0; i < impl_->user_libraries.size(); ++i) {
    for (const auto& [uid, entry] : impl_->user_libraries[i]->index.entries) {
      const Impl::UidRecord* rec = impl_->FindUser(uid);
      if (rec != nullptr && rec->library == i) out.push_back(uid);
    }
  }
  return out;
}

void Registry::RegisterObjathorStore(const fs::path& dir) {
  impl_->objathor = PackedLibrary::Open(MakeAbsolute(dir), std::string(kObjathorMetadata));
  std::lock_guard<std::mutex> lock(impl_->annotation_mutex);
  impl_->annotations.clear();
}

std::shared_ptr<const PackedLibrary> Registry::objathor_store() const { return impl_->objathor; }

std::vector<std::string> Registry::annotated_uids() const {
  const Impl& impl = *impl_;
  std::vector<std::string> out;
  std::unordered_set<std::string_view> seen;
  auto add_packed = [&](const PackedLibrary& lib) {
    for (size_t i = 0; i < lib.size(); ++i) {
      const PackedAsset a = lib.At(i);
      if (a.metadata_size != 0 && seen.insert(a.uid).second) out.emplace_back(a.uid);
    }
  };
  if (impl.objathor) add_packed(*impl.objathor);
  for (const Impl::Source& src : impl.sources) {
    if (src.packed != nullptr) add_packed(*src.packed);
  }
  for (std::string& uid : user_uids()) {
    if (!seen.contains(uid)) out.push_back(std::move(uid));
  }
  return out;
}

std::optional<AssetLocation> Registry::Locate(std::string_view uid) const {
  const Impl& impl = *impl_;
  // Built-in and packed sources first (one probe each); only the winner's path is built.
  std::optional<AssetLocation> loc;
  for (const Impl::Source& src : impl.sources) {
    if (src.packed != nullptr) {
      const std::optional<PackedAsset> asset = src.packed->Find(uid);
      if (!asset) continue;
      if (loc) {
        loc->shadowed.push_back(src.name);
        continue;
      }
      loc.emplace();
      loc->library = src.name;
      loc->mjcf_path = src.packed->dir();
      loc->mjcf_path /= asset->mjcf;
      loc->archive = src.packed->archives()[asset->archive];
      loc->installed = src.entry->Installed(asset->archive);
    } else {
      const Impl::BuiltinScan* scan = impl.Scan(src.name);
      auto it = scan->uids.find(uid);
      if (it == scan->uids.end()) continue;
      if (loc) {
        loc->shadowed.push_back(src.name);
        continue;
      }
      loc.emplace();
      loc->library = src.name;
      loc->mjcf_path = it->second;
    }
  }
  // Then the user libraries: one hash lookup.
  const Impl::UidRecord* rec = impl.FindUser(uid);
  if (rec == nullptr) return loc;
  std::vector<std::string> holders;
  if (rec->duplicate >= 0) {
    holders = impl.user_duplicates[static_cast<size_t>(rec->duplicate)].libraries;
  } else {
    holders.push_back(impl.user_libraries[rec->library]->name);
  }
  if (loc) {
    loc->shadowed.insert(loc->shadowed.end(), holders.begin(), holders.end());
    return loc;
  }
  loc.emplace();
  loc->library = std::move(holders.front());
  loc->mjcf_path = fs::path(rec->mjcf);
  loc->entry = rec->entry;
  loc->shadowed.assign(std::make_move_iterator(holders.begin() + 1),
                       std::make_move_iterator(holders.end()));
  return loc;
}

AssetLocation Registry::LocateOrThrow(std::string_view uid) const {
  std::optional<AssetLocation> loc = Locate(uid);
  if (!loc) {
    throw Error(std::string(uid) + " not found in asset libraries " + QuotedList(asset_libraries()),
                "", "", std::string(uid));
  }
  return std::move(*loc);
}

std::shared_ptr<const Annotation> Registry::GetAnnotation(std::string_view uid) const {
  const Impl& impl = *impl_;
  {
    std::lock_guard<std::mutex> lock(impl.annotation_mutex);
    auto it = impl.annotations.find(uid);
    if (it != impl.annotations.end()) return it->second;
  }
  if (impl.objathor) {  // the original's union: objathor first
    if (std::optional<PackedAsset> asset = impl.objathor->Find(uid)) {
      std::shared_ptr<const Annotation> annotation = impl.objathor->LoadAnnotation(*asset);
      if (annotation) {
        std::lock_guard<std::mutex> lock(impl.annotation_mutex);
        auto [it, inserted] = impl.annotations.try_emplace(std::string(uid), std::move(annotation));
        return it->second;
      }
    }
  }
  for (const Impl::Source& src : impl.sources) {
    if (src.packed == nullptr) continue;
    std::optional<PackedAsset> asset = src.packed->Find(uid);
    if (!asset) continue;
    std::shared_ptr<const Annotation> annotation = src.packed->LoadAnnotation(*asset);
    if (!annotation) return nullptr;
    std::lock_guard<std::mutex> lock(impl.annotation_mutex);
    return impl.annotations.try_emplace(std::string(uid), std::move(annotation)).first->second;
  }
  const Impl::UidRecord* rec = impl.FindUser(uid);
  if (rec == nullptr) return nullptr;
  const Impl::UserAssetLibrary& lib = *impl.user_libraries[rec->library];
  const AssetEntry& entry = *rec->entry;
  // Loaded outside the lock so first-time loads of different UIDs run in parallel.
  auto annotation = std::make_shared<const Annotation>(
      internal::LoadAnnotationAt(lib.dir_fd, lib.dir, uid, lib.name, entry.metadata_path,
                                 entry.metadata_npz_path ? &*entry.metadata_npz_path : nullptr));
  std::lock_guard<std::mutex> lock(impl.annotation_mutex);
  auto [it, inserted] = impl.annotations.try_emplace(std::string(uid), std::move(annotation));
  return it->second;
}

std::vector<std::string> Registry::GraspLibrariesFor(std::string_view uid,
                                                     GraspLibraryFilter filter) const {
  return impl_->Walk(uid, filter);
}

namespace {

/// FindGraspFile's walk; `usable` says whether a candidate NPZ is there (IsFile, or a load
/// through the grasp-file cache, which needs one stat for both).
template <class Impl, class Usable>
std::optional<GraspFileLocation> FindGraspFileIn(const Impl& impl, const GraspQuery& query,
                                                 const Usable& usable) {
  const std::string_view uid = query.uid;
  const GraspLibraryFilter filter = query.libraries;
  if (query.joint.empty()) {
    for (const std::string& name : impl.Walk(uid, filter)) {
      const auto& lib = *impl.grasp_libraries.find(name)->second;
      if (lib.packed != nullptr) {
        if (auto loc = impl.PackedCandidate(lib, uid, "")) return loc;
        continue;
      }
      std::optional<fs::path> candidate = impl.PickupCandidate(lib, uid);
      if (candidate && usable(*candidate)) return GraspFileLocation{name, *candidate, {}};
    }
    return std::nullopt;
  }
  std::vector<std::string> walk;
  if (!impl.LibraryOf(uid).empty()) {
    walk = impl.Walk(uid, filter);
  } else if (filter.size() == 1 && impl.grasp_libraries.count(filter[0]) != 0) {
    walk = {filter[0]};  // UID in no asset library (iTHOR articulated objects): ask directly
  }
  for (const std::string& name : walk) {
    const auto& lib = *impl.grasp_libraries.find(name)->second;
    if (lib.packed != nullptr) {
      if (auto loc = impl.PackedCandidate(lib, uid, query.joint)) return loc;
      continue;
    }
    std::optional<fs::path> candidate = impl.JointCandidate(lib, uid, query.joint);
    if (candidate && usable(*candidate)) return GraspFileLocation{name, *candidate, {}};
  }
  return std::nullopt;
}

}  // namespace

std::optional<GraspFileLocation> Registry::FindGraspFile(const GraspQuery& query) const {
  return FindGraspFileIn(*impl_, query, [](const fs::path& p) { return IsFile(p); });
}

std::optional<fs::path> Registry::GraspPath(const GraspQuery& query) const {
  auto found = FindGraspFile(query);
  if (!found) return std::nullopt;
  return std::move(found->path);
}

bool Registry::HasValidGrasps(const GraspQuery& query, size_t num_grasps) const {
  std::optional<GraspFileLocation> loc = FindGraspFile(query);
  if (!loc) return false;
  const size_t count = loc->packed ? loc->packed->count : CountGraspFileRows(loc->path);
  return count >= num_grasps;
}

GraspSet Registry::LoadGrasps(const GraspQuery& query, size_t num_grasps, uint64_t seed) const {
  return LoadGrasps(query, SeededRowChooser(num_grasps, seed));
}

GraspSet Registry::LoadGrasps(const GraspQuery& query, const GraspRowChooser& choose) const {
  // One stat per NPZ candidate: the cache's (a missing file is not usable, a present one is
  // decoded or reused while unchanged).
  std::shared_ptr<const GraspSet> all;
  std::optional<GraspFileLocation> loc = FindGraspFileIn(*impl_, query, [&](const fs::path& p) {
    all = impl_->grasp_cache.TryGet(p);
    return all != nullptr;
  });
  if (!loc) {
    throw Error(query.joint.empty()
                    ? "No grasp file found for " + query.uid
                    : "No joint grasp file found for " + query.uid + "/" + query.joint,
                "", "", query.uid);
  }
  if (loc->packed) {
    const PackedLibrary& lib = *impl_->grasp_libraries.find(loc->library)->second->packed;
    return LoadPackedGrasps(lib, *loc->packed, loc->path, choose);
  }
  // The decoded file (grasp_cache.h); the rows are copied out.
  return SelectGraspRows(*all, choose);
}

}  // namespace mlspaces
