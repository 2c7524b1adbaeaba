// The pure parts of MolmoSpaces-format sources (molmo_remote.h): behaviours, archive indexes,
// the tries and size-manifest readers, scene references.
#include <zlib.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <pugixml.hpp>
#include <set>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/resources/molmo_remote.h"

namespace mlspaces {
namespace fs = std::filesystem;

// =============================================================================================
// Behaviours

SourceBehavior ResolveSourceBehavior(const std::string& type, const std::string& source) {
  SourceBehavior b;
  if (type == "objects" || type == "grasps") {
    b = {LinkStrategy::kGlobal, InstallMode::kOnDemand, ArchiveIndexKind::kSubstring};
  } else if (type == "scenes") {
    b = {LinkStrategy::kPerFile, InstallMode::kOnDemand, ArchiveIndexKind::kNumeric};
  } else if (type == "robots") {
    b = {LinkStrategy::kPerFile, InstallMode::kEager, ArchiveIndexKind::kNone};
  } else if (type == "test_data" || type == "benchmarks" || type == "textures") {
    b = {LinkStrategy::kGlobal, InstallMode::kEager, ArchiveIndexKind::kNone};
  } else if (type == "franka-rby1-training-data") {
    b = {LinkStrategy::kGlobal, InstallMode::kOnDemand, ArchiveIndexKind::kNumeric};
  } else {
    throw Error("no behaviour for data type '" + type +
                "' (known: benchmarks, franka-rby1-training-data, grasps, objects, robots, "
                "scenes, test_data, textures)");
  }
  if ((type == "objects" && (source == "thor" || source == "objathor_metadata")) ||
      (type == "grasps" && (source == "droid" || source == "rum"))) {
    b.mode = InstallMode::kEager;
  }
  if (type == "robots" && source == "humans_rocketbox") {
    b.mode = InstallMode::kOnDemand;
    b.index = ArchiveIndexKind::kSubstring;
  }
  return b;
}

// =============================================================================================
// Tokens and indexes

namespace {

bool IsDelimiter(char c) {
  return c == '.' || c == '/' || c == '_' || c == ' ' || c == '\t' || c == '\n' || c == '\r' ||
         c == '\f' || c == '\v';
}

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

constexpr std::string_view kTarZst = ".tar.zst";

/// Python's str.replace(".tar.zst", "") on an archive name.
std::string WithoutTarZst(std::string_view name) {
  std::string out;
  size_t pos = 0;
  for (;;) {
    const size_t hit = name.find(kTarZst, pos);
    if (hit == std::string_view::npos) break;
    out.append(name.substr(pos, hit - pos));
    pos = hit + kTarZst.size();
  }
  out.append(name.substr(pos));
  return out;
}

}  // namespace

std::vector<std::string> SplitQueryTokens(std::string_view text) {
  std::vector<std::string> out;
  size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && IsDelimiter(text[i])) ++i;
    const size_t start = i;
    while (i < text.size() && !IsDelimiter(text[i])) ++i;
    if (i > start) out.emplace_back(text.substr(start, i - start));
  }
  return out;
}

std::vector<std::string> NumericTokens(std::string_view text) {
  std::vector<std::string> out;
  size_t i = 0;
  while (i < text.size()) {
    // -?\d+ scanned left to right, as re.findall does.
    if (IsDigit(text[i]) || (text[i] == '-' && i + 1 < text.size() && IsDigit(text[i + 1]))) {
      const size_t start = i;
      if (text[i] == '-') ++i;
      while (i < text.size() && IsDigit(text[i])) ++i;
      out.emplace_back(text.substr(start, i - start));
    } else {
      ++i;
    }
  }
  return out;
}

ArchiveIndex::ArchiveIndex(ArchiveIndexKind kind, std::span<const std::string> archives)
    : kind_(kind), names_(archives.begin(), archives.end()) {
  if (kind_ == ArchiveIndexKind::kNone) return;
  for (uint32_t i = 0; i < names_.size(); ++i) {
    const std::vector<std::string> tokens = kind_ == ArchiveIndexKind::kSubstring
                                                ? SplitQueryTokens(WithoutTarZst(names_[i]))
                                                : NumericTokens(names_[i]);
    for (const std::string& t : tokens) {
      std::vector<uint32_t>& bucket = buckets_[t];
      if (bucket.empty() || bucket.back() != i) bucket.push_back(i);
    }
  }
}

std::vector<std::string> ArchiveIndex::QueryToken(std::string_view token) const {
  std::vector<std::string> out;
  auto it = buckets_.find(std::string(token));
  if (it == buckets_.end()) return out;
  for (uint32_t i : it->second) out.push_back(names_[i]);
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::string> ArchiveIndex::Candidates(std::string_view query,
                                                  size_t max_returns) const {
  if (kind_ == ArchiveIndexKind::kNone) return {};
  const std::vector<std::string> tokens =
      kind_ == ArchiveIndexKind::kSubstring ? SplitQueryTokens(query) : NumericTokens(query);
  std::set<std::string> hits;
  for (const std::string& t : tokens) {
    auto it = buckets_.find(t);
    if (it == buckets_.end() || it->second.size() > max_returns) continue;  // ambiguous
    for (uint32_t i : it->second) hits.insert(names_[i]);
  }
  return {hits.begin(), hits.end()};
}

std::vector<std::string> ArchiveIndex::Unindexed(std::span<const std::string> archives) const {
  std::set<std::string> indexed;
  for (const auto& [token, bucket] : buckets_) {
    for (uint32_t i : bucket) indexed.insert(names_[i]);
  }
  std::set<std::string> out;
  for (const std::string& a : archives) {
    if (indexed.count(a) == 0) out.insert(a);
  }
  return {out.begin(), out.end()};
}

// =============================================================================================
// Gzip, tries, size manifest

namespace {

/// Biggest JSON we inflate: far above the real files (tens of MB), low enough that a
/// decompression bomb is an Error rather than an allocation failure.
constexpr size_t kMaxInflated = size_t{8} << 30;

bool HasGzipMagic(const unsigned char* p, size_t n) {
  return n >= 2 && p[0] == 0x1f && p[1] == 0x8b;
}

}  // namespace

std::optional<std::string_view> BadPathComponent(std::string_view key) {
  size_t start = 0;
  for (;;) {
    const size_t slash = key.find('/', start);
    const std::string_view c =
        key.substr(start, slash == std::string_view::npos ? std::string_view::npos : slash - start);
    if (c.empty() || c == "." || c == ".." || c.find('\0') != std::string_view::npos) return c;
    if (slash == std::string_view::npos) return std::nullopt;
    start = slash + 1;
  }
}

std::string InflateGzip(const std::string& data, const std::string& origin) {
  const auto* in = reinterpret_cast<const unsigned char*>(data.data());
  if (!HasGzipMagic(in, data.size())) {
    throw Error("not a gzip file (it does not start with the gzip magic bytes 1f 8b)", origin);
  }
  if (data.size() > UINT_MAX) throw Error("file over 4 GiB, too large for a tries file", origin);
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 16) != Z_OK) throw Error("zlib: cannot start inflating", origin);
  struct End {
    z_stream* z;
    ~End() { inflateEnd(z); }
  } end{&zs};
  zs.next_in = const_cast<Bytef*>(in);
  zs.avail_in = static_cast<uInt>(data.size());
  std::string out(std::min(kMaxInflated, std::max<size_t>(data.size() * 8, 1 << 16)), '\0');
  size_t produced = 0;
  for (;;) {
    if (produced == out.size()) {
      if (out.size() >= kMaxInflated) {
        throw Error("inflates to more than " + std::to_string(kMaxInflated >> 30) +
                        " GiB, too large for a tries file",
                    origin);
      }
      out.resize(std::min(kMaxInflated, out.size() * 2));
    }
    const size_t room = std::min<size_t>(out.size() - produced, UINT_MAX);
    zs.next_out = reinterpret_cast<Bytef*>(out.data() + produced);
    zs.avail_out = static_cast<uInt>(room);
    const int rc = inflate(&zs, Z_NO_FLUSH);
    produced += room - zs.avail_out;
    if (rc == Z_STREAM_END) {
      if (zs.avail_in == 0) break;
      if (!HasGzipMagic(zs.next_in, zs.avail_in)) {
        throw Error("trailing bytes after the gzip stream", origin);
      }
      if (inflateReset(&zs) != Z_OK) throw Error("zlib: cannot inflate the next member", origin);
      continue;
    }
    if (rc == Z_OK) continue;
    if (rc == Z_BUF_ERROR && zs.avail_out == 0) continue;  // needs more room
    if (rc == Z_BUF_ERROR) throw Error("truncated gzip stream", origin);
    throw Error(std::string("corrupt gzip stream: ") + (zs.msg != nullptr ? zs.msg : "zlib error"),
                origin);
  }
  out.resize(produced);
  return out;
}

SourceTries ParseTries(const std::string& gzip_bytes, const std::string& origin) {
  const FlatJson root = ParseFlatJson(InflateGzip(gzip_bytes, origin), origin);
  if (!root.is_object()) {
    throw Error(
        "expected an object {archive name: trie} at the top level, got " + JsonTypeName(root),
        origin);
  }
  SourceTries out;
  for (auto it = root.cbegin(); it != root.cend(); ++it) {  // sorted keys
    const std::string& archive = it.key();
    if (archive.empty()) throw Error("empty archive name", origin, "/");
    if (!it->is_object()) {
      throw Error("expected object (the archive's trie), got " + JsonTypeName(*it), origin,
                  "/" + JsonPointerToken(archive));
    }
    out.archives.push_back(archive);
    std::vector<std::string>& files = out.files.emplace_back();
    // Iterative walk: no recursion on untrusted depth.
    struct Frame {
      FlatJson::const_iterator it, end;
      std::string prefix;  // folder path of the node, '/'-terminated or empty
      std::string pointer;
    };
    std::vector<Frame> stack;
    stack.push_back({it->cbegin(), it->cend(), "", "/" + JsonPointerToken(archive)});
    while (!stack.empty()) {
      Frame& f = stack.back();
      if (f.it == f.end) {
        stack.pop_back();
        continue;
      }
      const std::string& key = f.it.key();
      const FlatJson& value = *f.it;
      ++f.it;
      const std::string pointer = f.pointer + "/" + JsonPointerToken(key);
      if (auto bad = BadPathComponent(key)) {
        throw Error("bad path component '" + std::string(*bad) + "' in trie key '" + key +
                        "' (components must be non-empty and not '.' or '..')",
                    origin, pointer);
      }
      if (!value.is_object()) {
        throw Error("expected object (a folder, or {} for a file), got " + JsonTypeName(value),
                    origin, pointer);
      }
      std::string path = f.prefix + key;
      if (value.empty()) {
        files.push_back(std::move(path));
      } else {
        path += '/';
        stack.push_back({value.cbegin(), value.cend(), std::move(path), pointer});
      }
    }
    std::sort(files.begin(), files.end());
    files.erase(std::unique(files.begin(), files.end()), files.end());
  }
  for (uint32_t a = 0; a < out.files.size(); ++a) {
    for (const std::string& f : out.files[a]) out.owner.emplace(f, a);
  }
  return out;
}

SourceTries ReadTries(const fs::path& file) {
  if (!IsFile(file)) throw Error("missing tries file", file.string());
  return ParseTries(ReadFile(file), file.string());
}

std::optional<uint32_t> SourceTries::Find(std::string_view archive) const {
  auto it = std::lower_bound(archives.begin(), archives.end(), archive);
  if (it == archives.end() || *it != archive) return std::nullopt;
  return static_cast<uint32_t>(it - archives.begin());
}

std::optional<uint32_t> SourceTries::ArchiveOf(std::string_view path) const {
  auto it = owner.find(std::string(path));
  if (it == owner.end()) return std::nullopt;
  return it->second;
}

std::map<std::string, double> ParseSizeManifest(const std::string& text,
                                                const std::string& origin) {
  const Json doc = ParseJson(text, origin);
  if (!doc.is_object()) {
    throw Error("expected an object {archive: size in MB}, got " + JsonTypeName(doc), origin);
  }
  std::map<std::string, double> out;
  for (auto it = doc.begin(); it != doc.end(); ++it) {
    const std::string pointer = "/" + JsonPointerToken(it.key());
    if (!it->is_number() || !std::isfinite(it->get<double>()) || it->get<double>() < 0) {
      throw Error("expected a size in MB (a non-negative number), got " + JsonTypeName(*it), origin,
                  pointer);
    }
    const std::string& name = it.key();
    if (BadPathComponent(name)) {  // empty, '/'-rooted, '.' or '..' components
      throw Error("bad archive name '" + name + "'", origin, pointer);
    }
    out.emplace(name, it->get<double>());
  }
  return out;
}

// =============================================================================================
// Scenes

std::vector<SceneObjectRef> FindSceneObjectRefs(const fs::path& scene_xml,
                                                const fs::path& assets_dir) {
  const std::string text = ReadFile(scene_xml);
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed = doc.load_buffer(text.data(), text.size());
  if (!parsed) {
    throw Error(std::string("malformed XML: ") + parsed.description() + " at byte " +
                    std::to_string(parsed.offset),
                scene_xml.string());
  }
  const fs::path assets = assets_dir.lexically_normal();
  const fs::path folder = scene_xml.parent_path();
  std::set<std::pair<std::string, std::string>> found;
  static const std::set<std::string> kKinds = {"mesh", "texture", "material", "hfield", "skin"};
  for (const pugi::xpath_node& asset : doc.select_nodes("//asset")) {
    for (const pugi::xml_node& child : asset.node().children()) {
      if (kKinds.count(child.name()) == 0) continue;
      const std::string file = child.attribute("file").as_string();
      if (file.rfind("../", 0) != 0) continue;
      const fs::path resolved = (folder / file).lexically_normal();
      const fs::path rel = resolved.lexically_relative(assets);
      auto part = rel.begin();
      if (rel.empty() || part == rel.end() || *part != "objects") continue;
      if (++part == rel.end()) continue;
      const std::string source = part->string();
      if (source == "..") continue;
      fs::path inside;
      for (++part; part != rel.end(); ++part) inside /= *part;
      if (inside.empty()) continue;
      found.emplace(source, inside.generic_string());
    }
  }
  std::vector<SceneObjectRef> out;
  out.reserve(found.size());
  for (const auto& [source, path] : found) out.push_back({source, path});
  return out;
}

}  // namespace mlspaces
