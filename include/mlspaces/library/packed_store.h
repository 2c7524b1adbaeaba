// Packed libraries: the read-only, memory-mapped stores a published package carries.
//
// A package (see docs/resources.md) is a folder <root>/<data_type>/<name>/<version>/ holding
// tar.zst archives and three store files written by `mlspaces pack`:
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

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/library/annotation.h"
#include "mlspaces/core/npy.h"
#include "mlspaces/core/transform.h"

namespace mlspaces {

inline constexpr std::string_view kUidIndexFile = "uid_index.mlsx";
inline constexpr std::string_view kMetadataStoreFile = "metadata.mlsm";
/// Where `mlspaces index-builtin` keeps the UID index of a MolmoSpaces-format source (one
/// without stores of its own), inside its version folder.
inline constexpr std::string_view kLegacyIndexDir = ".mlspaces/index";
/// Grasp shards live inside the archives, under this folder of the package root.
inline constexpr std::string_view kGraspShardDir = ".mlspaces/grasps";
inline constexpr std::string_view kGraspShardExtension = ".mlsg";

/// The original's extraction flag for an installed archive, a file in the package folder:
/// ".<name with '/' -> '__'>_complete_extract". Its presence means the archive is installed.
std::string ExtractFlagName(const std::string& archive);

/// "foo.tar.zst" -> "foo"; otherwise the name without its last extension.
std::string ArchiveStem(const std::string& archive);

/// Path of an archive's grasp shard inside the archive and the package folder:
/// ".mlspaces/grasps/<archive stem>.mlsg" (what pack writes and lookups open).
std::string GraspShardMember(const std::string& archive);

/// One (robot, joint) grasp set of an asset. `joint` is empty for pickup grasps.
struct PackedGraspRef {
  std::string_view robot;
  std::string_view joint;
  uint32_t archive = 0;        ///< shard = the archive's grasp shard
  uint64_t offset = 0;         ///< byte offset of the first pose in the shard
  uint32_t count = 0;          ///< number of poses
  DType stored_dtype = DType::kF8;  ///< dtype of the NPZ it was packed from
};

/// What the UID index says about one asset. Views point into the mapped file.
struct PackedAsset {
  std::string_view uid;
  std::string_view mjcf;       ///< path relative to the package root, '/'-separated
  uint32_t archive = 0;        ///< index into PackedUidIndex::archives()
  uint64_t metadata_offset = 0, metadata_size = 0;  ///< record in metadata.mlsm (size 0: none)
  uint32_t first_grasp = 0, num_grasps = 0;         ///< range of grasp refs
};

// ---------------------------------------------------------------------------------------------
// Writing (used by `mlspaces pack`). Output is byte-identical for the same input.

/// Appends poses to a grasp shard file; returns offsets for PackedGraspRef.
class GraspShardWriter {
 public:
  /// Starts a shard (written to a temp file, renamed into place by Finish).
  explicit GraspShardWriter(std::filesystem::path path);
  ~GraspShardWriter();
  GraspShardWriter(const GraspShardWriter&) = delete;
  GraspShardWriter& operator=(const GraspShardWriter&) = delete;
  /// Appends poses (f8, row-major); returns the byte offset of the first one.
  uint64_t Append(std::span<const Mat4> poses);
  /// Writes the header, flushes, renames into place; with `sync`, fsyncs the file and its
  /// folder first (pack passes false and flushes the whole package once). @throws Error.
  void Finish(bool sync = true);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One asset handed to the store writer.
struct PackedAssetInput {
  std::string uid;
  std::string mjcf;            ///< relative to the package root
  uint32_t archive = 0;
  const Annotation* annotation = nullptr;  ///< null: no metadata
  struct Grasps {
    std::string robot, joint;  ///< joint empty = pickup
    uint32_t archive = 0;
    uint64_t offset = 0;
    uint32_t count = 0;
    DType stored_dtype = DType::kF8;
  };
  std::vector<Grasps> grasps;
};

/// Streams assets into metadata.mlsm and builds uid_index.mlsx at Finish. Memory use is the
/// index (tens of bytes per asset), not the metadata.
class PackedStoreWriter {
 public:
  /// `dir` is the package folder; `archives` are the archive file names, in index order.
  PackedStoreWriter(std::filesystem::path dir, std::string library,
                    std::vector<std::string> archives);
  ~PackedStoreWriter();
  PackedStoreWriter(const PackedStoreWriter&) = delete;
  PackedStoreWriter& operator=(const PackedStoreWriter&) = delete;
  /// @throws Error for a duplicate UID or an archive index out of range.
  void Add(const PackedAssetInput& asset);
  /// Writes both files atomically. @throws Error naming the path.
  void Finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// ---------------------------------------------------------------------------------------------
// Reading. Open once (mmap); lookups are lock-free and may run from many threads.

class PackedLibrary {
 public:
  /// Opens <dir>/uid_index.mlsx and <dir>/metadata.mlsm (mmap, MAP_SHARED read-only).
  /// `name` is the asset library name lookups report. Grasp shards are opened on first use.
  /// `root` is the package folder MJCF paths, shards and extraction flags are relative to
  /// (default `dir`; an index built for a MolmoSpaces-format source lives elsewhere).
  /// @throws Error naming the file for a missing, truncated or inconsistent store.
  static std::shared_ptr<const PackedLibrary> Open(const std::filesystem::path& dir,
                                                   std::string name,
                                                   const std::filesystem::path& root = {});
  ~PackedLibrary();

  const std::string& name() const;
  const std::filesystem::path& dir() const;
  size_t size() const;                               ///< number of UIDs
  std::span<const std::string> archives() const;     ///< archive file names
  std::vector<std::string> robots() const;           ///< robots with grasps, sorted

  /// One hash probe. nullopt for an unknown UID.
  std::optional<PackedAsset> Find(std::string_view uid) const;
  /// The i-th asset in index order (i < size()), for iteration (install --where, stats).
  PackedAsset At(size_t i) const;
  /// The grasp refs of an asset, in (robot, joint) order.
  std::vector<PackedGraspRef> Grasps(const PackedAsset& asset) const;
  /// The ref for (robot, joint) of an asset, or nullopt.
  std::optional<PackedGraspRef> FindGrasps(const PackedAsset& asset, std::string_view robot,
                                           std::string_view joint) const;

  /// Decodes an asset's annotation. nullptr when it has none. @throws Error for a bad record.
  std::shared_ptr<const Annotation> LoadAnnotation(const PackedAsset& asset) const;

  /// Path of an archive's grasp shard inside the package folder (exists once installed).
  std::filesystem::path GraspShardPath(uint32_t archive) const;
  /// Reads poses `rows` (all when null) of a grasp ref from its shard, mapping the shard on
  /// first use. @throws Error when the shard is not installed or is damaged.
  std::vector<Mat4> ReadGrasps(const PackedGraspRef& ref,
                               const std::vector<size_t>* rows = nullptr) const;

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
