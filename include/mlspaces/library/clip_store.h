// CLIP feature stores and the exact / approximate scan behind `mlspaces search` (spec 8.5).
//
// A store (`clip_features.mlsc`, byte layout in docs/formats.md "CLIP feature store") holds, per
// asset, `views` L2-normalised image vectors and one L2-normalised text vector of `dim` float16
// values, one contiguous record per asset so that a query is one streaming pass over the file.
// An optional section holds a reduced int8 code per asset for the approximate first pass and
// per-vector int8 codes with residual norms that bound every score for exact queries.
//
// The score is the original's ObjectRetriever score: for an L2-normalised query q,
//   score = max over views v of cos(img_v, q) + 0.5 * cos(text, q),
// scores >= threshold are kept, sorted descending (ties by UID bytes), at most top_k returned.
//
// Lifetimes: a ClipStore is immutable once opened and may be searched from many threads; the
// views it returns (uid()) are valid while the store lives (hold its shared_ptr).
#pragma once

#include "mlspaces/core/export.h"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace mlspaces {

/// File name of the store inside a converted objathor index folder
/// (<assets>/objects/objathor_metadata/.mlspaces/index/).
inline constexpr std::string_view kClipStoreFileName = "clip_features.mlsc";

// =============================================================================================
// Writing

/// Writes a store. Records are streamed to a temp file next to `file` as Add is called (memory
/// stays small); Finish adds the UID table and the approximate section, fsyncs and renames the
/// temp file onto `file`. A writer destroyed before Finish removes its temp file. Same input in
/// the same Add order -> byte-identical file.
class MLSPACES_API ClipStoreWriter {
 public:
  /// `views` >= 1 image vectors per asset, `dim` >= 1 values per vector.
  /// @throws Error naming the file when the temp file cannot be created.
  ClipStoreWriter(std::filesystem::path file, size_t views /*3*/, size_t dim /*768*/);
  ~ClipStoreWriter();
  ClipStoreWriter(const ClipStoreWriter&) = delete;
  ClipStoreWriter& operator=(const ClipStoreWriter&) = delete;

  /// One asset: `img` holds views*dim floats (view-major), `text` dim floats. Vectors are
  /// L2-normalised and stored as float16 by the writer. @throws Error (file, uid) on NaN/Inf,
  /// a zero vector, wrong sizes, an empty UID or a UID added twice.
  void Add(std::string_view uid, std::span<const float> img, std::span<const float> text);
  /// Number of assets added so far.
  size_t size() const;
  /// Writes the UID table and the approximate section, then renames into place.
  /// @throws Error naming the file. Call at most once.
  void Finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// =============================================================================================
// Searching

/// One result: the asset and its score. `uid` views the store it came from.
struct MLSPACES_API ClipHit {
  std::string_view uid;
  float score = 0;
};

struct MLSPACES_API ClipSearchOptions {
  size_t top_k = 50;       ///< the original's max_results
  float threshold = 0.5f;  ///< the original's sim_thres: scores below are dropped
  /// Approximate mode: an int8 reduced-dimension first pass picks `candidates` assets
  /// (0: max(1000, 20 * top_k)), which are then scored exactly. Falls back to the exact scan
  /// when the store has no approximate section.
  bool approximate = false;
  size_t candidates = 0;
  /// Exact queries on a store with a bound section (every written store) first compute an
  /// upper bound of each asset's score from small per-vector codes, then score exactly only
  /// the assets whose bound reaches the k-th best exact score so far, best bound first: the
  /// same hits, scores and order as the full scan (docs/search.md). true: always scan every
  /// record (the reference the tests compare with).
  bool full_scan = false;
  /// Threads for the full scan (1: the calling thread only; <= 0: every core).
  int threads = 1;
  /// When set, receives how many assets were scored exactly (n for the full scan).
  size_t* scored = nullptr;
  /// When set, only rows for which it returns true are kept (before top-k). Called from the
  /// scanning threads, only for rows whose score passed the threshold.
  std::function<bool(size_t row)> keep;
};

/// An opened store (mmap, read-only) or one built in memory.
class MLSPACES_API ClipStore {
 public:
  /// Maps `file` and checks its header, every offset and the UID table against the file size.
  /// @throws Error naming the file for a missing, truncated or inconsistent store.
  static std::shared_ptr<const ClipStore> Open(const std::filesystem::path& file);
  /// A store held in memory (no approximate section): `img` is n*views*dim floats, `text`
  /// n*dim, normalised and rounded to float16 as the writer does. `source` names it in errors.
  /// @throws Error (source, uid) as ClipStoreWriter::Add.
  static std::shared_ptr<const ClipStore> FromVectors(std::vector<std::string> uids, size_t views,
                                                      size_t dim, std::span<const float> img,
                                                      std::span<const float> text,
                                                      const std::string& source);
  ~ClipStore();

  // --- what it holds ----------------------------------------------------------------------
  size_t size() const;
  size_t views() const;
  size_t dim() const;
  bool has_approximate() const;               ///< also: has the bound section exact queries use
  const std::filesystem::path& path() const;  ///< empty for in-memory stores
  std::string_view uid(size_t row) const;     ///< row < size()
  /// The row of a UID (binary search over the sorted UID table), or nullopt.
  std::optional<size_t> Find(std::string_view uid) const;
  /// The stored (normalised, float16-rounded) vectors of a row as floats.
  std::vector<float> ImageFeatures(size_t row) const;  ///< views*dim, view-major
  std::vector<float> TextFeature(size_t row) const;    ///< dim

  // --- queries ----------------------------------------------------------------------------
  /// Scores every row against `query` (dim floats, normalised here; need not be unit length)
  /// and returns the hits best first. @throws Error for a wrong-sized, zero or non-finite query.
  std::vector<ClipHit> Search(std::span<const float> query,
                              const ClipSearchOptions& options = {}) const;
  /// The score of one row (the same arithmetic as Search's exact scan).
  float Score(size_t row, std::span<const float> unit_query) const;

  // --- integrity --------------------------------------------------------------------------
  /// Reads the whole file: checksum, UID order, approximate section. @throws Error.
  void Check() const;

 private:
  ClipStore();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Which float kernel the exact scan uses on this CPU: "avx2+f16c+fma" or "portable".
MLSPACES_API std::string_view ClipKernelName();

}  // namespace mlspaces
