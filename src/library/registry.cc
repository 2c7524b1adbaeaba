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
#include <mutex>
#include <utility>

#include "registry_impl.h"

namespace mlspaces {
namespace fs = std::filesystem;
using namespace registry_detail;  // NOLINT(google-build-using-namespace): this file's helpers

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

}  // namespace mlspaces
