// The registry's grasp lookups (spec sections 8.3, 8.4): which grasp libraries serve a UID,
// where its pickup or joint grasp file is, and loading rows from it (through the grasp-file
// cache). Registry::Impl is in registry_impl.h.
#include "mlspaces/library/registry.h"

#include <optional>
#include <string>
#include <vector>

#include "registry_impl.h"

namespace mlspaces {
namespace fs = std::filesystem;

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
