// Object search over the asset libraries (include/mlspaces/library/object_search.h).
#include "mlspaces/library/object_search.h"

#include <algorithm>
#include <cctype>
#include <unordered_set>

#include "mlspaces/core/error.h"
#include "mlspaces/library/annotation.h"
#include "mlspaces/library/registry.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

// Adds the tokens of every string under `value` (objects and lists walked) to `out`.
void CollectTokens(const Json& value, std::unordered_set<std::string>& out) {
  if (value.is_string()) {
    for (std::string& t : SearchTokens(value.get_ref<const std::string&>()))
      out.insert(std::move(t));
  } else if (value.is_object() || value.is_array()) {
    for (const Json& item : value) CollectTokens(item, out);
  }
}

}  // namespace

fs::path ObjathorClipStorePath(const fs::path& assets_dir) {
  return assets_dir / "objects" / "objathor_metadata" / ".mlspaces" / "index" /
         std::string(kClipStoreFileName);
}

std::vector<std::string> SearchTokens(std::string_view text) {
  std::vector<std::string> tokens;
  std::string cur;
  for (char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) != 0 || u >= 0x80) {  // bytes of non-ASCII letters stay in the token
      cur += static_cast<char>(std::tolower(u));
    } else if (!cur.empty()) {
      tokens.push_back(std::move(cur));
      cur.clear();
    }
  }
  if (!cur.empty()) tokens.push_back(std::move(cur));
  return tokens;
}

struct ObjectSearch::Impl {
  const Registry* registry = nullptr;
  std::shared_ptr<const ClipStore> objathor, others;
  size_t skipped = 0;
  std::vector<std::string> other_uids;  // annotated assets outside the objathor store

  std::shared_ptr<const mlspaces::Annotation> Find(std::string_view uid) const {
    return registry->GetAnnotation(uid);
  }
  bool Allowed(LicensePolicy policy, std::string_view uid) const {
    return policy == LicensePolicy::kAll ||
           AllowedByLicensePolicy(policy, registry->GetAnnotation(uid).get());
  }
};

ObjectSearch::ObjectSearch(const Registry& registry, const std::optional<fs::path>& assets_dir,
                           const std::optional<fs::path>& clip_store)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.registry = &registry;
  std::optional<fs::path> store = clip_store;
  if (!store && assets_dir) store = ObjathorClipStorePath(*assets_dir);
  std::error_code ec;
  if (store && fs::exists(*store, ec)) s.objathor = ClipStore::Open(*store);

  // Every other asset of the union: packed libraries (objathor's own rows excluded), then
  // user libraries, each UID once.
  std::vector<std::string> uids;
  std::unordered_set<std::string> seen;
  auto consider = [&](std::string_view uid) {
    if (s.objathor && s.objathor->Find(uid)) return;
    if (seen.emplace(uid).second) uids.emplace_back(uid);
  };
  for (const std::string& name : registry.asset_libraries()) {
    if (auto packed = registry.FindPackedLibrary(name)) {
      for (size_t i = 0; i < packed->size(); ++i) consider(packed->At(i).uid);
    }
  }
  for (const std::string& uid : registry.user_uids()) consider(uid);

  const size_t views = s.objathor ? s.objathor->views() : 3;
  size_t dim = s.objathor ? s.objathor->dim() : 0;
  std::vector<std::string> with;
  std::vector<float> img, text;
  for (const std::string& uid : uids) {
    std::shared_ptr<const mlspaces::Annotation> a = registry.GetAnnotation(uid);
    if (a == nullptr) continue;
    s.other_uids.push_back(uid);
    const NpyArray* im = a->FindArray("/clip_img_features");
    const NpyArray* tx = a->FindArray("/clip_text_features");
    if (im == nullptr || tx == nullptr) {
      ++s.skipped;
      continue;
    }
    if (im->shape.size() != 2 || im->shape[0] != views || tx->shape.size() != 1 ||
        tx->shape[0] != im->shape[1] || (dim != 0 && tx->shape[0] != dim)) {
      throw Error("clip_img_features must be (" + std::to_string(views) +
                      ", D) and clip_text_features (D,)" +
                      (dim != 0 ? " with D = " + std::to_string(dim) : std::string()),
                  a->library, "/clip_img_features", uid);
    }
    dim = tx->shape[0];
    for (double x : im->ToDoubles()) img.push_back(static_cast<float>(x));
    for (double x : tx->ToDoubles()) text.push_back(static_cast<float>(x));
    with.push_back(uid);
  }
  if (!with.empty()) {
    s.others = ClipStore::FromVectors(std::move(with), views, dim, img, text, "annotations");
  }
}

ObjectSearch::~ObjectSearch() = default;

size_t ObjectSearch::size() const {
  return (impl_->objathor ? impl_->objathor->size() : 0) +
         (impl_->others ? impl_->others->size() : 0);
}
size_t ObjectSearch::skipped_without_features() const { return impl_->skipped; }
size_t ObjectSearch::dim() const {
  if (impl_->objathor) return impl_->objathor->dim();
  return impl_->others ? impl_->others->dim() : 0;
}

std::vector<std::shared_ptr<const ClipStore>> ObjectSearch::stores() const {
  std::vector<std::shared_ptr<const ClipStore>> out;
  if (impl_->objathor) out.push_back(impl_->objathor);
  if (impl_->others) out.push_back(impl_->others);
  return out;
}

std::vector<ObjectSearchHit> ObjectSearch::Query(std::span<const float> embedding,
                                                 const ClipSearchOptions& options,
                                                 LicensePolicy policy) const {
  const std::vector<std::shared_ptr<const ClipStore>> all = stores();
  if (all.empty()) {
    throw Error(
        "no CLIP features: neither the objathor store (objects/objathor_metadata, see "
        "docs/search.md) nor any annotation with clip_img_features/clip_text_features");
  }
  std::vector<ObjectSearchHit> hits;
  for (const auto& store : all) {
    for (const ClipHit& h : store->Search(embedding, options)) {
      hits.push_back({std::string(h.uid), h.score});
    }
  }
  std::sort(hits.begin(), hits.end(), [](const ObjectSearchHit& a, const ObjectSearchHit& b) {
    return a.score != b.score ? a.score > b.score : a.uid < b.uid;
  });
  if (hits.size() > options.top_k) hits.resize(options.top_k);
  // The original filters after the top-k.
  std::erase_if(hits, [&](const ObjectSearchHit& h) { return !impl_->Allowed(policy, h.uid); });
  return hits;
}

std::vector<float> ObjectSearch::UidEmbedding(std::string_view uid) const {
  for (const auto& store : stores()) {
    if (auto row = store->Find(uid)) return store->TextFeature(*row);
  }
  throw Error(std::string(uid) +
                  ": no CLIP features (not in the objathor store, and no annotation with "
                  "clip_img_features and clip_text_features)",
              "", "", std::string(uid));
}

std::vector<ObjectSearchHit> ObjectSearch::TextSearch(std::string_view words, size_t top_k,
                                                      LicensePolicy policy) const {
  std::vector<std::string> query = SearchTokens(words);
  std::sort(query.begin(), query.end());
  query.erase(std::unique(query.begin(), query.end()), query.end());
  if (query.empty()) throw UsageError("--text needs at least one word (letters or digits)");
  const Impl& s = *impl_;
  std::vector<ObjectSearchHit> hits;
  auto score_uid = [&](std::string_view uid) {
    std::shared_ptr<const mlspaces::Annotation> a = s.Find(uid);
    if (a == nullptr || !a->json.is_object()) return;
    std::unordered_set<std::string> names, descriptions;
    for (const char* key : {"category", "synset"}) {
      if (auto it = a->json.find(key); it != a->json.end()) CollectTokens(*it, names);
    }
    for (const char* key : {"description", "description_long", "description_short"}) {
      if (auto it = a->json.find(key); it != a->json.end()) CollectTokens(*it, descriptions);
    }
    double points = 0;
    for (const std::string& t : query) {
      if (names.count(t) != 0) {
        points += 2;
      } else if (descriptions.count(t) != 0) {
        points += 1;
      }
    }
    if (points > 0 && s.Allowed(policy, uid)) {
      hits.push_back({std::string(uid), points / (2.0 * static_cast<double>(query.size()))});
    }
  };
  if (s.objathor) {
    for (size_t r = 0; r < s.objathor->size(); ++r) score_uid(s.objathor->uid(r));
  }
  for (const std::string& uid : s.other_uids) score_uid(uid);
  std::sort(hits.begin(), hits.end(), [](const ObjectSearchHit& a, const ObjectSearchHit& b) {
    return a.score != b.score ? a.score > b.score : a.uid < b.uid;
  });
  if (hits.size() > top_k) hits.resize(top_k);
  return hits;
}

}  // namespace mlspaces
