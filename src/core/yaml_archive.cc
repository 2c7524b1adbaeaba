// The non-template parts of the strict YAML archive: scalar parsing, key checks, errors,
// formatting.
#include "mlspaces/core/yaml_archive.h"

#include <cctype>
#include <cstdio>
#include <limits>

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

std::string Lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

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

bool IsPlainScalar(const YAML::Node& node) { return node.IsScalar() && node.Tag() != "!"; }

}  // namespace

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

std::string JoinNames(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

std::string YamlChildKey(const std::string& path, std::string_view name) {
  return path.empty() ? std::string(name) : path + "." + std::string(name);
}

std::string YamlLineOf(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  if (mark.is_null()) return {};
  return "line " + std::to_string(mark.line + 1);
}

std::string DescribeYaml(const YAML::Node& node) {
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

std::string FormatYamlDouble(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  char buf[64];
  const auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
  (void)ec;
  return std::string(buf, ptr);
}

std::string QuoteYamlString(std::string_view s) {
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

YAML::Node LoadYamlFile(const fs::path& file, const std::string& what) {
  try {
    return YAML::LoadFile(file.string());
  } catch (const YAML::BadFile&) {
    throw Error("cannot open the " + what, file.string());
  } catch (const YAML::ParserException& e) {
    throw Error("invalid YAML: " + e.msg, file.string(),
                e.mark.is_null() ? std::string() : "line " + std::to_string(e.mark.line + 1));
  }
}

YAML::Node LoadYamlString(std::string_view text, const std::string& origin) {
  try {
    return YAML::Load(std::string(text));
  } catch (const YAML::ParserException& e) {
    throw Error("invalid YAML: " + e.msg, origin,
                e.mark.is_null() ? std::string() : "line " + std::to_string(e.mark.line + 1));
  }
}

// ---------------------------------------------------------------------------------------
// YamlReader.

void YamlReader::Fail(const YAML::Node& node, const std::string& key,
                      const std::string& message) const {
  const std::string what = (key.empty() ? "top level" : key) + ": " + message;
  if (!ctx_.usage_prefix.empty()) throw UsageError(ctx_.usage_prefix + what);
  // An empty value's mark points past its key (often to the next line): use the key's.
  const std::string line = YamlLineOf(node);
  throw Error(what, ctx_.file, line.empty() || node.IsNull() ? key_line_ : line);
}

void YamlReader::ReadBool(const YAML::Node& node, const std::string& key, bool& out) const {
  static const std::set<std::string> kTrue{"true", "True", "TRUE"};
  static const std::set<std::string> kFalse{"false", "False", "FALSE"};
  if (IsPlainScalar(node) && kTrue.count(node.Scalar())) {
    out = true;
  } else if (IsPlainScalar(node) && kFalse.count(node.Scalar())) {
    out = false;
  } else {
    Fail(node, key, "expected true or false, got " + DescribeYaml(node));
  }
}

void YamlReader::ReadDouble(const YAML::Node& node, const std::string& key, double& out) const {
  const std::string s = IsPlainScalar(node) ? node.Scalar() : std::string();
  static const std::map<std::string, double> kSpecial{
      {".inf", HUGE_VAL},   {".Inf", HUGE_VAL}, {"+.inf", HUGE_VAL}, {"-.inf", -HUGE_VAL},
      {"-.Inf", -HUGE_VAL}, {".nan", NAN},      {".NaN", NAN}};
  if (auto it = kSpecial.find(s); it != kSpecial.end()) {
    out = it->second;
    return;
  }
  double value = 0;
  const char* first = s.data() + (s.starts_with('+') ? 1 : 0);
  const auto [ptr, ec] = std::from_chars(first, s.data() + s.size(), value);
  if (s.empty() || ec != std::errc() || ptr != s.data() + s.size()) {
    Fail(node, key, "expected a number, got " + DescribeYaml(node));
  }
  out = value;
}

void YamlReader::ReadString(const YAML::Node& node, const std::string& key,
                            std::string& out) const {
  if (!node.IsScalar()) Fail(node, key, "expected a string, got " + DescribeYaml(node));
  out = node.Scalar();
}

void YamlReader::ReadPath(const YAML::Node& node, const std::string& key, fs::path& out) const {
  if (!node.IsScalar() || node.Scalar().empty()) {
    Fail(node, key, "expected a path, got " + DescribeYaml(node));
  }
  fs::path p(node.Scalar());
  out = p.is_absolute() || ctx_.base_dir.empty() ? p : (ctx_.base_dir / p).lexically_normal();
}

size_t YamlReader::ReadEnumIndex(const YAML::Node& node, const std::string& key,
                                 const std::vector<std::string>& names) const {
  if (node.IsScalar()) {
    for (size_t i = 0; i < names.size(); ++i) {
      if (names[i] == node.Scalar()) return i;
    }
  }
  const std::string hint = node.IsScalar() ? DidYouMean(node.Scalar(), names) : "";
  Fail(node, key,
       "expected one of " + JoinNames(names) + ", got " + DescribeYaml(node) +
           (hint.empty() ? "" : " (" + hint + ")"));
}

void YamlReader::CheckKeys(const YAML::Node& node, const std::string& key,
                           const std::vector<std::string>& names,
                           const std::set<std::string>& extra) const {
  if (!node.IsMap()) Fail(node, key, "expected a mapping, got " + DescribeYaml(node));
  std::set<std::string> seen;
  for (const auto& kv : node) {
    if (!kv.first.IsScalar()) Fail(kv.first, key, "keys must be strings");
    const std::string name = kv.first.Scalar();
    if (!seen.insert(name).second) Fail(kv.first, YamlChildKey(key, name), "duplicate key");
    if (extra.count(name)) continue;
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      const std::string hint = DidYouMean(name, names);
      Fail(kv.first, YamlChildKey(key, name),
           "unknown key (" + (hint.empty() ? "" : hint + " ") + "valid keys: " + JoinNames(names) +
               ")");
    }
  }
}

// ---------------------------------------------------------------------------------------
// Overrides.

namespace yaml_internal {

void ThrowUnknownKey(const std::string& prefix, const std::string& key, const std::string& part,
                     const std::vector<std::string>& names) {
  const std::string hint = DidYouMean(part, names);
  throw UsageError(prefix + YamlChildKey(key, part) + ": unknown key (" +
                   (hint.empty() ? "" : hint + " ") + "valid keys: " + JoinNames(names) + ")");
}

void ThrowBadIndex(const std::string& prefix, const std::string& key, const std::string& part,
                   size_t size) {
  throw UsageError(prefix + key + ": '" + part + "' is not an index of this list (" +
                   std::to_string(size) + " items)");
}

void ThrowNoKeys(const std::string& prefix, const std::string& key, const std::string& part) {
  throw UsageError(prefix + key + ": is a single value, it has no key '" + part + "'");
}

size_t ParseIndex(const std::string& part) {
  size_t index = 0;
  const auto [ptr, ec] = std::from_chars(part.data(), part.data() + part.size(), index);
  if (part.empty() || ec != std::errc() || ptr != part.data() + part.size()) {
    return std::numeric_limits<size_t>::max();
  }
  return index;
}

}  // namespace yaml_internal
}  // namespace mlspaces
