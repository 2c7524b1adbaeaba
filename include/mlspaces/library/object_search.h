// Object search over the asset libraries (spec 8.5, `mlspaces search`, Python ObjectRetriever):
// CLIP search over the objathor feature store and the user/packed libraries' annotations, and a
// plain token search over category, synset and descriptions.
//
// Lifetimes: an ObjectSearch keeps a reference to the Registry it was built from (the Registry
// must outlive it) and shares the feature stores it opened. Searches are const and may run
// from several threads.
#pragma once

#include "mlspaces/core/export.h"

#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/library/clip_store.h"
#include "mlspaces/library/license_policy.h"

namespace mlspaces {

class Registry;

/// One search result (owns its UID).
struct MLSPACES_API ObjectSearchHit {
  std::string uid;
  double score = 0;
};

/// Where the converted objathor store keeps its CLIP features:
/// <assets>/objects/objathor_metadata/.mlspaces/index/clip_features.mlsc.
MLSPACES_API std::filesystem::path ObjathorClipStorePath(const std::filesystem::path& assets_dir);

class MLSPACES_API ObjectSearch {
 public:
  /// Gathers the features the original's ObjectRetriever uses, in its union order: the
  /// objathor store (when `clip_store` exists; default ObjathorClipStorePath(assets_dir) when
  /// `assets_dir` is given), then every other asset whose annotation carries
  /// `clip_img_features` (views x dim) and `clip_text_features` (dim) — user and packed
  /// libraries. An asset without them is skipped and counted (the original raises KeyError).
  /// @throws Error for a damaged store or malformed feature arrays (naming the UID).
  ObjectSearch(const Registry& registry, const std::optional<std::filesystem::path>& assets_dir,
               const std::optional<std::filesystem::path>& clip_store = {});
  ~ObjectSearch();

  size_t size() const;                      ///< assets with CLIP features
  size_t skipped_without_features() const;  ///< annotated assets left out (no CLIP arrays)
  size_t dim() const;                       ///< feature length (0 when there are no features)
  /// The stores searched, objathor first (the second, when present, is built in memory).
  std::vector<std::shared_ptr<const ClipStore>> stores() const;

  /// CLIP search with the original's score. Assets the licence policy excludes are removed
  /// after the top-k, as the original does (so fewer than top_k may come back).
  /// @throws Error when there are no features or for a bad query.
  std::vector<ObjectSearchHit> Query(std::span<const float> embedding,
                                     const ClipSearchOptions& options,
                                     LicensePolicy policy = LicensePolicy::kAll) const;
  /// "More like this": the query vector for a UID = its stored text feature (the original's
  /// queries are text embeddings, so a UID stands in for its own description).
  /// @throws Error naming the UID when it has no CLIP features.
  std::vector<float> UidEmbedding(std::string_view uid) const;

  /// Token search over category, synset, description, description_long and the values of
  /// description_short (recursively) of every annotated asset; see docs/search.md for the rule.
  /// Case-insensitive; tokens are maximal runs of letters and digits.
  std::vector<ObjectSearchHit> TextSearch(std::string_view words, size_t top_k,
                                          LicensePolicy policy = LicensePolicy::kAll) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The tokens TextSearch finds in `text`: lower-cased maximal runs of ASCII letters and digits
/// (bytes >= 0x80 stay inside tokens, so UTF-8 words are kept whole).
MLSPACES_API std::vector<std::string> SearchTokens(std::string_view text);

}  // namespace mlspaces
