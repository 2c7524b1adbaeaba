// Packed libraries: the read-only, memory-mapped stores a published package carries.
//
// A package (see docs/resources.md) is a folder <root>/<data_type>/<name>/<version>/ holding
// tar.zst archives and three store files written by `mlspaces pack` (the writers are in
// include/mlspaces/resources/packed_store_writer.h; file names in package_layout.h):
//
//   uid_index.mlsx     UID -> (archive, MJCF path, metadata record, grasp entries); an
//                      open-addressing hash table over XXH3-64 of the UID, one probe on average.
//   metadata.mlsm      every asset's annotation: the metadata JSON (as written, key order
//                      kept) and its NPZ arrays as raw little-endian blobs.
//   (per archive)      .mlspaces/grasps/<archive stem>.mlsg inside the archive: the grasp
//                      poses of that archive's assets, f8 row-major 4x4, contiguous per
//                      (uid, robot, joint); installed with the archive.
//
// All integers are little-endian; every section starts 8-byte aligned; every file starts with
// a 64-byte header (magic, format version, sizes). Readers check the header and every offset
// against the file size before use, so a truncated or damaged file is an Error, never a crash.
// The byte layout is in docs/formats.md ("Packed stores").
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/npy.h"
#include "mlspaces/core/transform.h"
#include "mlspaces/library/package_layout.h"

namespace mlspaces {

struct Annotation;

/// One (robot, joint) grasp set of an asset. `joint` is empty for pickup grasps. The views
/// point into the mapped index: valid while the PackedLibrary that returned it lives.
struct MLSPACES_API PackedGraspRef {
  std::string_view robot;
  std::string_view joint;
  uint32_t archive = 0;             ///< shard = the archive's grasp shard
  uint64_t offset = 0;              ///< byte offset of the first pose in the shard
  uint32_t count = 0;               ///< number of poses
  DType stored_dtype = DType::kF8;  ///< dtype of the NPZ it was packed from
};

/// What the UID index says about one asset. The views point into the mapped index: valid
/// while the PackedLibrary that returned it lives (hold its shared_ptr).
struct MLSPACES_API PackedAsset {
  std::string_view uid;
  std::string_view mjcf;  ///< path relative to the package root, '/'-separated
  uint32_t archive = 0;   ///< index into PackedLibrary::archives()
  uint64_t metadata_offset = 0, metadata_size = 0;  ///< record in metadata.mlsm (size 0: none)
  uint32_t first_grasp = 0, num_grasps = 0;         ///< range of grasp refs
};

/// An opened package store. Open once (mmap); lookups are lock-free and may run from many
/// threads. Everything it returns that holds a view (PackedAsset, PackedGraspRef, archives())
/// is valid while the library lives; the mappings are released with the last shared_ptr.
class MLSPACES_API PackedLibrary {
 public:
  // --- opening ---------------------------------------------------------------------------
  /// Opens <dir>/uid_index.mlsx and <dir>/metadata.mlsm (mmap, MAP_SHARED read-only).
  /// `name` is the asset library name lookups report. Grasp shards are opened on first use.
  /// `root` is the package folder MJCF paths, shards and extraction flags are relative to
  /// (default `dir`; an index built for a MolmoSpaces-format source lives elsewhere).
  /// @throws Error naming the file for a missing, truncated or inconsistent store.
  static std::shared_ptr<const PackedLibrary> Open(const std::filesystem::path& dir,
                                                   std::string name,
                                                   const std::filesystem::path& root = {});
  ~PackedLibrary();

  // --- what it holds ----------------------------------------------------------------------
  const std::string& name() const;
  const std::filesystem::path& dir() const;
  size_t size() const;                            ///< number of UIDs
  std::span<const std::string> archives() const;  ///< archive file names
  std::vector<std::string> robots() const;        ///< robots with grasps, sorted

  // --- assets ----------------------------------------------------------------------------
  /// One hash probe. nullopt for an unknown UID. @throws Error for a damaged index.
  std::optional<PackedAsset> Find(std::string_view uid) const;
  /// The i-th asset in index order (i < size()), for iteration (install --where, stats).
  PackedAsset At(size_t i) const;

  // --- grasps ----------------------------------------------------------------------------
  /// The grasp refs of an asset, in (robot, joint) order.
  std::vector<PackedGraspRef> Grasps(const PackedAsset& asset) const;
  /// The ref for (robot, joint) of an asset, or nullopt.
  std::optional<PackedGraspRef> FindGrasps(const PackedAsset& asset, std::string_view robot,
                                           std::string_view joint) const;

  /// Path of an archive's grasp shard inside the package folder (exists once installed).
  std::filesystem::path GraspShardPath(uint32_t archive) const;
  /// Reads poses `rows` (all when null) of a grasp ref from its shard, mapping the shard on
  /// first use. @throws Error when the shard is not installed or is damaged.
  std::vector<Mat4> ReadGrasps(const PackedGraspRef& ref,
                               const std::vector<size_t>* rows = nullptr) const;

  // --- annotations -----------------------------------------------------------------------
  /// Decodes an asset's annotation: a new object the caller owns (not cached here; the
  /// Registry caches). nullptr when the asset has none. @throws Error for a bad record.
  std::shared_ptr<const Annotation> LoadAnnotation(const PackedAsset& asset) const;

  // --- integrity -------------------------------------------------------------------------
  /// Walks the whole store: both files' checksums, every bucket, record, grasp ref and
  /// metadata record (UIDs sorted, each found by its hash). Touches every page; for tests and
  /// `validate`, not for lookups. Grasp shards are not read. @throws Error naming the file.
  void Check() const;

 private:
  PackedLibrary();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlspaces
