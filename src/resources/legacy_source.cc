// The tries of a MolmoSpaces-format source -> our UID index (see legacy_source.h).
#include "mlspaces/resources/legacy_source.h"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <optional>
#include <string_view>
#include <tuple>
#include <unordered_map>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/library/packed_store.h"
#include "mlspaces/resources/molmo_remote.h"
#include "mlspaces/resources/package.h"
#include "mlspaces/resources/packed_store_writer.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

/// An .xml leaf: an asset candidate.
struct Candidate {
  std::string uid;
  uint32_t archive = 0;
  std::string path;
};

/// JSON pointer of `archive` / keys... / `last`.
std::string Pointer(const std::string& archive, const std::vector<const std::string*>& keys,
                    const std::string* last) {
  std::string p = "/" + JsonPointerToken(archive);
  for (const std::string* k : keys) p += "/" + JsonPointerToken(*k);
  if (last != nullptr) p += "/" + JsonPointerToken(*last);
  return p;
}

/// Walks one archive's trie (iteratively: no recursion on untrusted depth), appending its
/// .xml leaves to `out`. @throws Error with the JSON pointer of a bad node or key.
void WalkTrie(const FlatJson& trie, const std::string& archive, uint32_t archive_index,
              const std::string& file, std::vector<Candidate>& out,
              std::vector<Diagnostic>& warnings) {
  struct Frame {
    FlatJson::const_iterator it, end;
    size_t prefix_len;  ///< length of `rel` for this node (its folder path)
  };
  std::vector<Frame> stack;
  std::vector<const std::string*> keys;  // key of each frame but the root, for pointers
  std::string rel;
  stack.push_back({trie.cbegin(), trie.cend(), 0});
  while (!stack.empty()) {
    Frame& f = stack.back();
    if (f.it == f.end) {
      stack.pop_back();
      if (!keys.empty()) keys.pop_back();
      continue;
    }
    const std::string& key = f.it.key();
    const FlatJson& value = *f.it;
    ++f.it;
    if (auto bad = BadPathComponent(key)) {
      throw Error("bad path component '" + std::string(*bad) + "' in trie key '" + key +
                      "' (components must be non-empty and not '.' or '..')",
                  file, Pointer(archive, keys, &key));
    }
    if (!value.is_object()) {
      throw Error("expected object (a folder, or {} for a file), got " + JsonTypeWord(value), file,
                  Pointer(archive, keys, &key));
    }
    rel.resize(f.prefix_len);
    if (!rel.empty()) rel += '/';
    rel += key;
    if (!value.empty()) {
      const size_t len = rel.size();
      keys.push_back(&key);
      stack.push_back({value.cbegin(), value.cend(), len});  // `f` is invalid from here
      continue;
    }
    constexpr std::string_view kXml = ".xml";
    if (rel.size() < kXml.size() || rel.compare(rel.size() - kXml.size(), kXml.size(), kXml) != 0) {
      continue;
    }
    const size_t slash = rel.rfind('/');
    const size_t name_start = slash == std::string::npos ? 0 : slash + 1;
    if (rel.size() - name_start == kXml.size()) {
      warnings.emplace_back(archive, rel, "a file named only \".xml\" has no UID; ignored", "",
                            Severity::kWarning);
      continue;
    }
    out.push_back(
        {rel.substr(name_start, rel.size() - name_start - kXml.size()), archive_index, rel});
  }
}

}  // namespace

std::string LegacyWarningLine(const Diagnostic& warning) {
  if (warning.uid.empty()) return warning.ToString();
  return "duplicate UID " + warning.uid + ": " + warning.path + ": " + warning.field + " " +
         warning.message;
}

LegacyIndexReport BuildLegacyIndex(const fs::path& version_dir, const std::string& name) {
  const fs::path tries_path = version_dir / std::string(kTriesFile);
  const std::string file = tries_path.string();
  std::error_code ec;
  if (!fs::exists(tries_path, ec)) {
    throw Error(
        "no MolmoSpaces tries file (is this a source version folder of the original's "
        "resource manager?)",
        file);
  }
  if (!IsFile(tries_path)) throw Error("not a regular file", file);
  const FlatJson root = [&] {
    const std::string json = InflateGzip(ReadFile(tries_path), file);
    return ParseFlatJson(json, file);
  }();
  if (!root.is_object()) {
    throw Error(
        "expected an object {archive name: trie} at the top level, got " + JsonTypeWord(root),
        file);
  }
  if (root.size() > UINT32_MAX) throw Error("too many archives for one index", file);

  LegacyIndexReport report;
  std::vector<std::string> archives;
  archives.reserve(root.size());
  std::vector<Candidate> candidates;
  // std::map order: archive names sorted bytewise.
  for (auto it = root.cbegin(); it != root.cend(); ++it) {
    const std::string& archive = it.key();
    const FlatJson& trie = *it;
    if (archive.empty()) throw Error("empty archive name", file, "/");
    if (!trie.is_object()) {
      throw Error("expected object (the archive's trie), got " + JsonTypeWord(trie), file,
                  "/" + JsonPointerToken(archive));
    }
    const auto index = static_cast<uint32_t>(archives.size());
    archives.push_back(archive);
    WalkTrie(trie, archive, index, file, candidates, report.warnings);
  }

  // The first in (archive name, path) order wins; the others are warnings.
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.archive, a.path) < std::tie(b.archive, b.path);
  });
  std::unordered_map<std::string_view, size_t> winner;
  winner.reserve(candidates.size());
  std::vector<size_t> kept;
  kept.reserve(candidates.size());
  for (size_t i = 0; i < candidates.size(); ++i) {
    const Candidate& c = candidates[i];
    auto [it, inserted] = winner.emplace(c.uid, i);
    if (inserted) {
      kept.push_back(i);
      continue;
    }
    const Candidate& w = candidates[it->second];
    if (w.archive == c.archive && w.path == c.path) continue;  // one file listed twice
    report.warnings.emplace_back(archives[c.archive], c.path,
                                 "is ignored; " + archives[w.archive] + ": " + w.path + " wins",
                                 c.uid, Severity::kWarning);
  }

  report.index_dir = version_dir / std::string(kLegacyIndexDir);
  report.archives = archives.size();
  report.assets = kept.size();
  PackedStoreWriter writer(report.index_dir, name, std::move(archives));
  for (size_t i : kept) {
    PackedAssetInput input;
    input.uid = std::move(candidates[i].uid);
    input.mjcf = std::move(candidates[i].path);
    input.archive = candidates[i].archive;
    writer.Add(input);
  }
  writer.Finish();
  return report;
}

std::vector<ObjectSource> FindObjectSources(const fs::path& assets_dir,
                                            const std::vector<std::string>& names) {
  const fs::path objects = assets_dir / "objects";
  const std::string tries_file(kTriesFile);
  const std::string index_file(kUidIndexFile);
  auto kind_of = [&](const fs::path& root) {
    if (IsFile(root / index_file)) return ObjectSource::Kind::kPackage;
    if (IsFile(root / tries_file)) return ObjectSource::Kind::kLegacy;
    return ObjectSource::Kind::kOther;
  };
  std::vector<ObjectSource> out;
  if (!names.empty()) {
    for (const std::string& n : names) {
      if (n.empty() || n == "." || n == ".." || n.find('/') != std::string::npos) {
        throw UsageError("bad source name '" + n + "' (a folder name under <assets>/objects)");
      }
      const fs::path root = objects / n;
      std::error_code ec;
      if (!fs::is_directory(root, ec)) {
        throw Error("no such source (not a folder, or a dangling link)", root.string());
      }
      const ObjectSource::Kind kind = kind_of(root);
      if (kind == ObjectSource::Kind::kOther) {
        throw Error("not a MolmoSpaces-format source: no " + tries_file, root.string());
      }
      out.push_back({n, root, kind});
    }
    return out;
  }
  std::error_code ec;
  if (!fs::is_directory(objects, ec)) {
    throw Error(
        "no objects folder: nothing is installed here (set --assets-dir or "
        "MLSPACES_ASSETS_DIR)",
        objects.string());
  }
  std::vector<std::string> found;
  for (const auto& entry : fs::directory_iterator(objects, ec)) {
    std::error_code dir_ec;
    if (fs::is_directory(entry.path(), dir_ec)) found.push_back(entry.path().filename().string());
  }
  if (ec) throw Error("cannot list: " + ec.message(), objects.string());
  std::sort(found.begin(), found.end());
  for (const std::string& n : found) out.push_back({n, objects / n, kind_of(objects / n)});
  return out;
}

LegacyIndexReport BuildLegacySourceIndex(const ObjectSource& source) {
  std::error_code ec;
  const fs::path version_dir = fs::canonical(source.root, ec);
  if (ec) throw Error("cannot resolve: " + ec.message(), source.root.string());
  return BuildLegacyIndex(version_dir, source.name);
}

}  // namespace mlspaces
