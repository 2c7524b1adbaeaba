// The library layer: Registry (libraries, UID lookup, annotations, grasps) and scene metadata.
// mlspaces/_registry.py wraps it with MolmoSpaces' names, argument forms and caching.
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/string_view.h>
#include <nanobind/stl/vector.h>

#include "bindings.h"
#include "convert.h"
#include "mlspaces/core/error.h"
#include "mlspaces/library/grasp_set.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/library/scene_metadata.h"
#include "mlspaces/resources/objathor.h"

namespace mlspaces::python {

namespace {

GraspQuery Query(std::string uid, std::string joint, std::optional<std::vector<std::string>> libs) {
  GraspQuery q;
  q.uid = std::move(uid);
  q.joint = std::move(joint);
  // MolmoSpaces keeps the object's grasp libraries that the list names, so [] keeps none; the
  // engine's empty filter means all, so [] becomes a name that no library has.
  if (libs) q.libraries = libs->empty() ? std::vector<std::string>{""} : std::move(*libs);
  return q;
}

/// random.sample(range(n), k) as CPython 3.10-3.14 computes it (Lib/random.py: the pool
/// branch for small populations, the set branch otherwise; _randbelow_with_getrandbits),
/// drawing from `getrandbits` (random.getrandbits of the user's `random`), so the rows and the
/// generator's state afterwards are the same as Python's. The Python side checks the version.
std::vector<size_t> PythonRandomSample(size_t n, size_t k, const nb::object& getrandbits) {
  if (k > n) throw Error("sample larger than population or is negative");
  if (n > (size_t{1} << 32)) throw Error("more than 2^32 grasps in one file");
  // Random words in batches: getrandbits(32 * m) is m successive 32-bit outputs of the
  // generator, the first in the lowest bits, and getrandbits(b <= 32) is one output shifted
  // right by 32 - b; so a batch gives exactly the draws of m calls. A batch asks for as many
  // words as picks are still missing (each needs at least one draw), so it never takes more
  // from the generator than random.sample would.
  std::vector<uint32_t> words;
  size_t next = 0;
  auto refill = [&](size_t m) {
    static nb::handle little = nb::str("little").release();
    nb::object value = getrandbits(nb::int_(32 * m));
    nb::object bytes = value.attr("to_bytes")(4 * m, little);
    const char* data = PyBytes_AsString(bytes.ptr());
    if (data == nullptr) throw nb::python_error();
    words.resize(m);
    std::memcpy(words.data(), data, 4 * m);
    next = 0;
  };
  size_t picked = 0;
  auto randbelow = [&](size_t m) -> size_t {
    const int bits = std::bit_width(m);
    while (true) {
      if (next == words.size()) refill(k - picked);
      const size_t r = words[next++] >> (32 - bits);
      if (r < m) return r;
    }
  };
  std::vector<size_t> out(k);
  size_t setsize = 21;
  if (k > 5) {
    setsize += static_cast<size_t>(
        std::pow(4.0, std::ceil(std::log(static_cast<double>(k * 3)) / std::log(4.0))));
  }
  if (n <= setsize) {
    std::vector<size_t> pool(n);
    for (size_t i = 0; i < n; ++i) pool[i] = i;
    for (; picked < k; ++picked) {
      const size_t j = randbelow(n - picked);
      out[picked] = pool[j];
      pool[j] = pool[n - picked - 1];
    }
  } else {
    // CPython keeps the picks in a set; membership is all that matters, so a bitmap does
    // for populations up to 2^24 (a grasp file), a hash set beyond.
    std::vector<bool> bitmap(n <= (size_t{1} << 24) ? n : 0);
    std::unordered_set<size_t> selected;
    auto taken = [&](size_t j) { return bitmap.empty() ? selected.count(j) != 0 : bitmap[j]; };
    for (; picked < k; ++picked) {
      size_t j = randbelow(n);
      while (taken(j)) j = randbelow(n);
      if (bitmap.empty()) {
        selected.insert(j);
      } else {
        bitmap[j] = true;
      }
      out[picked] = j;
    }
  }
  return out;
}

/// Takes the dicts and lists of a tree out of the cyclic GC: a cached annotation template is
/// never handed out (callers get CopyTree's copies) and holds no cycles, and with thousands of
/// templates cached, Python's collections spent more time walking them than decoding.
void UntrackTree(PyObject* node) {
  if (PyDict_CheckExact(node)) {
    PyObject *key = nullptr, *value = nullptr;
    Py_ssize_t pos = 0;
    while (PyDict_Next(node, &pos, &key, &value)) UntrackTree(value);
  } else if (PyList_CheckExact(node)) {
    for (Py_ssize_t i = 0; i < PyList_GET_SIZE(node); ++i) UntrackTree(PyList_GET_ITEM(node, i));
  } else {
    return;
  }
  if (PyObject_GC_IsTracked(node)) PyObject_GC_UnTrack(node);
}

/// A new tree of dicts and lists over the same leaves (str, numbers, arrays): what
/// Registry.annotation returns from its cached template, so every call gets its own dicts.
PyObject* CopyTree(PyObject* node) {
  if (PyDict_CheckExact(node)) {
    // PyDict_Copy clones the table in one go; then only the nested containers are replaced.
    PyObject* out = PyDict_Copy(node);
    if (out == nullptr) return nullptr;
    PyObject *key = nullptr, *value = nullptr;
    Py_ssize_t pos = 0;
    while (PyDict_Next(node, &pos, &key, &value)) {
      if (!PyDict_CheckExact(value) && !PyList_CheckExact(value)) continue;
      PyObject* copy = CopyTree(value);
      if (copy == nullptr || PyDict_SetItem(out, key, copy) != 0) {
        Py_XDECREF(copy);
        Py_DECREF(out);
        return nullptr;
      }
      Py_DECREF(copy);
    }
    return out;
  }
  if (PyList_CheckExact(node)) {
    const Py_ssize_t n = PyList_GET_SIZE(node);
    PyObject* out = PyList_New(n);
    if (out == nullptr) return nullptr;
    for (Py_ssize_t i = 0; i < n; ++i) {
      PyObject* item = PyList_GET_ITEM(node, i);
      PyObject* copy = nullptr;
      if (PyDict_CheckExact(item) || PyList_CheckExact(item)) {
        copy = CopyTree(item);
        if (copy == nullptr) {
          Py_DECREF(out);
          return nullptr;
        }
      } else {
        Py_INCREF(item);
        copy = item;
      }
      PyList_SET_ITEM(out, i, copy);
    }
    return out;
  }
  Py_INCREF(node);
  return node;
}

}  // namespace

void BindLibrary(nb::module_& m) {
  nb::class_<Registry>(
      m, "Registry", "Asset and grasp libraries and every lookup by UID (C++ mlspaces::Registry).")
      .def(
          "__init__",
          [](Registry* self, std::optional<std::filesystem::path> assets_dir) {
            Registry::Options options;
            options.assets_dir = std::move(assets_dir);
            new (self) Registry(std::move(options));
          },
          nb::arg("assets_dir") = nb::none())
      // Registration.
      .def("register_asset_library", &Registry::RegisterAssetLibrary, nb::arg("name"),
           nb::arg("path"))
      .def("register_grasp_library", &Registry::RegisterGraspLibrary, nb::arg("root_name"),
           nb::arg("path"), nb::arg("object_library"))
      .def("register_packed_library", &Registry::RegisterPackedLibrary, nb::arg("name"),
           nb::arg("path"))
      // Libraries.
      .def("asset_libraries", &Registry::asset_libraries)
      .def("grasp_libraries_of", &Registry::grasp_libraries_of, nb::arg("asset_library"))
      .def(
          "grasp_library_dir",
          [](const Registry& r, const std::string& name) -> std::optional<std::filesystem::path> {
            const GraspLibraryInfo* info = r.FindGraspLibrary(name);
            if (info == nullptr) return std::nullopt;
            return info->dir;
          },
          nb::arg("name"))
      .def("num_uids", &Registry::num_uids)
      .def("user_uids", &Registry::user_uids)
      .def("annotated_uids", &Registry::annotated_uids)
      // The objathor store: converted on first use (resources/objathor.h), then opened.
      .def(
          "ensure_objathor",
          [](Registry& r, const std::filesystem::path& assets_dir) {
            // Always checked (a few stats): the Registry may have opened a stale store, which
            // EnsureObjathorStore converts again (its marker, resources/objathor.h).
            std::optional<ObjathorReport> report;
            {
              nb::gil_scoped_release release;  // a conversion takes a while
              report = EnsureObjathorStore(assets_dir);
            }
            if (!report) return r.objathor_store() != nullptr;
            if (report->converted || !r.objathor_store()) {
              r.RegisterObjathorStore(report->index_dir);
            }
            return true;
          },
          nb::arg("assets_dir"))
      .def("duplicates",
           [](const Registry& r) {
             nb::list out;
             for (const DuplicateUid& d : r.duplicates()) {
               out.append(nb::make_tuple(d.uid, d.libraries));
             }
             return out;
           })
      // Assets: (library, package or None, mjcf path, installed) or None.
      .def(
          "locate",
          [](const Registry& r, std::string_view uid) -> nb::object {
            std::optional<AssetLocation> loc = r.Locate(uid);
            if (!loc) return nb::none();
            nb::object package = loc->archive.empty() ? nb::none() : nb::str(loc->archive.c_str());
            return nb::make_tuple(nb::str(loc->library.c_str()), package, ToPathlib(loc->mjcf_path),
                                  nb::bool_(loc->installed));
          },
          nb::arg("uid"))
      // Annotations: a new dict each call, or None.
      // template=True: a tree to cache and hand out only through copy_tree (untracked by
      // the cyclic GC; see UntrackTree).
      .def(
          "annotation",
          [](const Registry& r, std::string_view uid, bool as_template) -> nb::object {
            std::shared_ptr<const Annotation> a = r.GetAnnotation(uid);
            if (!a) return nb::none();
            nb::object out = AnnotationToPython(std::move(a));  // arrays: read-only views
            if (as_template) UntrackTree(out.ptr());
            return out;
          },
          nb::arg("uid"), nb::arg("template") = false)
      // Grasps.
      .def(
          "grasp_libraries_for",
          [](const Registry& r, std::string_view uid,
             std::optional<std::vector<std::string>> libs) {
            return libs ? r.GraspLibrariesFor(uid, *libs) : r.GraspLibrariesFor(uid);
          },
          nb::arg("uid"), nb::arg("libraries") = nb::none())
      .def(
          "grasp_path",
          [](const Registry& r, std::string uid, std::string joint,
             std::optional<std::vector<std::string>> libs) {
            return r.GraspPath(Query(std::move(uid), std::move(joint), std::move(libs)));
          },
          nb::arg("uid"), nb::arg("joint") = "", nb::arg("libraries") = nb::none())
      .def(
          "has_valid_grasps",
          [](const Registry& r, std::string uid, std::string joint, int64_t num_grasps,
             std::optional<std::vector<std::string>> libs) {
            return r.HasValidGrasps(Query(std::move(uid), std::move(joint), std::move(libs)),
                                    num_grasps < 0 ? 0 : static_cast<size_t>(num_grasps));
          },
          nb::arg("uid"), nb::arg("joint") = "", nb::arg("num_grasps") = 1,
          nb::arg("libraries") = nb::none())
      // load_grasps(uid, joint, libraries, num_grasps, getrandbits): when the file holds
      // more than num_grasps rows, they are drawn as CPython's random.sample(range(n), k) draws
      // them, from `getrandbits` (random.getrandbits: the same Mersenne Twister stream, so the
      // same rows as MolmoSpaces for the same seed); a fresh float64 (N,4,4) array.
      .def(
          "load_grasps",
          [](const Registry& r, std::string uid, std::string joint,
             std::optional<std::vector<std::string>> libs, int64_t num_grasps,
             nb::object getrandbits) {
            const GraspQuery q = Query(std::move(uid), std::move(joint), std::move(libs));
            const size_t k = num_grasps < 0 ? 0 : static_cast<size_t>(num_grasps);
            GraspSet set = r.LoadGrasps(q, [&](size_t n) -> std::optional<std::vector<size_t>> {
              if (n <= k) return std::nullopt;
              return PythonRandomSample(n, k, getrandbits);
            });
            return PosesToNumpy(std::move(set.poses));
          },
          nb::arg("uid"), nb::arg("joint"), nb::arg("libraries").none(), nb::arg("num_grasps"),
          nb::arg("getrandbits"))
      .def_static(
          "_random_sample",
          [](size_t n, size_t k, const nb::object& getrandbits) {
            return PythonRandomSample(n, k, getrandbits);
          },
          nb::arg("n"), nb::arg("k"), nb::arg("getrandbits"))
      .def(
          "count_grasps",
          [](const Registry& r, std::string uid, std::string joint,
             std::optional<std::vector<std::string>> libs) -> std::optional<size_t> {
            std::optional<GraspFileLocation> loc =
                r.FindGraspFile(Query(std::move(uid), std::move(joint), std::move(libs)));
            if (!loc) return std::nullopt;
            if (loc->packed) return loc->packed->count;
            return CountGraspFileRows(loc->path);
          },
          nb::arg("uid"), nb::arg("joint") = "", nb::arg("libraries") = nb::none());

  m.def(
      "copy_tree",
      [](nb::handle tree) {
        PyObject* out = CopyTree(tree.ptr());
        if (out == nullptr) throw nb::python_error();
        return nb::steal(out);
      },
      nb::arg("tree"));

  // Scene metadata.
  m.def(
      "find_scene_metadata_file",
      [](const std::filesystem::path& xml) { return FindSceneMetadataFile(xml); }, nb::arg("xml"));
  m.def(
      "load_scene_metadata",
      [](const std::filesystem::path& xml) -> nb::object {
        std::optional<Json> meta = LoadSceneMetadata(xml);
        if (!meta) return nb::none();
        return JsonToPython(*meta);
      },
      nb::arg("xml"));
  // World-frame grasps: body_pose @ G_i, then (include_flipped) each @ Rz(180 deg).
  m.def(
      "grasps_in_world",
      [](nb::handle body_pose, nb::handle grasps, bool include_flipped) {
        const Mat4 pose = Mat4FromPython(body_pose, "body pose");
        const std::vector<Mat4> g = PosesFromPython(grasps, "grasps");
        return PosesToNumpy(GraspsInWorld(pose, g, include_flipped));
      },
      nb::arg("body_pose"), nb::arg("grasps"), nb::arg("include_flipped") = true);
  m.def(
      "flip_grasps",
      [](nb::handle grasps) {
        std::vector<Mat4> g = PosesFromPython(grasps, "grasps");
        for (Mat4& p : g) {
          for (int r = 0; r < 3; ++r) {
            p(r, 0) = -p(r, 0);
            p(r, 1) = -p(r, 1);
          }
        }
        return PosesToNumpy(std::move(g));
      },
      nb::arg("grasps"));
}

}  // namespace mlspaces::python
