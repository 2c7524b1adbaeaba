// Writing the packed stores a package carries (used by `mlspaces pack` and `index-builtin`):
// uid_index.mlsx, metadata.mlsm and the per-archive grasp shards. The reader is
// PackedLibrary (include/mlspaces/library/packed_store.h); the byte layout is in
// docs/formats.md ("Packed stores"). Output is byte-identical for the same input, whatever
// the order of Add calls.
//
// A writer is used from one thread at a time. Nothing it is given is kept after the call
// returns (PackedAssetInput::annotation is read during Add only).
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mlspaces/core/npy.h"
#include "mlspaces/core/transform.h"

namespace mlspaces {

struct Annotation;  // mlspaces/library/annotation.h

// =============================================================================================
// Grasp shards

/// Appends poses to a grasp shard file; returns offsets for PackedAssetInput::Grasps.
class MLSPACES_API GraspShardWriter {
 public:
  /// Starts a shard (written to a temp file beside `path`, renamed into place by Finish;
  /// removed if the writer is destroyed unfinished). @throws Error naming the path.
  explicit GraspShardWriter(std::filesystem::path path);
  ~GraspShardWriter();
  GraspShardWriter(const GraspShardWriter&) = delete;
  GraspShardWriter& operator=(const GraspShardWriter&) = delete;
  /// Appends poses (f8, row-major); returns the byte offset of the first one.
  /// @throws Error for a non-finite value or after Finish.
  uint64_t Append(std::span<const Mat4> poses);
  /// Writes the header, flushes, renames into place; with `sync`, fsyncs the file and its
  /// folder first (pack passes false and flushes the whole package once). @throws Error.
  void Finish(bool sync = true);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// =============================================================================================
// The UID index and the metadata store

/// One asset handed to the store writer.
struct MLSPACES_API PackedAssetInput {
  std::string uid;
  std::string mjcf;  ///< relative to the package root
  uint32_t archive = 0;
  /// Null: no metadata. Read during Add only (not kept).
  const Annotation* annotation = nullptr;
  struct Grasps {
    std::string robot, joint;  ///< joint empty = pickup
    uint32_t archive = 0;
    uint64_t offset = 0;  ///< GraspShardWriter::Append's return value
    uint32_t count = 0;
    DType stored_dtype = DType::kF8;
  };
  std::vector<Grasps> grasps;
};

/// Streams assets into metadata.mlsm and builds uid_index.mlsx at Finish. Memory use is the
/// index (tens of bytes per asset), not the metadata.
class MLSPACES_API PackedStoreWriter {
 public:
  /// `dir` is the package folder (created); `archives` are the archive file names, in index
  /// order. @throws Error naming the folder.
  PackedStoreWriter(std::filesystem::path dir, std::string library,
                    std::vector<std::string> archives);
  ~PackedStoreWriter();
  PackedStoreWriter(const PackedStoreWriter&) = delete;
  PackedStoreWriter& operator=(const PackedStoreWriter&) = delete;
  /// @throws Error for a duplicate UID, an archive index out of range, duplicate or badly
  /// named grasp sets, or metadata that cannot be encoded.
  void Add(const PackedAssetInput& asset);
  /// Writes both files atomically. @throws Error naming the path.
  void Finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlspaces
