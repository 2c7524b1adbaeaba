// A strict YAML <-> struct archive: one field description per struct drives strict loading,
// dotted-key overrides, the canonical dump and path resolution.
//
// A struct describes its fields by name, in order, either with a member
//
//     template <class A> void Serialize(A* a) { a->Visit("name", name); ... }
//
// or with a free `template <class A> void SerializeFields(A* a, T& value)` found by ADL (for
// types that must stay plain). Field types: bool, integers, floating point, std::string,
// std::filesystem::path (relative paths resolve against the file's folder), enums with a
// free `YamlEnumNames(E)` found by ADL (the YAML names in declaration order), std::optional
// (null clears), std::vector, std::array (exact length), std::map<std::string, T> and nested
// structs. A free `ReadYaml(const YamlReader&, const YAML::Node&, const std::string& key, T&)`
// found by ADL replaces the reading of a struct T (extra checks, other accepted forms).
//
// Reading is strict: unknown keys ("did you mean"), duplicate keys, wrong types and bad enum
// values are errors naming the file, the dotted key path and "line N".
#pragma once

#include "mlspaces/core/export.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "mlspaces/core/error.h"

namespace mlspaces {

// ---------------------------------------------------------------------------------------
// Small helpers (also used for other name lookups).

/// "did you mean 'x'?" for the candidates closest to `word` (case-insensitive edit distance
/// at most a third of the length, or a prefix match); empty when none is close.
MLSPACES_API std::string DidYouMean(std::string_view word,
                                    const std::vector<std::string>& candidates);
/// "a, b, c".
MLSPACES_API std::string JoinNames(const std::vector<std::string>& items);
/// "path.name" (or "name" at the top level).
MLSPACES_API std::string YamlChildKey(const std::string& path, std::string_view name);
/// "line N" of a node, empty when it has no mark.
MLSPACES_API std::string YamlLineOf(const YAML::Node& node);
/// "null", "a list", "a mapping" or the quoted scalar.
MLSPACES_API std::string DescribeYaml(const YAML::Node& node);
/// A double in shortest round-trip form (.nan, .inf, -.inf for the special values).
MLSPACES_API std::string FormatYamlDouble(double v);
/// A string as a plain YAML scalar where that reads back the same, else double-quoted.
MLSPACES_API std::string QuoteYamlString(std::string_view s);
/// Parses a YAML file. @throws Error "cannot open the <what>" or "invalid YAML: ..." with the
/// file and "line N".
MLSPACES_API YAML::Node LoadYamlFile(const std::filesystem::path& file, const std::string& what);
/// Parses YAML text (JSON is YAML too); `origin` names it in errors. @throws Error
/// "invalid YAML: ..." with `origin` and "line N".
MLSPACES_API YAML::Node LoadYamlString(std::string_view text, const std::string& origin);

// ---------------------------------------------------------------------------------------
// Type traits and field visiting.

namespace yaml_internal {

/// Collects field names (to check keys against).
struct MLSPACES_API NameCollector {
  std::vector<std::string> names;
  template <class T>
  void Visit(const char* name, T&) {
    names.emplace_back(name);
  }
};

template <class T>
concept HasSerialize = requires(T& t, NameCollector* a) {
  t.Serialize(a);
};
template <class T>
concept HasSerializeFields = requires(T& t, NameCollector* a) {
  SerializeFields(a, t);
};
template <class T>
concept IsEnum = std::is_enum_v<T> && requires(T e) {
  YamlEnumNames(e);
};

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

}  // namespace yaml_internal

/// A type the archive reads and writes as a mapping of named fields.
template <class T>
concept YamlStruct = yaml_internal::HasSerialize<T> || yaml_internal::HasSerializeFields<T>;

namespace yaml_internal {
template <class T>
struct IsStructVector : std::false_type {};
template <class T>
struct IsStructVector<std::vector<T>> : std::bool_constant<YamlStruct<T>> {};
}  // namespace yaml_internal

/// Calls a->Visit(name, field) for every field of `value`, in order.
template <class A, YamlStruct T>
void VisitYamlFields(A* a, T& value) {
  if constexpr (yaml_internal::HasSerialize<T>) {
    value.Serialize(a);
  } else {
    SerializeFields(a, value);
  }
}

/// The field names of T, in order.
template <YamlStruct T>
std::vector<std::string> YamlFieldNames() {
  yaml_internal::NameCollector c;
  T value{};
  VisitYamlFields(&c, value);
  return c.names;
}

// ---------------------------------------------------------------------------------------
// Reading.

/// Where values come from, for errors and relative paths.
struct MLSPACES_API YamlContext {
  YamlContext() = default;
  YamlContext(std::string file, std::filesystem::path base_dir, std::string usage_prefix = {})
      : file(std::move(file)),
        base_dir(std::move(base_dir)),
        usage_prefix(std::move(usage_prefix)) {}

  std::string file;                ///< for errors; empty for overrides
  std::filesystem::path base_dir;  ///< relative paths resolve against it (empty: kept)
  /// Non-empty: errors are UsageError("<usage_prefix><key>: <message>") without a line
  /// (command-line overrides, e.g. "--set ").
  std::string usage_prefix;
  /// A null std::vector reads as empty (else it is an error, as other nulls).
  bool null_lists_are_empty = false;
};

class YamlReader;

template <class T>
concept HasReadHook = requires(const YamlReader& r, const YAML::Node& n, const std::string& k,
                               T& t) {
  ReadYaml(r, n, k, t);
};

/// Reads YAML nodes into values strictly; see the file comment.
class MLSPACES_API YamlReader {
 public:
  explicit YamlReader(YamlContext ctx) : ctx_(std::move(ctx)) {}

  /// The context the reader was built with; valid while the reader lives.
  const YamlContext& context() const { return ctx_; }

  /// @throws Error "<key>: <message>" (key "top level" when empty) with the file and the
  /// node's line (an empty value's: its key's line), or UsageError (see YamlContext).
  [[noreturn]] void Fail(const YAML::Node& node, const std::string& key,
                         const std::string& message) const;

  /// Reads `node` into `out`; `key` is the dotted key path.
  template <class T>
  void Read(const YAML::Node& node, const std::string& key, T& out) const;

  /// Merges the keys of mapping `node` into struct `out` (fields absent from `node` keep
  /// their value); `extra` keys are allowed and skipped.
  template <YamlStruct T>
  void ReadStruct(const YAML::Node& node, const std::string& key, T& out,
                  const std::set<std::string>& extra = {}) const;

 private:
  void ReadBool(const YAML::Node& node, const std::string& key, bool& out) const;
  void ReadDouble(const YAML::Node& node, const std::string& key, double& out) const;
  void ReadString(const YAML::Node& node, const std::string& key, std::string& out) const;
  void ReadPath(const YAML::Node& node, const std::string& key, std::filesystem::path& out) const;
  /// The index of the node's scalar in `names`. @throws via Fail.
  size_t ReadEnumIndex(const YAML::Node& node, const std::string& key,
                       const std::vector<std::string>& names) const;
  /// Checks the keys of mapping `node` against `names` and `extra`.
  void CheckKeys(const YAML::Node& node, const std::string& key,
                 const std::vector<std::string>& names, const std::set<std::string>& extra) const;

  struct FieldReader {
    const YamlReader* reader;
    const YAML::Node* node;
    std::string key;
    template <class T>
    void Visit(const char* name, T& field) {
      for (const auto& kv : *node) {
        if (kv.first.Scalar() == name) {
          reader->key_line_ = YamlLineOf(kv.first);  // for empty values (see Fail)
          reader->Read(kv.second, YamlChildKey(key, name), field);
          return;
        }
      }
    }
  };

  YamlContext ctx_;
  mutable std::string key_line_;
};

template <class T>
void YamlReader::Read(const YAML::Node& node, const std::string& key, T& out) const {
  using namespace yaml_internal;
  if constexpr (std::is_same_v<T, bool>) {
    ReadBool(node, key, out);
  } else if constexpr (std::is_integral_v<T>) {
    const std::string s = node.IsScalar() && node.Tag() != "!" ? node.Scalar() : std::string();
    T value{};
    const char* first = s.data() + (s.starts_with('+') ? 1 : 0);
    const auto [ptr, ec] = std::from_chars(first, s.data() + s.size(), value);
    if (s.empty() || ec != std::errc() || ptr != s.data() + s.size()) {
      const bool range = ec == std::errc::result_out_of_range;
      Fail(node, key,
           std::string(range                 ? "integer out of range"
                       : std::is_signed_v<T> ? "expected an integer"
                                             : "expected a whole number >= 0") +
               ", got " + DescribeYaml(node));
    }
    out = value;
  } else if constexpr (std::is_floating_point_v<T>) {
    double value = 0;
    ReadDouble(node, key, value);
    out = static_cast<T>(value);
  } else if constexpr (std::is_same_v<T, std::string>) {
    ReadString(node, key, out);
  } else if constexpr (std::is_same_v<T, std::filesystem::path>) {
    ReadPath(node, key, out);
  } else if constexpr (IsEnum<T>) {
    const auto& names = YamlEnumNames(T{});
    out = static_cast<T>(ReadEnumIndex(node, key, {names.begin(), names.end()}));
  } else if constexpr (IsOptional<T>::value) {
    if (node.IsNull()) {
      out.reset();
      return;
    }
    if (!out.has_value()) out.emplace();
    Read(node, key, *out);
  } else if constexpr (IsVector<T>::value) {
    if (node.IsNull() && ctx_.null_lists_are_empty) {
      out.clear();
      return;
    }
    if (!node.IsSequence()) Fail(node, key, "expected a list, got " + DescribeYaml(node));
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
                                  : DescribeYaml(node)));
    }
    T items{};
    for (size_t i = 0; i < n; ++i) Read(node[i], key + "[" + std::to_string(i) + "]", items[i]);
    out = items;
  } else if constexpr (IsMap<T>::value) {
    if (!node.IsMap()) Fail(node, key, "expected a mapping, got " + DescribeYaml(node));
    T items;
    for (const auto& kv : node) {
      if (!kv.first.IsScalar() || kv.first.Scalar().empty()) {
        Fail(kv.first, key, "keys must be non-empty strings");
      }
      const std::string name = kv.first.Scalar();
      if (items.count(name)) Fail(kv.first, YamlChildKey(key, name), "duplicate key");
      Read(kv.second, YamlChildKey(key, name), items[name]);
    }
    out = std::move(items);
  } else if constexpr (HasReadHook<T>) {
    ReadYaml(*this, node, key, out);
  } else {
    static_assert(YamlStruct<T>, "a type the YAML archive cannot read");
    ReadStruct(node, key, out);
  }
}

template <YamlStruct T>
void YamlReader::ReadStruct(const YAML::Node& node, const std::string& key, T& out,
                            const std::set<std::string>& extra) const {
  CheckKeys(node, key, YamlFieldNames<T>(), extra);
  FieldReader fields{this, &node, key};
  VisitYamlFields(&fields, out);
}

// ---------------------------------------------------------------------------------------
// Dotted-key overrides ("a.b.c" = YAML value).

/// Sets the field at the dotted key `parts` inside `target` to `value`, read with `reader`'s
/// strictness. Unknown keys, bad list indices and keys below single values are UsageErrors
/// "<usage_prefix><key>: ...".
template <class T>
void SetYamlKey(const YamlReader& reader, T& target, const std::vector<std::string>& parts,
                const YAML::Node& value);

namespace yaml_internal {

[[noreturn]] MLSPACES_API void ThrowUnknownKey(const std::string& prefix, const std::string& key,
                                               const std::string& part,
                                               const std::vector<std::string>& names);
[[noreturn]] MLSPACES_API void ThrowBadIndex(const std::string& prefix, const std::string& key,
                                             const std::string& part, size_t size);
[[noreturn]] MLSPACES_API void ThrowNoKeys(const std::string& prefix, const std::string& key,
                                           const std::string& part);
/// The list index in `part`, or SIZE_MAX.
MLSPACES_API size_t ParseIndex(const std::string& part);

template <class T>
void Set(const YamlReader& reader, const YAML::Node& value, T& target,
         const std::vector<std::string>& parts, size_t i, const std::string& done);

struct MLSPACES_API Descender {
  const YamlReader* reader;
  const YAML::Node* value;
  const std::vector<std::string>* parts;
  size_t i;
  std::string done;
  bool matched = false;
  template <class T>
  void Visit(const char* name, T& field) {
    if (matched || (*parts)[i] != name) return;
    matched = true;
    Set(*reader, *value, field, *parts, i + 1, YamlChildKey(done, name));
  }
};

template <class T>
void Set(const YamlReader& reader, const YAML::Node& value, T& target,
         const std::vector<std::string>& parts, size_t i, const std::string& done) {
  const std::string& prefix = reader.context().usage_prefix;
  if (i == parts.size()) {
    reader.Read(value, done, target);
    return;
  }
  const std::string& part = parts[i];
  if constexpr (YamlStruct<T>) {
    Descender d{&reader, &value, &parts, i, done};
    VisitYamlFields(&d, target);
    if (!d.matched) ThrowUnknownKey(prefix, done, part, YamlFieldNames<T>());
  } else if constexpr (IsOptional<T>::value) {
    if (!target.has_value()) target.emplace();
    Set(reader, value, *target, parts, i, done);
  } else if constexpr (IsMap<T>::value) {
    Set(reader, value, target[part], parts, i + 1, YamlChildKey(done, part));
  } else if constexpr (IsVector<T>::value || IsArray<T>::value) {
    const size_t index = ParseIndex(part);
    if (index >= target.size()) ThrowBadIndex(prefix, done, part, target.size());
    Set(reader, value, target[index], parts, i + 1, done + "[" + part + "]");
  } else {
    ThrowNoKeys(prefix, done, part);
  }
}

}  // namespace yaml_internal

template <class T>
void SetYamlKey(const YamlReader& reader, T& target, const std::vector<std::string>& parts,
                const YAML::Node& value) {
  yaml_internal::Set(reader, value, target, parts, 0, "");
}

// ---------------------------------------------------------------------------------------
// Writing: the canonical dump.

/// Writes structs as block YAML: every field in declaration order, scalars and lists of
/// scalars inline, numbers in shortest round-trip form.
class MLSPACES_API YamlWriter {
 public:
  std::string out;

  /// The inline form of a scalar or a sequence of scalars.
  template <class T>
  static std::string Inline(const T& value);

  /// Writes `key: value` at `indent`.
  template <class T>
  void Field(int indent, const std::string& key, const T& value);

  /// Writes the fields of `value` at `indent`.
  template <YamlStruct T>
  void Struct(int indent, const T& value) {
    FieldWriter w{this, indent};
    VisitYamlFields(&w, const_cast<T&>(value));
  }

 private:
  struct FieldWriter {
    YamlWriter* writer;
    int indent;
    template <class T>
    void Visit(const char* name, T& field) {
      writer->Field(indent, name, field);
    }
  };
};

template <class T>
std::string YamlWriter::Inline(const T& value) {
  using namespace yaml_internal;
  if constexpr (std::is_same_v<T, bool>) {
    return value ? "true" : "false";
  } else if constexpr (std::is_integral_v<T>) {
    return std::to_string(value);
  } else if constexpr (std::is_floating_point_v<T>) {
    return FormatYamlDouble(value);
  } else if constexpr (std::is_same_v<T, std::string>) {
    return QuoteYamlString(value);
  } else if constexpr (std::is_same_v<T, std::filesystem::path>) {
    return QuoteYamlString(value.generic_string());
  } else if constexpr (IsEnum<T>) {
    return std::string(YamlEnumNames(value)[static_cast<size_t>(value)]);
  } else if constexpr (IsOptional<T>::value) {
    return value.has_value() ? Inline(*value) : "null";
  } else {
    static_assert(IsVector<T>::value || IsArray<T>::value);
    std::string s = "[";
    for (size_t i = 0; i < value.size(); ++i) s += (i ? ", " : "") + Inline(value[i]);
    return s + "]";
  }
}

template <class T>
void YamlWriter::Field(int indent, const std::string& key, const T& value) {
  using namespace yaml_internal;
  const std::string pad(indent, ' ');
  if constexpr (IsOptional<T>::value) {
    if (!value.has_value()) {
      out += pad + key + ": null\n";
    } else {
      Field(indent, key, *value);
    }
  } else if constexpr (YamlStruct<T>) {
    out += pad + key + ":\n";
    Struct(indent + 2, value);
  } else if constexpr (IsMap<T>::value) {
    if (value.empty()) {
      out += pad + key + ": {}\n";
      return;
    }
    out += pad + key + ":\n";
    for (const auto& [k, v] : value) Field(indent + 2, QuoteYamlString(k), v);
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

/// The canonical YAML of a struct (see YamlWriter).
template <YamlStruct T>
std::string DumpYaml(const T& value) {
  YamlWriter writer;
  writer.Struct(0, value);
  return writer.out;
}

// ---------------------------------------------------------------------------------------
// Path resolution.

/// Replaces every non-empty std::filesystem::path inside `value` (struct fields, optionals,
/// vectors, arrays and map values, recursively) by `map(path)`.
template <class T, class F>
void MapYamlPaths(T& value, const F& map);

namespace yaml_internal {
template <class F>
struct PathMapper {
  const F* map;
  template <class T>
  void Visit(const char*, T& field) {
    MapYamlPaths(field, *map);
  }
};
}  // namespace yaml_internal

template <class T, class F>
void MapYamlPaths(T& value, const F& map) {
  using namespace yaml_internal;
  if constexpr (std::is_same_v<T, std::filesystem::path>) {
    if (!value.empty()) value = map(std::as_const(value));
  } else if constexpr (IsOptional<T>::value) {
    if (value.has_value()) MapYamlPaths(*value, map);
  } else if constexpr (IsVector<T>::value || IsArray<T>::value) {
    for (auto& item : value) MapYamlPaths(item, map);
  } else if constexpr (IsMap<T>::value) {
    for (auto& [k, v] : value) MapYamlPaths(v, map);
  } else if constexpr (YamlStruct<T>) {
    PathMapper<F> mapper{&map};
    VisitYamlFields(&mapper, value);
  }
}

/// Makes every non-empty relative std::filesystem::path inside `value` absolute against
/// `base` (lexically normalised).
template <class T>
void ResolveYamlPaths(T& value, const std::filesystem::path& base) {
  MapYamlPaths(value, [&base](const std::filesystem::path& p) {
    return p.is_relative() ? (base / p).lexically_normal() : p;
  });
}

}  // namespace mlspaces
