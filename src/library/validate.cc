#include "mlspaces/library/validate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <string_view>
#include <system_error>

#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/library/asset_index.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

constexpr double kOrthoTolerance = 1e-3;      // f4 / f8 files
constexpr double kOrthoToleranceHalf = 5e-3;  // f2 files: 10-bit mantissa, u = 2^-11
constexpr double kLastRowTolerance = 1e-6;

std::string Child(const std::string& pointer, std::string_view key) {
  return pointer + "/" + JsonPointerToken(key);
}

// Collects problems for one library folder.
class Validator {
 public:
  explicit Validator(fs::path dir) : dir_(std::move(dir)) {}

  std::vector<Problem> Run() {
    std::error_code ec;
    if (!fs::is_directory(dir_, ec)) {
      Add(dir_.string(), "", fs::exists(dir_, ec) ? "not a folder" : "folder not found");
      return std::move(problems_);
    }
    const fs::path asset_index = dir_ / "assets_index.json";
    const fs::path grasp_index = dir_ / "grasps_index.json";
    const bool has_assets = fs::exists(asset_index, ec);
    const bool has_grasps = fs::exists(grasp_index, ec);
    if (!has_assets && !has_grasps) {
      Add(dir_.string(), "", "neither assets_index.json nor grasps_index.json found");
    }
    if (has_assets) ValidateAssetIndex(asset_index);
    if (has_grasps) ValidateGraspIndex(grasp_index, has_assets);
    return std::move(problems_);
  }

 private:
  void Add(std::string file, std::string pointer, std::string message) {
    problems_.push_back({std::move(file), std::move(pointer), std::move(message)});
  }
  void Add(const Error& e) { Add(e.path(), e.field(), e.message()); }

  // Parses a JSON file; on failure records the problem and returns false.
  template <class J>
  bool Parse(const fs::path& path, J* out) {
    try {
      if constexpr (std::is_same_v<J, FlatJson>) {
        *out = ParseFlatJsonFile(path);
      } else {
        *out = ParseJsonFile(path);
      }
      return true;
    } catch (const Error& e) {
      Add(e);
      return false;
    }
  }

  // Parse, then the top level must be an object; on failure records the problem and returns
  // false.
  template <class J>
  bool ParseObject(const fs::path& path, J* out) {
    if (!Parse(path, out)) return false;
    if (!out->is_object()) {
      Add(path.string(), "/", "expected object, got " + JsonTypeWord(*out));
      return false;
    }
    return true;
  }

  // Checks that a path field names an existing file under the library; returns the full path.
  std::optional<fs::path> CheckPath(const std::string& file, const std::string& pointer,
                                    const FlatJson& value, bool nullable) {
    if (nullable && value.is_null()) return std::nullopt;
    if (!value.is_string()) {
      Add(file, pointer,
          std::string("expected string") + (nullable ? " or null" : "") + ", got " +
              JsonTypeWord(value));
      return std::nullopt;
    }
    const std::string& rel = value.get_ref<const std::string&>();
    fs::path p(rel);
    if (rel.empty() || p.is_absolute()) {
      Add(file, pointer, "expected a path relative to the library folder, got '" + rel + "'");
      return std::nullopt;
    }
    fs::path full = dir_ / p;
    std::error_code ec;
    auto st = fs::status(full, ec);
    if (!fs::exists(st)) {
      Add(file, pointer, "file not found: " + full.string());
      return std::nullopt;
    }
    if (fs::is_directory(st)) {
      Add(file, pointer, "is a folder, expected a file: " + full.string());
      return std::nullopt;
    }
    return full;
  }

  void ValidateAssetIndex(const fs::path& index_path) {
    const std::string file = index_path.string();
    FlatJson root;
    if (!ParseObject(index_path, &root)) return;
    asset_index_ok_ = true;
    for (auto it = root.begin(); it != root.end(); ++it) {
      const std::string& uid = it.key();
      asset_uids_.insert(uid);
      const std::string pointer = Child("", uid);
      const FlatJson& entry = it.value();
      if (!entry.is_object()) {
        Add(file, pointer, "expected object, got " + JsonTypeWord(entry));
        continue;
      }
      if (auto u = entry.find("uid"); u == entry.end()) {
        Add(file, pointer + "/uid", "missing required field");
      } else if (!u->is_string()) {
        Add(file, pointer + "/uid", "expected string, got " + JsonTypeWord(*u));
      } else if (u->get_ref<const std::string&>() != uid) {
        Add(file, pointer + "/uid",
            "uid '" + u->get<std::string>() + "' differs from its key '" + uid +
                "' (lookups use the key)");
      }
      std::optional<fs::path> paths[3];
      static constexpr std::string_view kFields[] = {"object_path", "metadata_path",
                                                     "metadata_npz_path"};
      for (int i = 0; i < 3; ++i) {
        const std::string field_pointer = pointer + "/" + std::string(kFields[i]);
        auto f = entry.find(kFields[i]);
        if (f == entry.end()) {
          Add(file, field_pointer,
              i == 2 ? "missing required field (string or null)" : "missing required field");
          continue;
        }
        paths[i] = CheckPath(file, field_pointer, *f, /*nullable=*/i == 2);
      }
      if (paths[1]) ValidateMetadata(uid, *paths[1], paths[2]);
    }
  }

  void ValidateMetadata(const std::string& uid, const fs::path& json_path,
                        const std::optional<fs::path>& npz_path) {
    const std::string file = json_path.string();
    Json meta;
    if (!ParseObject(json_path, &meta)) return;
    CheckKnownFields(file, meta);
    // A computed file mlspaces wrote names its sources and their hashes: any change is stale.
    if (auto stale = CheckComputedFrom(json_path, meta)) {
      problems_.insert(problems_.end(), stale->begin(), stale->end());
    }
    if (npz_path) ValidateMetadataNpz(uid, *npz_path, meta);
  }

  void ExpectString(const std::string& file, const Json& meta, std::string_view key) {
    auto it = meta.find(key);
    if (it != meta.end() && !it->is_string()) {
      Add(file, Child("", key), "expected string, got " + JsonTypeWord(*it));
    }
  }
  void ExpectBool(const std::string& file, const Json& meta, std::string_view key) {
    auto it = meta.find(key);
    if (it != meta.end() && !it->is_boolean()) {
      Add(file, Child("", key), "expected boolean, got " + JsonTypeWord(*it));
    }
  }
  void ExpectNonNegative(const std::string& file, const std::string& pointer, const Json& v) {
    if (!v.is_number()) {
      Add(file, pointer, "expected number, got " + JsonTypeWord(v));
      return;
    }
    double d = v.get<double>();
    if (!std::isfinite(d)) {
      Add(file, pointer, "expected a finite number");
    } else if (d < 0) {
      Add(file, pointer, "expected a number >= 0, got " + v.dump());
    }
  }

  // A WordNet synset name: lemma.pos.NN, e.g. block.n.01.
  static bool IsSynsetName(const std::string& s) {
    size_t last = s.rfind('.');
    if (last == std::string::npos || last == 0) return false;
    size_t mid = s.rfind('.', last - 1);
    if (mid == std::string::npos || mid == 0) return false;
    std::string_view lemma(s.data(), mid);
    std::string_view pos(s.data() + mid + 1, last - mid - 1);
    std::string_view num(s.data() + last + 1, s.size() - last - 1);
    if (pos.size() != 1 || std::string_view("nvasr").find(pos[0]) == std::string_view::npos) {
      return false;
    }
    if (num.size() != 2) return false;
    for (char c : num) {
      if (c < '0' || c > '9') return false;
    }
    for (char c : lemma) {
      if (static_cast<unsigned char>(c) <= ' ') return false;
    }
    return true;
  }

  void CheckKnownFields(const std::string& file, const Json& meta) {
    for (std::string_view key :
         {"assetId", "category", "description", "description_long", "primaryProperty"}) {
      ExpectString(file, meta, key);
    }
    if (auto it = meta.find("synset"); it != meta.end()) {
      if (!it->is_string()) {
        Add(file, "/synset", "expected string, got " + JsonTypeWord(*it));
      } else if (!IsSynsetName(it->get_ref<const std::string&>())) {
        Add(file, "/synset",
            "'" + it->get<std::string>() +
                "' is not a WordNet synset name (word.pos.NN, "
                "e.g. block.n.01)");
      }
    }
    if (auto it = meta.find("description_short"); it != meta.end()) {
      if (!it->is_object()) {
        Add(file, "/description_short", "expected object, got " + JsonTypeWord(*it));
      } else {
        for (auto d = it->begin(); d != it->end(); ++d) {
          if (!d.value().is_string()) {
            Add(file, Child("/description_short", d.key()),
                "expected string, got " + JsonTypeWord(d.value()));
          }
        }
      }
    }
    if (auto it = meta.find("mass"); it != meta.end()) ExpectNonNegative(file, "/mass", *it);
    if (auto it = meta.find("boundingBox"); it != meta.end()) {
      if (!it->is_object()) {
        Add(file, "/boundingBox", "expected object, got " + JsonTypeWord(*it));
      } else {
        for (std::string_view axis : {"x", "y", "z"}) {
          auto a = it->find(axis);
          const std::string pointer = Child("/boundingBox", axis);
          if (a == it->end()) {
            Add(file, pointer, "missing required field");
          } else {
            ExpectNonNegative(file, pointer, *a);
          }
        }
      }
    }
    ExpectBool(file, meta, "receptacle");
    ExpectBool(file, meta, "isObjaverse");
    if (auto it = meta.find("split"); it != meta.end() && !it->is_null()) {
      if (!it->is_string()) {
        Add(file, "/split",
            "expected \"train\", \"val\", \"test\" or null, got " + JsonTypeWord(*it));
      } else {
        const std::string& s = it->get_ref<const std::string&>();
        if (s != "train" && s != "val" && s != "test") {
          Add(file, "/split", "expected \"train\", \"val\", \"test\" or null, got \"" + s + "\"");
        }
      }
    }
    if (auto it = meta.find("license_info"); it != meta.end() && !it->is_object()) {
      Add(file, "/license_info", "expected object, got " + JsonTypeWord(*it));
    }
  }

  void ValidateMetadataNpz(const std::string& uid, const fs::path& npz_path, const Json& meta) {
    const std::string file = npz_path.string();
    try {
      NpzReader reader(npz_path);
      // Paths the NPZ creates: true for an intermediate object, false for an array.
      std::map<std::string, bool> created;
      for (const std::string& key : reader.keys()) {
        try {
          (void)reader.Read(key);
        } catch (const Error& e) {
          Add(file, key + ".npy", e.message());
          continue;
        }
        if (key.empty()) {
          Add(file, ".npy", "empty array name");
          continue;
        }
        const Json* node = &meta;  // the JSON at `pointer`; nullptr below what the JSON has
        std::string pointer;
        size_t start = 0;
        for (;;) {
          const size_t slash = key.find('/', start);
          const bool last = slash == std::string::npos;
          std::string_view part(key.data() + start, (last ? key.size() : slash) - start);
          pointer = Child(pointer, part);
          const Json* child = nullptr;
          if (node != nullptr) {
            auto it = node->find(part);
            if (it != node->end()) child = &*it;
          }
          auto made = created.find(pointer);
          if (last) {
            if (child != nullptr || made != created.end()) {
              Add(file, key + ".npy",
                  "Key " + key + " from npz metadata already exists in metadata for uid=" + uid);
            } else {
              created[pointer] = false;
            }
            break;
          }
          if ((child != nullptr && !child->is_object()) ||
              (made != created.end() && !made->second)) {
            Add(file, key + ".npy",
                "npz key " + key + " crosses " + pointer + ", which is not an object");
            break;
          }
          if (child == nullptr) created[pointer] = true;
          node = child;
          start = slash + 1;
        }
      }
    } catch (const Error& e) {
      Add(e.path().empty() ? file : e.path(), e.field(), e.message());
    }
  }

  void ValidateGraspIndex(const fs::path& index_path, bool has_assets) {
    const std::string file = index_path.string();
    FlatJson root;
    if (!ParseObject(index_path, &root)) return;
    const bool check_uids = has_assets && asset_index_ok_;
    auto check_uid = [&](const std::string& pointer, const std::string& uid) {
      if (check_uids && !asset_uids_.contains(uid)) {
        Add(file, pointer, "uid '" + uid + "' is not in " + (dir_ / "assets_index.json").string());
      }
    };
    if (auto it = root.find("grasp_paths"); it != root.end()) {
      ForEachMember(file, "/grasp_paths", *it,
                    [&](const std::string&, const FlatJson& uids, const std::string& p1) {
                      ForEachMember(
                          file, p1, uids,
                          [&](const std::string& uid, const FlatJson& path, const std::string& p2) {
                            check_uid(p2, uid);
                            if (auto full = CheckPath(file, p2, path, false))
                              ValidateGraspFile(*full);
                          });
                    });
    }
    if (auto it = root.find("articulated_grasp_paths"); it != root.end()) {
      ForEachMember(
          file, "/articulated_grasp_paths", *it,
          [&](const std::string&, const FlatJson& uids, const std::string& p1) {
            ForEachMember(
                file, p1, uids,
                [&](const std::string& uid, const FlatJson& joints, const std::string& p2) {
                  check_uid(p2, uid);
                  ForEachMember(
                      file, p2, joints,
                      [&](const std::string& joint, const FlatJson& path, const std::string& p3) {
                        if (joint.empty()) Add(file, p3, "empty joint name");
                        if (auto full = CheckPath(file, p3, path, false)) ValidateGraspFile(*full);
                      });
                });
          });
    }
  }

  // Calls fn(key, member, pointer) for each member of `value`, the JSON at `pointer`; records
  // a problem instead when `value` is not an object.
  template <class Fn>
  void ForEachMember(const std::string& file, const std::string& pointer, const FlatJson& value,
                     Fn&& fn) {
    if (!value.is_object()) {
      Add(file, pointer, "expected object, got " + JsonTypeWord(value));
      return;
    }
    for (auto it = value.begin(); it != value.end(); ++it) {
      fn(it.key(), it.value(), Child(pointer, it.key()));
    }
  }

  void ValidateGraspFile(const fs::path& path) {
    const std::string file = path.string();
    constexpr const char* kMember = "transforms.npy";
    try {
      NpzReader reader(path);
      if (!reader.Contains("transforms")) {
        Add(file, kMember, "missing member (grasp files hold their poses in transforms.npy)");
        return;
      }
      NpyHeader header = reader.ReadHeader("transforms");
      const auto& s = header.shape;
      if (s.size() != 3 || s[1] != 4 || s[2] != 4) {
        Add(file, kMember, "expected shape (N, 4, 4), got " + ShapeRepr(s));
        return;
      }
      if (s[0] == 0) {
        Add(file, kMember, "no grasps (shape (0, 4, 4))");
        return;
      }
      const double tolerance = header.dtype == DType::kF2 ? kOrthoToleranceHalf : kOrthoTolerance;
      std::vector<double> v = reader.Read("transforms").ToDoubles();
      CheckTransforms(file, v, s[0], tolerance);
    } catch (const Error& e) {
      Add(e.path().empty() ? file : e.path(), e.field(), e.message());
    }
  }

  struct Failure {
    size_t count = 0;
    size_t first = 0;
    double worst = 0;
  };

  void CheckTransforms(const std::string& file, const std::vector<double>& v, size_t n,
                       double tolerance) {
    Failure not_finite, last_row, not_ortho, not_right;
    auto fail = [](Failure& f, size_t i, double amount) {
      if (f.count++ == 0) f.first = i;
      if (amount > f.worst) f.worst = amount;
    };
    for (size_t g = 0; g < n; ++g) {
      const double* m = v.data() + g * 16;
      bool finite = true;
      for (int k = 0; k < 16; ++k) finite = finite && std::isfinite(m[k]);
      if (!finite) {
        fail(not_finite, g, 0);
        continue;
      }
      double row =
          std::max({std::abs(m[12]), std::abs(m[13]), std::abs(m[14]), std::abs(m[15] - 1.0)});
      if (row > kLastRowTolerance) fail(last_row, g, row);
      // R is m[r*4 + c] for r, c < 3; check R^T R = I.
      double worst = 0;
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) {
          double dot = 0;
          for (int r = 0; r < 3; ++r) dot += m[r * 4 + a] * m[r * 4 + b];
          worst = std::max(worst, std::abs(dot - (a == b ? 1.0 : 0.0)));
        }
      }
      if (worst >= tolerance) fail(not_ortho, g, worst);
      double det = m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
                   m[2] * (m[4] * m[9] - m[5] * m[8]);
      if (!(det > 0)) fail(not_right, g, -det);
    }
    auto report = [&](const Failure& f, const std::string& what, const std::string& measure) {
      if (f.count == 0) return;
      char worst[64];
      std::snprintf(worst, sizeof worst, "%.3g", f.worst);
      std::string message = std::to_string(f.count) + " of " + std::to_string(n) + " grasps " +
                            what + " (first: grasp " + std::to_string(f.first);
      if (!measure.empty()) message += ", worst " + measure + " = " + worst;
      Add(file, "transforms.npy", message + ")");
    };
    report(not_finite, "have non-finite values", "");
    report(last_row, "have a last row other than 0 0 0 1", "deviation");
    report(not_ortho, "have a rotation that is not orthonormal", "|R^T R - I|");
    report(not_right, "have a rotation with det <= 0 (not right-handed)", "");
  }

  fs::path dir_;
  std::vector<Problem> problems_;
  std::set<std::string> asset_uids_;
  bool asset_index_ok_ = false;
};

}  // namespace

std::vector<Problem> ValidateLibrary(const fs::path& dir) { return Validator(dir).Run(); }

}  // namespace mlspaces
