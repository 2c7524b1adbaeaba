// Asset annotations (spec 3.3, 3.4, 8.3): metadata JSON plus NPZ arrays at '/'-paths.
#include "mlspaces/library/annotation.h"

#include <fcntl.h>

#include <cerrno>
#include <cstring>
#include <optional>

#include "annotation_internal.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/npz.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

/// Splits an NPZ key on '/', keeping empty parts (as Python's str.split does).
std::vector<std::string> SplitKey(std::string_view key) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (;;) {
    size_t slash = key.find('/', start);
    parts.emplace_back(key.substr(start, slash - start));
    if (slash == std::string_view::npos) break;
    start = slash + 1;
  }
  return parts;
}

std::string PointerOf(const std::vector<std::string>& parts) {
  std::string out;
  for (const std::string& p : parts) out += "/" + JsonPointerToken(p);
  return out;
}

/// The unescaped reference tokens of a non-empty JSON pointer.
std::vector<std::string> PointerTokens(std::string_view pointer) {
  std::vector<std::string> tokens = SplitKey(pointer.substr(1));
  for (std::string& t : tokens) {
    std::string u;
    for (size_t i = 0; i < t.size(); ++i) {
      if (t[i] == '~' && i + 1 < t.size()) {
        u += t[i + 1] == '1' ? '/' : '~';
        ++i;
      } else {
        u += t[i];
      }
    }
    t = std::move(u);
  }
  return tokens;
}

/// The JSON form of an array: nested lists following the shape (a scalar for 0-d), values
/// as numpy's tolist() gives them (floats widened to double, ints, bools).
Json ArrayToJson(const NpyArray& array, size_t dim, size_t& flat) {
  if (dim == array.shape.size()) {
    const size_t i = flat++;
    switch (array.dtype) {
      case DType::kB1:
        return Json(array.data[i] != 0);
      case DType::kU1:
        return Json(static_cast<uint64_t>(array.data[i]));
      case DType::kI4: {
        int32_t v;
        std::memcpy(&v, array.data.data() + i * sizeof v, sizeof v);
        return Json(static_cast<int64_t>(v));
      }
      case DType::kI8: {  // exact (AsDouble may round)
        int64_t v;
        std::memcpy(&v, array.data.data() + i * sizeof v, sizeof v);
        return Json(v);
      }
      default:
        return Json(array.AsDouble(i));
    }
  }
  Json list = Json::array();
  for (size_t k = 0; k < array.shape[dim]; ++k) list.push_back(ArrayToJson(array, dim + 1, flat));
  return list;
}

}  // namespace

const NpyArray* Annotation::FindArray(std::string_view pointer) const {
  for (const auto& [p, array] : arrays) {
    if (p == pointer) return &array;
  }
  return nullptr;
}

Json Annotation::ToJson() const {
  Json out = json;
  for (const auto& [pointer, array] : arrays) {
    size_t flat = 0;
    Json value = ArrayToJson(array, 0, flat);
    // Walk by object keys (a json_pointer would turn digit tokens into array indices).
    Json* node = &out;
    const std::vector<std::string> parts = PointerTokens(pointer);
    for (size_t i = 0; i + 1 < parts.size(); ++i) {
      Json& child = (*node)[parts[i]];
      if (!child.is_object()) child = Json::object();
      node = &child;
    }
    (*node)[parts.back()] = std::move(value);
  }
  return out;
}

namespace {

Annotation LoadAnnotationImpl(std::string_view uid, const std::string& library, int dir_fd,
                              const char* json_path, const fs::path& json_full,
                              const fs::path* metadata_npz) {
  Annotation out;
  out.uid = uid;
  out.library = library;
  const std::string text = ReadFileAt(dir_fd, json_path, json_full);
  // The path is only needed in an error; building it costs an allocation per lookup.
  out.json = ParseJson(text, json_full.empty() ? std::string() : json_full.string());
  if (!out.json.is_object()) {
    throw Error("metadata must be a JSON object, got " + JsonTypeName(out.json), json_full.string(),
                "", std::string(uid));
  }
  if (metadata_npz == nullptr) return out;
  const std::string uid_str(uid);

  std::vector<std::pair<std::string, NpyArray>> arrays = ReadNpz(*metadata_npz);
  // Merge into a skeleton copy to find collisions with the JSON and between arrays: an
  // array's place holds null there, so a later key under it crosses a non-object.
  Json skeleton = out.json;
  for (auto& entry : arrays) {
    // Named, not a structured binding: clang 14 (the fuzz build) cannot capture those.
    const std::string& key = entry.first;
    NpyArray& array = entry.second;
    const std::vector<std::string> parts = SplitKey(key);
    auto collision = [&] {
      return Error(
          "Key " + key + " from npz metadata already exists in metadata for uid=" + uid_str,
          metadata_npz->string(), key, uid_str);
    };
    Json* node = &skeleton;
    for (size_t i = 0; i + 1 < parts.size(); ++i) {
      auto it = node->find(parts[i]);
      if (it == node->end()) {
        node = &(*node)[parts[i]];
        *node = Json::object();
      } else if (it->is_object()) {
        node = &*it;
      } else {
        throw collision();
      }
    }
    if (node->contains(parts.back())) throw collision();
    (*node)[parts.back()] = nullptr;
    out.arrays.emplace_back(PointerOf(parts), std::move(array));
  }
  return out;
}

}  // namespace

Annotation LoadAnnotation(const std::string& uid, const std::string& library,
                          const fs::path& metadata_json, const fs::path* metadata_npz) {
  return LoadAnnotationImpl(uid, library, AT_FDCWD, metadata_json.c_str(), metadata_json,
                            metadata_npz);
}

namespace internal {

Annotation LoadAnnotationAt(int dir_fd, const fs::path& dir, std::string_view uid,
                            const std::string& library, const std::string& metadata_rel,
                            const std::string* npz_rel) {
  std::optional<fs::path> npz;
  if (npz_rel != nullptr) npz = dir / *npz_rel;
  if (dir_fd < 0) {
    const fs::path full = dir / metadata_rel;
    return LoadAnnotationImpl(uid, library, AT_FDCWD, full.c_str(), full, npz ? &*npz : nullptr);
  }
  // The full path is only built for an error message.
  try {
    return LoadAnnotationImpl(uid, library, dir_fd, metadata_rel.c_str(), fs::path(),
                              npz ? &*npz : nullptr);
  } catch (const Error& e) {
    if (!e.path().empty()) throw;
    throw Error(e.message(), (dir / metadata_rel).string(), e.field(), e.uid());
  }
}

}  // namespace internal

}  // namespace mlspaces
