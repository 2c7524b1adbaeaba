// CLIP feature stores and object search (mlspaces.utils.object_retriever; C++
// include/mlspaces/library/clip_store.h, object_search.h). Only translates: arrays come in as
// contiguous float32 (the Python side converts and checks shapes).
#include <nanobind/ndarray.h>
#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/shared_ptr.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/string_view.h>
#include <nanobind/stl/vector.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bindings.h"
#include "convert.h"
#include "mlspaces/library/clip_store.h"
#include "mlspaces/library/license_policy.h"
#include "mlspaces/library/object_search.h"
#include "mlspaces/library/registry.h"

namespace mlspaces::python {
namespace {

using Floats = nb::ndarray<const float, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

std::span<const float> Span(const Floats& a) { return {a.data(), a.shape(0)}; }

ClipSearchOptions Options(size_t top_k, float threshold, bool approximate, int threads) {
  ClipSearchOptions o;
  o.top_k = top_k;
  o.threshold = threshold;
  o.approximate = approximate;
  o.threads = threads;
  return o;
}

LicensePolicy Policy(const std::optional<std::string>& policy) {
  return ResolveLicensePolicy(policy ? std::optional(ParseLicensePolicy(*policy, "license_policy"))
                                     : std::nullopt);
}

// (list of UIDs, float32 scores) as the original's query returns (uids, sims).
nb::tuple Hits(const std::vector<ObjectSearchHit>& hits) {
  nb::list uids;
  std::vector<float> scores;
  for (const ObjectSearchHit& h : hits) {
    uids.append(nb::str(h.uid.data(), h.uid.size()));
    scores.push_back(static_cast<float>(h.score));
  }
  const std::vector<size_t> shape{scores.size()};
  return nb::make_tuple(uids, OwnedNumpy<float>(std::move(scores), shape));
}

// Keeps the Registry alive while an ObjectSearch refers to it.
struct PySearch {
  nb::object registry_owner;
  std::unique_ptr<ObjectSearch> search;
};

}  // namespace

void BindSearch(nb::module_& m) {
  nb::class_<ClipStoreWriter>(m, "ClipStoreWriter", "Writes a clip_features.mlsc store.")
      .def(nb::init<std::filesystem::path, size_t, size_t>(), nb::arg("file"), nb::arg("views") = 3,
           nb::arg("dim") = 768)
      .def(
          "add",
          [](ClipStoreWriter& w, std::string_view uid, const Floats& img, const Floats& text) {
            w.Add(uid, Span(img), Span(text));
          },
          nb::arg("uid"), nb::arg("img"), nb::arg("text"))
      .def("finish", &ClipStoreWriter::Finish)
      .def("__len__", &ClipStoreWriter::size);

  nb::class_<ClipStore>(m, "ClipStore", "An opened clip_features.mlsc store.")
      .def_static("open", &ClipStore::Open, nb::arg("file"))
      .def("__len__", &ClipStore::size)
      .def_prop_ro("views", &ClipStore::views)
      .def_prop_ro("dim", &ClipStore::dim)
      .def_prop_ro("has_approximate", &ClipStore::has_approximate)
      .def("uid", [](const ClipStore& s, size_t row) { return std::string(s.uid(row)); })
      .def("find", &ClipStore::Find, nb::arg("uid"))
      .def("image_features",
           [](const ClipStore& s, size_t row) {
             return OwnedNumpy<float>(s.ImageFeatures(row), {s.views(), s.dim()});
           })
      .def("text_feature",
           [](const ClipStore& s, size_t row) {
             return OwnedNumpy<float>(s.TextFeature(row), {s.dim()});
           })
      .def("check", &ClipStore::Check)
      .def(
          "search",
          [](const ClipStore& s, const Floats& q, size_t top_k, float threshold, bool approximate,
             int threads) {
            std::vector<ObjectSearchHit> hits;
            {
              nb::gil_scoped_release release;
              for (const ClipHit& h :
                   s.Search(Span(q), Options(top_k, threshold, approximate, threads))) {
                hits.push_back({std::string(h.uid), h.score});
              }
            }
            return Hits(hits);
          },
          nb::arg("query"), nb::arg("top_k") = 50, nb::arg("threshold") = 0.5f,
          nb::arg("approximate") = false, nb::arg("threads") = 1);
  m.def("clip_kernel_name", [] { return std::string(ClipKernelName()); });

  nb::class_<PySearch>(m, "ObjectSearch", "CLIP and word search over a Registry's libraries.")
      .def(
          "__init__",
          [](PySearch* self, const nb::object& registry,
             const std::optional<std::filesystem::path>& assets_dir,
             const std::optional<std::filesystem::path>& clip_store) {
            const Registry& r = nb::cast<const Registry&>(registry);
            new (self)
                PySearch{registry, std::make_unique<ObjectSearch>(r, assets_dir, clip_store)};
          },
          nb::arg("registry"), nb::arg("assets_dir") = nb::none(),
          nb::arg("clip_store") = nb::none())
      .def("__len__", [](const PySearch& s) { return s.search->size(); })
      .def_prop_ro("dim", [](const PySearch& s) { return s.search->dim(); })
      .def_prop_ro("skipped_without_features",
                   [](const PySearch& s) { return s.search->skipped_without_features(); })
      .def(
          "query",
          [](const PySearch& s, const Floats& q, size_t top_k, float threshold, bool approximate,
             int threads, const std::optional<std::string>& policy) {
            const LicensePolicy p = Policy(policy);
            return Hits(
                s.search->Query(Span(q), Options(top_k, threshold, approximate, threads), p));
          },
          nb::arg("query"), nb::arg("top_k") = 50, nb::arg("threshold") = 0.5f,
          nb::arg("approximate") = false, nb::arg("threads") = 1,
          nb::arg("license_policy") = nb::none())
      .def(
          "uid_embedding",
          [](const PySearch& s, std::string_view uid) {
            std::vector<float> v = s.search->UidEmbedding(uid);
            const std::vector<size_t> shape{v.size()};
            return OwnedNumpy<float>(std::move(v), shape);
          },
          nb::arg("uid"))
      .def(
          "text_search",
          [](const PySearch& s, std::string_view words, size_t top_k,
             const std::optional<std::string>& policy) {
            return Hits(s.search->TextSearch(words, top_k, Policy(policy)));
          },
          nb::arg("words"), nb::arg("top_k") = 50, nb::arg("license_policy") = nb::none());
}

}  // namespace mlspaces::python
