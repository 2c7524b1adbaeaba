// Datagen configs: one field description per struct (Serialize) drives strict YAML loading,
// `--set` overrides, the canonical dump, the hash and path resolution.
#include "mlspaces/datagen/config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <sstream>
#include <type_traits>

#include "mlspaces/core/error.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/core/strings.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;

namespace {

// ---------------------------------------------------------------------------------------
// Field descriptions of core's library types (they have no Serialize member).

template <class A>
void SerializeFields(A* a, AssetLibrarySpec& spec) {
  a->Visit("name", spec.name);
  a->Visit("path", spec.dir);
}

template <class A>
void SerializeFields(A* a, GraspLibrarySpec& spec) {
  a->Visit("name", spec.name);
  a->Visit("path", spec.dir);
  a->Visit("asset_library", spec.asset_library);
}

template <class A>
void SerializeFields(A* a, LibraryConfig& config) {
  a->Visit("assets_dir", config.assets_dir);
  a->Visit("asset_libraries", config.asset_libraries);
  a->Visit("grasp_libraries", config.grasp_libraries);
}

/// Collects field names (to check keys against).
struct NameCollector {
  std::vector<std::string> names;
  template <class T>
  void Visit(const char* name, T&) {
    names.emplace_back(name);
  }
};

template <class T>
concept HasSerialize = requires(T& t, NameCollector* a) { t.Serialize(a); };
template <class T>
concept IsStruct = HasSerialize<T> || std::is_same_v<T, AssetLibrarySpec> ||
                   std::is_same_v<T, GraspLibrarySpec> || std::is_same_v<T, LibraryConfig>;

template <class A, class T>
void VisitFields(A* a, T& value) {
  if constexpr (HasSerialize<T>) {
    value.Serialize(a);
  } else {
    SerializeFields(a, value);
  }
}

template <class T>
std::vector<std::string> FieldNames() {
  NameCollector c;
  T value{};
  VisitFields(&c, value);
  return c.names;
}

template <class T>
struct IsOptional : std::false_type {};
template <class T>
struct IsOptional<std::optional<T>> : std::true_type {};
template <class T>
struct IsVector : std::false_type {};
template <class T>
struct IsVector<std::vector<T>> : std::true_type {};
template <class T>
struct IsArray : std::false_type {};
template <class T, size_t N>
struct IsArray<std::array<T, N>> : std::true_type {};
template <class T>
struct IsMap : std::false_type {};
template <class T>
struct IsMap<std::map<std::string, T>> : std::true_type {};

// ---------------------------------------------------------------------------------------
// Small helpers.

size_t EditDistance(std::string_view a, std::string_view b) {
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t sub = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

/// "did you mean 'x'?" for the candidates closest to `word` (case-insensitive edit distance
/// at most a third of the length, or a prefix match); empty when none is close.
std::string DidYouMean(std::string_view word, const std::vector<std::string>& candidates) {
  const std::string w = Lower(word);
  size_t best = std::numeric_limits<size_t>::max();
  std::vector<std::string> close;
  for (const std::string& c : candidates) {
    const std::string lc = Lower(c);
    size_t d = EditDistance(w, lc);
    if (std::min(w.size(), lc.size()) >= 4 && (lc.starts_with(w) || w.starts_with(lc))) {
      d = std::min<size_t>(d, 1);
    }
    if (d > std::max<size_t>(2, std::max(w.size(), lc.size()) / 3)) continue;
    if (d < best) {
      best = d;
      close.clear();
    }
    if (d == best) close.push_back(c);
  }
  if (close.empty()) return {};
  std::string out = "did you mean ";
  for (size_t i = 0; i < close.size(); ++i) {
    out += (i == 0 ? "'" : i + 1 == close.size() ? " or '" : ", '") + close[i] + "'";
  }
  return out + "?";
}

std::string Join(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

std::string Child(const std::string& path, std::string_view name) {
  return path.empty() ? std::string(name) : path + "." + std::string(name);
}

std::string LineOf(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  if (mark.is_null()) return {};
  return "line " + std::to_string(mark.line + 1);
}

std::string Describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
      return "null";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a mapping";
    case YAML::NodeType::Scalar:
      return "'" + node.Scalar() + "'";
    default:
      return "nothing";
  }
}

bool IsPlainScalar(const YAML::Node& node) { return node.IsScalar() && node.Tag() != "!"; }

// ---------------------------------------------------------------------------------------
// Reading: YAML node -> value, strictly.

struct ReadContext {
  std::string file;  ///< for errors; empty for --set
  fs::path base_dir;  ///< relative paths resolve against it
  bool usage = false;  ///< --set: throw UsageError without a line
};

class Reader {
 public:
  explicit Reader(const ReadContext& ctx) : ctx_(ctx) {}

  [[noreturn]] void Fail(const YAML::Node& node, const std::string& key,
                         const std::string& message) const {
    const std::string what = (key.empty() ? "top level" : key) + ": " + message;
    if (ctx_.usage) throw UsageError("--set " + what);
    // An empty value's mark points past its key (often to the next line): use the key's.
    const std::string line = LineOf(node);
    throw Error(what, ctx_.file, line.empty() || node.IsNull() ? key_line_ : line);
  }

  /// Reads `node` into `out`; `key` is the dotted key path.
  template <class T>
  void Read(const YAML::Node& node, const std::string& key, T& out) const {
    if constexpr (std::is_same_v<T, bool>) {
      static const std::set<std::string> kTrue{"true", "True", "TRUE"};
      static const std::set<std::string> kFalse{"false", "False", "FALSE"};
      if (IsPlainScalar(node) && kTrue.count(node.Scalar())) {
        out = true;
      } else if (IsPlainScalar(node) && kFalse.count(node.Scalar())) {
        out = false;
      } else {
        Fail(node, key, "expected true or false, got " + Describe(node));
      }
    } else if constexpr (std::is_integral_v<T>) {
      const std::string s = IsPlainScalar(node) ? node.Scalar() : std::string();
      T value{};
      const char* first = s.data() + (s.starts_with('+') ? 1 : 0);
      const auto [ptr, ec] = std::from_chars(first, s.data() + s.size(), value);
      if (s.empty() || ec != std::errc() || ptr != s.data() + s.size()) {
        const bool range = ec == std::errc::result_out_of_range;
        Fail(node, key,
             std::string(range ? "integer out of range" : std::is_signed_v<T>
                                                              ? "expected an integer"
                                                              : "expected a whole number >= 0") +
                 ", got " + Describe(node));
      }
      out = value;
    } else if constexpr (std::is_floating_point_v<T>) {
      const std::string s = IsPlainScalar(node) ? node.Scalar() : std::string();
      static const std::map<std::string, double> kSpecial{
          {".inf", HUGE_VAL},  {".Inf", HUGE_VAL},  {"+.inf", HUGE_VAL}, {"-.inf", -HUGE_VAL},
          {"-.Inf", -HUGE_VAL}, {".nan", NAN}, {".NaN", NAN}};
      if (auto it = kSpecial.find(s); it != kSpecial.end()) {
        out = it->second;
        return;
      }
      double value = 0;
      const char* first = s.data() + (s.starts_with('+') ? 1 : 0);
      const auto [ptr, ec] = std::from_chars(first, s.data() + s.size(), value);
      if (s.empty() || ec != std::errc() || ptr != s.data() + s.size()) {
        Fail(node, key, "expected a number, got " + Describe(node));
      }
      out = value;
    } else if constexpr (std::is_same_v<T, std::string>) {
      if (!node.IsScalar()) Fail(node, key, "expected a string, got " + Describe(node));
      out = node.Scalar();
    } else if constexpr (std::is_same_v<T, fs::path>) {
      if (!node.IsScalar() || node.Scalar().empty()) {
        Fail(node, key, "expected a path, got " + Describe(node));
      }
      fs::path p(node.Scalar());
      out = p.is_absolute() || ctx_.base_dir.empty() ? p : (ctx_.base_dir / p).lexically_normal();
    } else if constexpr (std::is_enum_v<T>) {
      const auto& names = EnumNames<T>::kNames;
      if (node.IsScalar()) {
        for (size_t i = 0; i < names.size(); ++i) {
          if (names[i] == node.Scalar()) {
            out = static_cast<T>(i);
            return;
          }
        }
      }
      std::vector<std::string> valid(names.begin(), names.end());
      std::string hint = node.IsScalar() ? DidYouMean(node.Scalar(), valid) : "";
      Fail(node, key,
           "expected one of " + Join(valid) + ", got " + Describe(node) +
               (hint.empty() ? "" : " (" + hint + ")"));
    } else if constexpr (IsOptional<T>::value) {
      if (node.IsNull()) {
        out.reset();
        return;
      }
      if (!out.has_value()) out.emplace();
      Read(node, key, *out);
    } else if constexpr (IsVector<T>::value) {
      if (!node.IsSequence()) Fail(node, key, "expected a list, got " + Describe(node));
      T items;
      for (size_t i = 0; i < node.size(); ++i) {
        typename T::value_type item{};
        Read(node[i], key + "[" + std::to_string(i) + "]", item);
        items.push_back(std::move(item));
      }
      out = std::move(items);
    } else if constexpr (IsArray<T>::value) {
      const size_t n = std::tuple_size_v<T>;
      if (!node.IsSequence() || node.size() != n) {
        Fail(node, key,
             "expected a list of " + std::to_string(n) + " values, got " +
                 (node.IsSequence() ? "a list of " + std::to_string(node.size())
                                    : Describe(node)));
      }
      T items{};
      for (size_t i = 0; i < n; ++i) Read(node[i], key + "[" + std::to_string(i) + "]", items[i]);
      out = items;
    } else if constexpr (IsMap<T>::value) {
      if (!node.IsMap()) Fail(node, key, "expected a mapping, got " + Describe(node));
      T items;
      for (const auto& kv : node) {
        if (!kv.first.IsScalar() || kv.first.Scalar().empty()) {
          Fail(kv.first, key, "keys must be non-empty strings");
        }
        const std::string name = kv.first.Scalar();
        if (items.count(name)) Fail(kv.first, Child(key, name), "duplicate key");
        Read(kv.second, Child(key, name), items[name]);
      }
      out = std::move(items);
    } else if constexpr (std::is_same_v<T, LibraryConfig>) {
      ReadLibraries(node, key, out);
    } else {
      static_assert(IsStruct<T>);
      ReadStruct(node, key, out, {});
      if constexpr (std::is_same_v<T, AssetLibrarySpec> || std::is_same_v<T, GraspLibrarySpec>) {
        RequireLibraryFields(node, key, out);
      }
    }
  }

  /// Merges the keys of mapping `node` into struct `out`; `extra` keys are allowed and
  /// skipped.
  template <class T>
  void ReadStruct(const YAML::Node& node, const std::string& key, T& out,
                  const std::set<std::string>& extra) const {
    if (!node.IsMap()) Fail(node, key, "expected a mapping, got " + Describe(node));
    const std::vector<std::string> names = FieldNames<T>();
    std::set<std::string> seen;
    for (const auto& kv : node) {
      if (!kv.first.IsScalar()) Fail(kv.first, key, "keys must be strings");
      const std::string name = kv.first.Scalar();
      if (!seen.insert(name).second) Fail(kv.first, Child(key, name), "duplicate key");
      if (extra.count(name)) continue;
      if (std::find(names.begin(), names.end(), name) == names.end()) {
        const std::string hint = DidYouMean(name, names);
        Fail(kv.first, Child(key, name),
             "unknown key (" + (hint.empty() ? "" : hint + " ") + "valid keys: " + Join(names) +
                 ")");
      }
    }
    FieldReader fields{this, &node, key};
    VisitFields(&fields, out);
  }

 private:
  struct FieldReader {
    const Reader* reader;
    const YAML::Node* node;
    std::string key;
    template <class T>
    void Visit(const char* name, T& field) {
      for (const auto& kv : *node) {
        if (kv.first.Scalar() == name) {
          reader->key_line_ = LineOf(kv.first);  // for empty values (see Fail)
          reader->Read(kv.second, Child(key, name), field);
          return;
        }
      }
    }
  };

  template <class Spec>
  void RequireLibraryFields(const YAML::Node& node, const std::string& key, Spec& spec) const {
    for (const std::string& name : FieldNames<Spec>()) {
      if (!node[name]) Fail(node, key, "missing '" + name + "'");
    }
    if (spec.name.empty()) Fail(node, Child(key, "name"), "must not be empty");
    if (spec.name.find('/') != std::string::npos) {
      Fail(node, Child(key, "name"), "library name " + spec.name + " must not contain slashes");
    }
    if (!ctx_.file.empty()) {
      spec.origin_file = ctx_.file;
      spec.origin_line = LineOf(node);
    }
  }

  /// `libraries:` is a mapping (LibraryConfig's fields) or the path of a libraries YAML.
  void ReadLibraries(const YAML::Node& node, const std::string& key, LibraryConfig& out) const {
    if (node.IsScalar()) {
      fs::path file;
      Read(node, key, file);
      try {
        out = LibraryConfig::LoadYaml(file);
      } catch (const Error& e) {
        if (!e.field().empty()) throw;  // located in the libraries file itself
        Fail(node, key, e.what());
      }
      return;
    }
    ReadStruct(node, key, out, {});
  }

  const ReadContext& ctx_;
  mutable std::string key_line_;
};

// ---------------------------------------------------------------------------------------
// Writing: the canonical YAML dump.

std::string FormatDouble(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  char buf[64];
  const auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
  (void)ec;
  return std::string(buf, ptr);
}

std::string QuoteString(std::string_view s) {
  static const std::set<std::string_view> kNullWords{"null", "Null", "NULL", "~"};
  bool plain = !s.empty() && s.front() != '-' && !kNullWords.count(s);
  for (char c : s) {
    plain = plain && (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' ||
                      c == '/' || c == '+' || c == '-');
  }
  if (plain) return std::string(s);
  std::string out = "\"";
  for (char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else if (c == '\t') {
      out += "\\t";
    } else if (u < 0x20 || u == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", u);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

template <class T>
struct IsStructVector : std::false_type {};
template <class T>
struct IsStructVector<std::vector<T>> : std::bool_constant<IsStruct<T>> {};

class Writer {
 public:
  std::string out;

  /// The inline form of a scalar or a sequence of scalars.
  template <class T>
  static std::string Inline(const T& value) {
    if constexpr (std::is_same_v<T, bool>) {
      return value ? "true" : "false";
    } else if constexpr (std::is_integral_v<T>) {
      return std::to_string(value);
    } else if constexpr (std::is_floating_point_v<T>) {
      return FormatDouble(value);
    } else if constexpr (std::is_same_v<T, std::string>) {
      return QuoteString(value);
    } else if constexpr (std::is_same_v<T, fs::path>) {
      return QuoteString(value.generic_string());
    } else if constexpr (std::is_enum_v<T>) {
      return std::string(EnumName(value));
    } else if constexpr (IsOptional<T>::value) {
      return value.has_value() ? Inline(*value) : "null";
    } else {
      static_assert(IsVector<T>::value || IsArray<T>::value);
      std::string s = "[";
      for (size_t i = 0; i < value.size(); ++i) s += (i ? ", " : "") + Inline(value[i]);
      return s + "]";
    }
  }

  /// Writes `key: value` at `indent`.
  template <class T>
  void Field(int indent, const std::string& key, const T& value) {
    const std::string pad(indent, ' ');
    if constexpr (IsOptional<T>::value) {
      if (!value.has_value()) {
        out += pad + key + ": null\n";
      } else {
        Field(indent, key, *value);
      }
    } else if constexpr (IsStruct<T>) {
      out += pad + key + ":\n";
      Struct(indent + 2, value);
    } else if constexpr (IsMap<T>::value) {
      if (value.empty()) {
        out += pad + key + ": {}\n";
        return;
      }
      out += pad + key + ":\n";
      for (const auto& [k, v] : value) Field(indent + 2, QuoteString(k), v);
    } else if constexpr (IsStructVector<T>::value) {
      if (value.empty()) {
        out += pad + key + ": []\n";
        return;
      }
      out += pad + key + ":\n";
      for (const auto& item : value) {
        const size_t start = out.size();
        Struct(indent + 4, item);
        out.replace(start + indent + 2, 2, "- ");
      }
    } else {
      out += pad + key + ": " + Inline(value) + "\n";
    }
  }

  template <class T>
  void Struct(int indent, const T& value) {
    FieldWriter w{this, indent};
    VisitFields(&w, const_cast<T&>(value));
  }

 private:
  struct FieldWriter {
    Writer* writer;
    int indent;
    template <class T>
    void Visit(const char* name, T& field) {
      writer->Field(indent, name, field);
    }
  };
};

// ---------------------------------------------------------------------------------------
// --set: walk the dotted key path through the field descriptions.

class Setter {
 public:
  Setter(const Reader& reader, const YAML::Node& value) : reader_(reader), value_(value) {}

  /// Applies the value at `parts[i..]` inside `target`; `done` is the dotted path so far.
  template <class T>
  void Apply(T& target, const std::vector<std::string>& parts, size_t i,
             const std::string& done) const {
    if (i == parts.size()) {
      reader_.Read(value_, done, target);
      return;
    }
    const std::string& part = parts[i];
    if constexpr (IsStruct<T>) {
      Descender d{this, &parts, i, done};
      VisitFields(&d, target);
      if (!d.matched) {
        const std::vector<std::string> names = FieldNames<T>();
        const std::string hint = DidYouMean(part, names);
        throw UsageError("--set " + Child(done, part) + ": unknown key (" +
                         (hint.empty() ? "" : hint + " ") + "valid keys: " + Join(names) + ")");
      }
    } else if constexpr (IsOptional<T>::value) {
      if (!target.has_value()) target.emplace();
      Apply(*target, parts, i, done);
    } else if constexpr (IsMap<T>::value) {
      Apply(target[part], parts, i + 1, Child(done, part));
    } else if constexpr (IsVector<T>::value || IsArray<T>::value) {
      size_t index = 0;
      const auto [ptr, ec] = std::from_chars(part.data(), part.data() + part.size(), index);
      if (part.empty() || ec != std::errc() || ptr != part.data() + part.size() ||
          index >= target.size()) {
        throw UsageError("--set " + done + ": '" + part + "' is not an index of this list (" +
                         std::to_string(target.size()) + " items)");
      }
      Apply(target[index], parts, i + 1, done + "[" + part + "]");
    } else {
      throw UsageError("--set " + done + ": is a single value, it has no key '" + part + "'");
    }
  }

 private:
  struct Descender {
    const Setter* setter;
    const std::vector<std::string>* parts;
    size_t i;
    std::string done;
    bool matched = false;
    template <class T>
    void Visit(const char* name, T& field) {
      if (matched || (*parts)[i] != name) return;
      matched = true;
      setter->Apply(field, *parts, i + 1, Child(done, name));
    }
  };

  const Reader& reader_;
  const YAML::Node& value_;
};

// ---------------------------------------------------------------------------------------
// Path resolution: visit every fs::path.

struct PathResolver {
  fs::path base;

  template <class T>
  void Walk(T& value) {
    if constexpr (std::is_same_v<T, fs::path>) {
      if (!value.empty() && value.is_relative()) value = (base / value).lexically_normal();
    } else if constexpr (IsOptional<T>::value) {
      if (value.has_value()) Walk(*value);
    } else if constexpr (IsVector<T>::value || IsArray<T>::value) {
      for (auto& item : value) Walk(item);
    } else if constexpr (IsMap<T>::value) {
      for (auto& [k, v] : value) Walk(v);
    } else if constexpr (IsStruct<T>) {
      VisitFields(this, value);
    }
  }

  template <class T>
  void Visit(const char*, T& field) {
    Walk(field);
  }
};

// ---------------------------------------------------------------------------------------
// Validation helpers.

class Checker {
 public:
  explicit Checker(const fs::path& origin) : origin_(origin.string()) {}

  void Check(bool ok, const std::string& key, const std::string& message) const {
    if (!ok) throw Error(key + ": " + message, origin_);
  }
  void Positive(int64_t v, const std::string& key) const {
    Check(v >= 1, key, "must be >= 1, got " + std::to_string(v));
  }
  void NonNegative(double v, const std::string& key) const {
    Check(std::isfinite(v) && v >= 0, key, "must be a finite number >= 0, got " + FormatDouble(v));
  }
  void PositiveReal(double v, const std::string& key) const {
    Check(std::isfinite(v) && v > 0, key, "must be a finite number > 0, got " + FormatDouble(v));
  }
  /// a / b is a whole number.
  void Divides(double a, double b, const std::string& key, const std::string& what) const {
    const double r = a / b;
    Check(std::fabs(r - std::round(r)) < 1e-9 * std::max(1.0, std::fabs(r)), key,
          what + " must be a whole number, got " + FormatDouble(r));
  }
  void Pose(const std::optional<std::array<double, 7>>& pose, const std::string& key) const {
    if (!pose) return;
    double n = 0;
    for (size_t i = 0; i < 7; ++i) {
      Check(std::isfinite((*pose)[i]), key, "values must be finite");
      if (i >= 3) n += (*pose)[i] * (*pose)[i];
    }
    Check(std::fabs(std::sqrt(n) - 1.0) < 1e-3, key,
          "the quaternion (values 4-7, wxyz) must have unit length");
  }

 private:
  std::string origin_;
};

}  // namespace

// ---------------------------------------------------------------------------------------
// Built-in configs.

std::vector<CameraConfig> CameraSystemConfig::DroidCameras() {
  CameraConfig wrist;
  wrist.name = "wrist_camera";
  wrist.type = CameraType::kMjcf;
  wrist.mjcf_name = "gripper/wrist_camera";
  wrist.robot_namespace = "robot_0/";
  wrist.fov = 56.74;
  CameraConfig exo;
  exo.name = "exo_camera_1";
  exo.type = CameraType::kRobotMounted;
  exo.reference_body_names = {"robot_0/fr3_link0"};
  exo.camera_offset = {0.1, 0.57, 0.66};
  exo.camera_quaternion = {-0.3633, -0.1241, 0.4263, 0.8191};
  exo.fov = 71.0;
  exo.visibility_constraints = {{"__task_objects__", 0.001}};
  return {wrist, exo};
}

ExperimentConfig CustomAssetsDataGenConfig() {
  ExperimentConfig c;
  c.scene_dataset = SceneDataset::kUser;
  c.num_workers = 1;
  c.robot_config.base_size.reset();
  c.camera_config = CameraSystemConfig{};
  TaskSamplerConfig& s = c.task_sampler_config;
  s.task_sampler_class = "block_pickup";
  s.dataset_name = SceneDataset::kUser;
  s.scene_xml_paths = {"scene.xml"};
  s.house_inds.reset();
  s.samples_per_house = 2;
  s.house_variant = "base";
  c.output_dir = "experiment_output";
  c.tag = "tutorial_franka_pick_custom_assets";
  AssetLibrarySpec assets;
  assets.name = "custom_assets";
  assets.dir = "asset_library";
  GraspLibrarySpec grasps;
  grasps.name = "custom_grasps";
  grasps.dir = "asset_library";
  grasps.asset_library = "custom_assets";
  c.libraries.asset_libraries = {assets};
  c.libraries.grasp_libraries = {grasps};
  return c;
}

ConfigRegistry ConfigRegistry::WithBuiltins() {
  ConfigRegistry registry;
  registry.RegisterConfig("PickBaseConfig", [] { return ExperimentConfig{}; });
  registry.RegisterConfig("CustomAssetsDataGenConfig", CustomAssetsDataGenConfig);
  return registry;
}

void ConfigRegistry::RegisterConfig(const std::string& name, ConfigFactory factory,
                                    bool replace) {
  if (name.empty() || std::any_of(name.begin(), name.end(), [](char c) {
        return std::isspace(static_cast<unsigned char>(c));
      })) {
    throw UsageError("config name '" + name + "' must be non-empty and without spaces");
  }
  if (!factory) throw UsageError("config " + name + ": the factory is empty");
  for (auto& [existing, f] : entries_) {
    if (Lower(existing) != Lower(name)) continue;
    if (!replace) throw UsageError("config " + name + " is already registered as " + existing);
    existing = name;
    f = std::move(factory);
    return;
  }
  entries_.emplace_back(name, std::move(factory));
}

bool ConfigRegistry::Contains(std::string_view name) const {
  const std::string key = Lower(name);
  return std::any_of(entries_.begin(), entries_.end(),
                     [&](const auto& e) { return Lower(e.first) == key; });
}

const std::string& ConfigRegistry::CanonicalName(std::string_view name) const {
  const std::string key = Lower(name);
  for (const auto& e : entries_) {
    if (Lower(e.first) == key) return e.first;
  }
  const std::vector<std::string> names = Names();
  const std::string hint = DidYouMean(name, names);
  throw Error("unknown config '" + std::string(name) + "' (" + (hint.empty() ? "" : hint + " ") +
              "registered: " + (names.empty() ? "none" : Join(names)) + ")");
}

ExperimentConfig ConfigRegistry::Make(std::string_view name) const {
  const std::string& canonical = CanonicalName(name);
  for (const auto& e : entries_) {
    if (e.first == canonical) return e.second();
  }
  throw Error("unknown config '" + std::string(name) + "'");  // unreachable
}

std::vector<std::string> ConfigRegistry::Names() const {
  std::vector<std::string> names;
  for (const auto& e : entries_) names.push_back(e.first);
  return names;
}

// ---------------------------------------------------------------------------------------
// Load, override, validate, dump, hash.

ExperimentConfig LoadConfigFile(const fs::path& file, const ConfigRegistry& registry) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(file.string());
  } catch (const YAML::BadFile&) {
    throw Error("cannot open the config file", file.string());
  } catch (const YAML::ParserException& e) {
    throw Error("invalid YAML: " + e.msg, file.string(),
                e.mark.is_null() ? std::string() : "line " + std::to_string(e.mark.line + 1));
  }
  const fs::path base_dir = fs::absolute(file).parent_path();
  ReadContext ctx{file.string(), base_dir, false};
  Reader reader(ctx);
  ExperimentConfig config;
  if (root.IsNull()) {
    ResolvePaths(config, base_dir);
    return config;
  }
  if (!root.IsMap()) reader.Fail(root, "", "expected a mapping, got " + Describe(root));
  if (const YAML::Node base = root["base"]) {
    if (!base.IsScalar()) reader.Fail(base, "base", "expected a config name, got " +
                                                        Describe(base));
    try {
      config = registry.Make(base.Scalar());
    } catch (const Error& e) {
      reader.Fail(base, "base", e.message());
    }
  }
  reader.ReadStruct(root, "", config, {"base"});
  ResolvePaths(config, base_dir);
  return config;
}

void ApplyOverride(ExperimentConfig& config, std::string_view assignment,
                   const fs::path& base_dir) {
  const size_t eq = assignment.find('=');
  if (eq == std::string_view::npos || eq == 0) {
    throw UsageError("--set expects KEY=VALUE (e.g. task_sampler_config.samples_per_house=4), "
                     "got '" + std::string(assignment) + "'");
  }
  const std::string key(assignment.substr(0, eq));
  const std::string text(assignment.substr(eq + 1));
  std::vector<std::string> parts;
  for (size_t start = 0;;) {
    const size_t dot = key.find('.', start);
    parts.push_back(key.substr(start, dot == std::string::npos ? dot : dot - start));
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  for (const std::string& p : parts) {
    if (p.empty()) throw UsageError("--set " + key + ": empty key component");
  }
  YAML::Node value;
  try {
    value = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw UsageError("--set " + key + ": invalid YAML value '" + text + "': " + e.msg);
  }
  ReadContext ctx{"", base_dir, true};
  Reader reader(ctx);
  Setter(reader, value).Apply(config, parts, 0, "");
}

void ResolvePaths(ExperimentConfig& config, const fs::path& base_dir) {
  PathResolver resolver{base_dir};
  resolver.Walk(config);
}

void Validate(const ExperimentConfig& c, const fs::path& origin) {
  Checker k(origin);
  k.Check(c.num_envs == 1, "num_envs", "only 1 environment per worker is supported, got " +
                                           std::to_string(c.num_envs));
  k.Positive(c.num_workers, "num_workers");
  k.PositiveReal(c.policy_dt_ms, "policy_dt_ms");
  k.PositiveReal(c.ctrl_dt_ms, "ctrl_dt_ms");
  k.PositiveReal(c.sim_dt_ms, "sim_dt_ms");
  k.Divides(c.policy_dt_ms, c.ctrl_dt_ms, "policy_dt_ms", "policy_dt_ms / ctrl_dt_ms");
  k.Divides(c.ctrl_dt_ms, c.sim_dt_ms, "ctrl_dt_ms", "ctrl_dt_ms / sim_dt_ms");
  k.Positive(c.task_horizon, "task_horizon");
  k.Check(!c.data_split.empty(), "data_split", "must not be empty");
  k.Check(!c.output_dir || !c.output_dir->empty(), "output_dir", "must not be empty");

  for (size_t i = 0; i < c.libraries.asset_libraries.size(); ++i) {
    const AssetLibrarySpec& s = c.libraries.asset_libraries[i];
    const std::string key = "libraries.asset_libraries[" + std::to_string(i) + "]";
    k.Check(!s.name.empty() && s.name.find('/') == std::string::npos, key + ".name",
            "must be non-empty and without slashes");
    k.Check(!s.dir.empty(), key + ".path", "must not be empty");
  }
  for (size_t i = 0; i < c.libraries.grasp_libraries.size(); ++i) {
    const GraspLibrarySpec& s = c.libraries.grasp_libraries[i];
    const std::string key = "libraries.grasp_libraries[" + std::to_string(i) + "]";
    k.Check(!s.name.empty() && s.name.find('/') == std::string::npos, key + ".name",
            "must be non-empty and without slashes");
    k.Check(!s.dir.empty(), key + ".path", "must not be empty");
    k.Check(!s.asset_library.empty(), key + ".asset_library", "must not be empty");
  }

  const TaskConfig& t = c.task_config;
  k.Check(!t.pickup_obj_name || !t.pickup_obj_name->empty(), "task_config.pickup_obj_name",
          "must not be empty (use null to let the sampler choose)");
  k.Pose(t.robot_base_pose, "task_config.robot_base_pose");
  k.Pose(t.pickup_obj_start_pose, "task_config.pickup_obj_start_pose");
  k.Pose(t.pickup_obj_goal_pose, "task_config.pickup_obj_goal_pose");
  k.PositiveReal(t.succ_pos_threshold, "task_config.succ_pos_threshold");

  const TaskSamplerConfig& s = c.task_sampler_config;
  const std::string sp = "task_sampler_config.";
  k.Check(!s.task_sampler_class.empty(), sp + "task_sampler_class", "must not be empty");
  k.Check(!s.scene_xml_paths.empty(), sp + "scene_xml_paths",
          "scene_dataset user needs at least one scene");
  if (s.house_inds) {
    k.Check(!s.house_inds->empty(), sp + "house_inds", "must not be empty (null = all scenes)");
    for (int64_t i : *s.house_inds) {
      k.Check(i >= 0 && static_cast<size_t>(i) < s.scene_xml_paths.size(), sp + "house_inds",
              "index " + std::to_string(i) + " is not in [0, " +
                  std::to_string(s.scene_xml_paths.size()) + ")");
    }
  }
  k.Positive(s.samples_per_house, sp + "samples_per_house");
  k.Check(s.house_variant == "base", sp + "house_variant",
          "user scenes have no variants; must be base, got " + s.house_variant);
  k.Positive(s.episodes_per_batch, sp + "episodes_per_batch");
  k.Positive(s.task_batch_size, sp + "task_batch_size");
  if (s.max_tasks) k.Positive(*s.max_tasks, sp + "max_tasks");
  k.Check(s.sim_settle_timesteps >= 0, sp + "sim_settle_timesteps", "must be >= 0");
  k.Positive(s.max_allowed_sequential_task_sampler_failures,
             sp + "max_allowed_sequential_task_sampler_failures");
  k.Positive(s.max_allowed_sequential_rollout_failures,
             sp + "max_allowed_sequential_rollout_failures");
  k.Positive(s.max_allowed_sequential_irrecoverable_failures,
             sp + "max_allowed_sequential_irrecoverable_failures");
  k.Positive(s.max_total_attempts_multiplier, sp + "max_total_attempts_multiplier");
  k.Positive(s.max_asset_failures, sp + "max_asset_failures");
  const std::pair<std::string, const PlanarNoise*> noises[] = {
      {"robot_base_noise", &s.robot_base_noise}, {"object_noise", &s.object_noise}};
  for (const auto& [name, noise] : noises) {
    k.NonNegative(noise->x, sp + name + ".x");
    k.NonNegative(noise->y, sp + name + ".y");
    k.NonNegative(noise->yaw_deg, sp + name + ".yaw_deg");
    k.Check(noise->yaw_deg <= 180, sp + name + ".yaw_deg", "must be <= 180");
  }
  k.Check(std::isfinite(s.goal_offset_z), sp + "goal_offset_z", "must be finite");

  const RobotConfig& r = c.robot_config;
  k.Check(!r.name.empty(), "robot_config.name", "must not be empty");
  if (r.base_size) {
    for (double v : *r.base_size) k.PositiveReal(v, "robot_config.base_size");
  }
  for (double v : r.init_qpos_noise_range.arm) {
    k.NonNegative(v, "robot_config.init_qpos_noise_range.arm");
  }
  const ActionNoiseConfig& n = r.action_noise_config;
  const std::string np = "robot_config.action_noise_config.";
  k.NonNegative(n.action_scale_factor, np + "action_scale_factor");
  k.NonNegative(n.rotation_noise_scale, np + "rotation_noise_scale");
  k.NonNegative(n.max_tcp_position_noise, np + "max_tcp_position_noise");
  k.NonNegative(n.max_tcp_rotation_noise, np + "max_tcp_rotation_noise");

  const CameraSystemConfig& cam = c.camera_config;
  k.Check(cam.img_resolution[0] >= 16 && cam.img_resolution[1] >= 16 &&
              cam.img_resolution[0] <= 8192 && cam.img_resolution[1] <= 8192,
          "camera_config.img_resolution", "width and height must be in 16..8192");
  k.Check(cam.depth_max_m > 0, "camera_config.depth_max_m", "must be > 0");
  k.Check(cam.video_crf >= 0 && cam.video_crf <= 51, "camera_config.video_crf",
          "must be in 0..51");
  static const std::set<std::string> kPresets = {"ultrafast", "superfast", "veryfast", "faster",
                                                 "fast",      "medium",    "slow",     "slower",
                                                 "veryslow",  "placebo"};
  k.Check(kPresets.count(cam.video_preset) != 0, "camera_config.video_preset",
          "must be an x264 preset (ultrafast ... placebo)");
  std::set<std::string> camera_names;
  for (size_t i = 0; i < cam.cameras.size(); ++i) {
    const CameraConfig& cc = cam.cameras[i];
    const std::string key = "camera_config.cameras[" + std::to_string(i) + "]";
    k.Check(!cc.name.empty(), key + ".name", "must not be empty");
    k.Check(camera_names.insert(cc.name).second, key + ".name",
            "duplicate camera name " + cc.name);
    k.Check(cc.fov > 0 && cc.fov < 180, key + ".fov", "must be in (0, 180) degrees");
    if (cc.type == CameraType::kMjcf) {
      k.Check(!cc.mjcf_name.empty(), key + ".mjcf_name", "an mjcf camera needs mjcf_name");
      k.Check(cc.reference_body_names.empty(), key + ".reference_body_names",
              "only for robot_mounted cameras");
    } else {
      k.Check(!cc.reference_body_names.empty(), key + ".reference_body_names",
              "a robot_mounted camera needs at least one reference body");
      k.Check(cc.mjcf_name.empty(), key + ".mjcf_name", "only for mjcf cameras");
      double q = 0;
      for (double v : cc.camera_quaternion) q += v * v;
      k.Check(std::fabs(std::sqrt(q) - 1.0) < 1e-3, key + ".camera_quaternion",
              "must have unit length (wxyz)");
    }
    for (const auto& [obj, fraction] : cc.visibility_constraints) {
      k.Check(fraction >= 0 && fraction <= 1, key + ".visibility_constraints." + obj,
              "must be in [0, 1]");
    }
  }

  const PolicyConfig& p = c.policy_config;
  const std::string pp = "policy_config.";
  k.Check(!p.policy_cls.empty(), pp + "policy_cls", "must not be empty");
  k.NonNegative(p.pregrasp_z_offset, pp + "pregrasp_z_offset");
  k.NonNegative(p.postgrasp_z_offset, pp + "postgrasp_z_offset");
  k.PositiveReal(p.speed_slow, pp + "speed_slow");
  k.PositiveReal(p.speed_fast, pp + "speed_fast");
  k.NonNegative(p.move_settle_time, pp + "move_settle_time");
  k.NonNegative(p.gripper_close_duration, pp + "gripper_close_duration");
  k.NonNegative(p.gripper_open_duration, pp + "gripper_open_duration");
  k.Check(p.max_retries >= 0, pp + "max_retries", "must be >= 0");
  k.NonNegative(p.gripper_empty_threshold, pp + "gripper_empty_threshold");
  k.PositiveReal(p.phase_timeout, pp + "phase_timeout");
  k.Positive(p.max_sequential_ik_failures, pp + "max_sequential_ik_failures");
  k.PositiveReal(p.tcp_pos_err_threshold, pp + "tcp_pos_err_threshold");
  k.PositiveReal(p.tcp_rot_err_threshold, pp + "tcp_rot_err_threshold");
  k.Positive(p.grasp_collision_batch_size, pp + "grasp_collision_batch_size");
  k.Positive(p.grasp_collision_max_grasps, pp + "grasp_collision_max_grasps");
  k.PositiveReal(p.grasp_width, pp + "grasp_width");
  k.PositiveReal(p.grasp_length, pp + "grasp_length");
  k.PositiveReal(p.grasp_height, pp + "grasp_height");
  k.NonNegative(p.grasp_cost_weights.pos, pp + "grasp_cost_weights.pos");
  k.NonNegative(p.grasp_cost_weights.rot, pp + "grasp_cost_weights.rot");
  k.NonNegative(p.grasp_cost_weights.vertical, pp + "grasp_cost_weights.vertical");
  k.NonNegative(p.grasp_cost_weights.com_dist, pp + "grasp_cost_weights.com_dist");
  k.Positive(p.grasp_feasibility_batch_size, pp + "grasp_feasibility_batch_size");
  k.Positive(p.grasp_feasibility_max_grasps, pp + "grasp_feasibility_max_grasps");
}

std::string DumpConfig(const ExperimentConfig& config) {
  Writer writer;
  writer.Struct(0, config);
  return writer.out;
}

uint64_t ConfigHash(const ExperimentConfig& config) { return HashString(DumpConfig(config)); }

std::string ConfigHashHex(const ExperimentConfig& config) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(ConfigHash(config)));
  return buf;
}

std::string DataConfigHashHex(const ExperimentConfig& config) {
  ExperimentConfig data = config;
  const ExperimentConfig defaults;
  data.output_dir = defaults.output_dir;
  data.log_level = defaults.log_level;
  data.num_workers = defaults.num_workers;
  data.profile = defaults.profile;
  return ConfigHashHex(data);
}

}  // namespace mlspaces::datagen
