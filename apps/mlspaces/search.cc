// mlspaces search: CLIP search (a UID or an embedding as the query) and token search over the
// annotations (docs/search.md).
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/npy.h"
#include "mlspaces/library/license_policy.h"
#include "mlspaces/library/object_search.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/resources/sources.h"

namespace mlspaces::cli {
namespace {

struct SearchFlags {
  std::string uid, embedding, text, license_policy, clip_store;
  size_t top_k = 50;
  float threshold = 0.5f;
  bool approx = false, json = false;
  int threads = 1;
  LibraryFlags libraries;
};

// A .npy holding one embedding: any float dtype, shape (D,) or (1, D).
std::vector<float> ReadEmbedding(const std::string& path) {
  const NpyArray array = ReadNpyFile(path);
  if (array.dtype != DType::kF2 && array.dtype != DType::kF4 && array.dtype != DType::kF8) {
    throw Error("embedding must be a float array (float16, float32 or float64), got " +
                    DTypeDescr(array.dtype),
                path);
  }
  const bool ok = array.shape.size() == 1 || (array.shape.size() == 2 && array.shape[0] == 1);
  if (!ok) {
    throw Error("embedding must have shape (D,) or (1, D), got " + ShapeRepr(array.shape), path);
  }
  std::vector<float> out;
  for (double x : array.ToDoubles()) out.push_back(static_cast<float>(x));
  return out;
}

int Run(const SearchFlags& flags) {
  const int kinds = !flags.uid.empty() + !flags.embedding.empty() + !flags.text.empty();
  if (kinds != 1) throw UsageError("give exactly one of --uid, --embedding, --text");
  std::optional<LicensePolicy> given;
  if (!flags.license_policy.empty()) {
    given = ParseLicensePolicy(flags.license_policy, "--license-policy");
  }
  const LicensePolicy policy = ResolveLicensePolicy(given);
  const Registry registry = flags.libraries.Build();
  // The same assets dir the registry uses (a --libraries YAML's assets_dir first).
  std::optional<std::filesystem::path> assets_dir = flags.libraries.AssetsDir();
  std::optional<std::filesystem::path> store;
  if (!flags.clip_store.empty()) store = flags.clip_store;
  const ObjectSearch search(registry, assets_dir, store);
  if (search.skipped_without_features() > 0 && flags.text.empty()) {
    Warn(std::to_string(search.skipped_without_features()) +
         " annotated assets have no clip_img_features/clip_text_features and are not searched");
  }

  std::vector<ObjectSearchHit> hits;
  if (!flags.text.empty()) {
    hits = search.TextSearch(flags.text, flags.top_k, policy);
  } else {
    const std::vector<float> query =
        flags.uid.empty() ? ReadEmbedding(flags.embedding) : search.UidEmbedding(flags.uid);
    ClipSearchOptions options;
    options.top_k = flags.top_k;
    options.threshold = flags.threshold;
    options.approximate = flags.approx;
    options.threads = flags.threads;
    hits = search.Query(query, options, policy);
  }
  if (flags.json) {
    Json out = Json::array();
    for (const ObjectSearchHit& h : hits) out.push_back({{"uid", h.uid}, {"score", h.score}});
    std::printf("%s\n", out.dump().c_str());
    return 0;
  }
  std::printf("%-5s %-9s %s\n", "rank", "score", "uid");
  for (size_t i = 0; i < hits.size(); ++i) {
    std::printf("%-5zu %-9.4f %s\n", i + 1, hits[i].score, hits[i].uid.c_str());
  }
  if (hits.empty()) std::printf("(no results)\n");
  return 0;
}

}  // namespace

void AddSearch(CLI::App& app, Action& action) {
  auto flags = std::make_shared<SearchFlags>();
  CLI::App* sub = app.add_subcommand(
      "search",
      "Find objects: CLIP search (score = best image view + 0.5 x text, as the original's "
      "ObjectRetriever) or word search over category, synset and descriptions.\n"
      "No text-to-CLIP model is available here: a CLIP query is a UID (more like this: its "
      "stored text feature) or an embedding made elsewhere (open_clip ViT-L-14 "
      "laion2b_s32b_b82k, 768 floats, saved with numpy.save).");
  auto* uid = sub->add_option("--uid", flags->uid, "Query: the CLIP text feature of this UID");
  auto* emb = sub->add_option("--embedding", flags->embedding,
                              "Query: a .npy of 768 floats (any float dtype), shape (768,) or "
                              "(1, 768), made by a CLIP text or image encoder elsewhere");
  auto* text = sub->add_option("--text", flags->text,
                               "Word search (not CLIP): tokens matched in category/synset "
                               "(2 points) or descriptions (1 point)");
  uid->excludes(emb)->excludes(text);
  emb->excludes(text);
  sub->add_option("--top-k", flags->top_k, "At most this many results (max_results)")
      ->capture_default_str()
      ->check(PositiveInteger());
  sub->add_option("--threshold", flags->threshold, "CLIP searches keep scores >= this (sim_thres)")
      ->capture_default_str()
      ->check(FiniteNumber());
  sub->add_flag("--approx", flags->approx,
                "Approximate CLIP search: int8 first pass, exact re-rank of the best candidates");
  sub->add_option("--threads", flags->threads, "Threads for the exact scan (<= 0: all cores)")
      ->capture_default_str();
  sub->add_option("--license-policy", flags->license_policy,
                  "all or commercial_safe (default: MLSPACES_LICENSE_POLICY, else all)");
  sub->add_option("--clip-store", flags->clip_store,
                  "CLIP feature store to search (default: <assets>/objects/objathor_metadata/"
                  ".mlspaces/index/clip_features.mlsc)");
  sub->add_flag("--json", flags->json, "Print [{\"uid\": ..., \"score\": ...}, ...] best first");
  flags->libraries.AddTo(*sub);
  sub->callback([&action, flags] { action = [flags] { return Run(*flags); }; });
}

}  // namespace mlspaces::cli
