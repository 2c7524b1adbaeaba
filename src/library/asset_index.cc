#include "mlspaces/library/asset_index.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string_view>
#include <system_error>

#define XXH_INLINE_ALL
#include <xxhash.h>

#include "library_walk.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/strings.h"

namespace mlspaces {
namespace fs = std::filesystem;
namespace {

const std::string& RequireString(const FlatJson& entry, std::string_view key,
                                 const std::string& file, const std::string& entry_pointer) {
  auto it = entry.find(key);
  std::string pointer = entry_pointer + "/" + std::string(key);
  if (it == entry.end()) throw Error("missing required field", file, pointer);
  if (!it->is_string()) {
    throw Error("expected string, got " + JsonTypeWord(*it), file, pointer);
  }
  return it->get_ref<const std::string&>();
}

}  // namespace

AssetIndex AssetIndex::Load(const fs::path& index_file) {
  const std::string file = index_file.string();
  FlatJson root = ParseFlatJsonFile(index_file);
  if (!root.is_object()) throw Error("expected object, got " + JsonTypeWord(root), file, "/");
  AssetIndex index;
  for (auto it = root.begin(); it != root.end(); ++it) {
    const std::string& key = it.key();
    const std::string pointer = "/" + JsonPointerToken(key);
    const FlatJson& value = it.value();
    if (!value.is_object()) {
      throw Error("expected object, got " + JsonTypeWord(value), file, pointer, key);
    }
    AssetEntry entry;
    entry.uid = RequireString(value, "uid", file, pointer);
    entry.object_path = RequireString(value, "object_path", file, pointer);
    entry.metadata_path = RequireString(value, "metadata_path", file, pointer);
    auto npz = value.find("metadata_npz_path");
    if (npz == value.end()) {
      throw Error("missing required field (string or null)", file, pointer + "/metadata_npz_path",
                  key);
    }
    if (npz->is_string()) {
      entry.metadata_npz_path = npz->get<std::string>();
    } else if (!npz->is_null()) {
      throw Error("expected string or null, got " + JsonTypeWord(*npz), file,
                  pointer + "/metadata_npz_path", key);
    }
    index.entries[key] = std::move(entry);
  }
  return index;
}

std::string AssetIndex::Serialize() const {
  if (entries.empty()) return "{}";
  std::string out;
  out.reserve(entries.size() * 256);
  out += "{\n";
  bool first = true;
  for (const auto& [key, entry] : entries) {
    if (!first) out += ",\n";
    first = false;
    out += "    ";
    internal::AppendJsonString(out, key);
    out += ": {\n        \"uid\": ";
    internal::AppendJsonString(out, entry.uid);
    out += ",\n        \"object_path\": ";
    internal::AppendJsonString(out, entry.object_path);
    out += ",\n        \"metadata_path\": ";
    internal::AppendJsonString(out, entry.metadata_path);
    out += ",\n        \"metadata_npz_path\": ";
    if (entry.metadata_npz_path) {
      internal::AppendJsonString(out, *entry.metadata_npz_path);
    } else {
      out += "null";
    }
    out += "\n    }";
  }
  out += "\n}";
  return out;
}

std::string IndexWarningLine(const Diagnostic& warning) {
  return "Warning: " + Printable(warning.message) + " Skipping.";
}

AssetIndex BuildAssetIndex(const fs::path& dir, const AssetIndexOptions& options,
                           IndexReport* report, bool use_computed) {
  const fs::path root = internal::ResolvePath(dir);
  AssetIndex index;
  internal::WalkSorted(root, [&](const internal::WalkDir& d, const internal::WalkEntry& e) {
    std::string_view name = e.name;
    constexpr std::string_view kXml = ".xml";
    if (name.size() <= kXml.size() || !name.ends_with(kXml)) return;
    const std::string uid(name.substr(0, name.size() - kXml.size()));
    if (e.kind == internal::WalkEntry::Kind::kSymlink && !d.HasFile(e.name)) {
      throw Error("broken symbolic link: its target does not exist", d.AbsChild(name), {}, uid);
    }
    const std::string json_name = uid + ".json";
    if (!d.HasFile(json_name)) {
      std::string message = "Expected metadata JSON for " + d.AbsChild(name) + " at " +
                            d.AbsChild(json_name) + ", but it was not found.";
      if (options.suppress_missing_metadata) {
        if (report != nullptr) {
          report->warnings.emplace_back(d.AbsChild(name), "", std::move(message), uid,
                                        Severity::kWarning);
        }
        return;
      }
      throw Error(message, {}, {}, uid);
    }
    AssetEntry entry;
    entry.uid = uid;
    entry.object_path = d.RelChild(name);
    const std::string computed_name = uid + "_computed.json";
    entry.metadata_path =
        d.RelChild(use_computed && d.HasFile(computed_name) ? computed_name : json_name);
    const std::string npz_name = uid + ".npz";
    if (d.HasFile(npz_name)) entry.metadata_npz_path = d.RelChild(npz_name);
    auto [it, inserted] = index.entries.try_emplace(uid, std::move(entry));
    if (!inserted) {
      throw Error("Duplicate asset id '" + uid + "' found at " + d.RelChild(name) + " and " +
                      it->second.object_path + ".",
                  {}, {}, uid);
    }
  });
  if (report != nullptr) report->count = index.entries.size();
  return index;
}

fs::path AssetIndexOutputPath(const fs::path& dir, const AssetIndexOptions& options) {
  return internal::IndexOutputPath(internal::ResolvePath(dir), options.output, "assets_index.json",
                                   options.overwrite);
}

IndexReport WriteAssetIndex(const fs::path& dir, const AssetIndexOptions& options) {
  IndexReport report;
  report.output = AssetIndexOutputPath(dir, options);
  AssetIndex index = BuildAssetIndex(dir, options, &report, /*use_computed=*/false);
  WriteFileAtomic(report.output, index.Serialize());
  return report;
}

std::string SourceFileHash(const fs::path& file) {
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(file.c_str(), "rb"), &std::fclose);
  if (!f) throw Error(std::string("cannot read: ") + std::strerror(errno), file.string());
  XXH3_state_t state{};
  XXH3_128bits_reset(&state);
  std::unique_ptr<char[]> buf(new char[1 << 20]);
  size_t n;
  while ((n = std::fread(buf.get(), 1, 1 << 20, f.get())) > 0) {
    XXH3_128bits_update(&state, buf.get(), n);
  }
  if (std::ferror(f.get())) throw Error("cannot read: read error", file.string());
  XXH128_canonical_t canonical;
  XXH128_canonicalFromHash(&canonical, XXH3_128bits_digest(&state));
  static constexpr char kHex[] = "0123456789abcdef";
  std::string hex;
  for (unsigned char byte : canonical.digest) {
    hex += kHex[byte >> 4];
    hex += kHex[byte & 15];
  }
  return hex;
}

namespace {
constexpr std::string_view kComputedHash = "xxh128";
}  // namespace

Json ComputedFromRecord(const fs::path& computed_file, const std::vector<fs::path>& sources) {
  const fs::path folder = fs::absolute(computed_file).lexically_normal().parent_path();
  std::map<std::string, std::string> files;
  for (const fs::path& source : sources) {
    const fs::path abs = fs::absolute(source).lexically_normal();
    files[abs.lexically_relative(folder).generic_string()] = SourceFileHash(abs);
  }
  Json record = Json::object();
  record["hash"] = kComputedHash;
  record["files"] = Json::object();
  for (const auto& [rel, hash] : files) record["files"][rel] = hash;
  return record;
}

std::optional<std::vector<Diagnostic>> CheckComputedFrom(const fs::path& computed_file,
                                                         const Json& computed) {
  if (!computed.is_object()) return std::nullopt;
  auto it = computed.find(kComputedFromKey);
  if (it == computed.end()) return std::nullopt;
  const std::string file = computed_file.string();
  const std::string pointer = "/" + std::string(kComputedFromKey);
  std::vector<Diagnostic> problems;
  auto add = [&](std::string field, std::string message) {
    problems.emplace_back(file, std::move(field), std::move(message));
  };
  const Json& record = *it;
  if (!record.is_object()) {
    add(pointer, "expected object, got " + JsonTypeWord(record));
    return problems;
  }
  auto hash = record.find("hash");
  if (hash == record.end() || !hash->is_string() || *hash != kComputedHash) {
    add(pointer + "/hash", "expected \"" + std::string(kComputedHash) + "\"");
    return problems;
  }
  auto files = record.find("files");
  if (files == record.end() || !files->is_object() || files->empty()) {
    add(pointer + "/files", "expected a non-empty object of source files and their hashes");
    return problems;
  }
  const fs::path folder = computed_file.parent_path();
  for (auto f = files->begin(); f != files->end(); ++f) {
    const std::string field = pointer + "/files/" + JsonPointerToken(f.key());
    if (!f.value().is_string()) {
      add(field, "expected string, got " + JsonTypeWord(f.value()));
      continue;
    }
    const fs::path source = (folder / f.key()).lexically_normal();
    std::error_code ec;
    if (f.key().empty() || fs::path(f.key()).is_absolute() || !fs::is_regular_file(source, ec)) {
      add(field, "source file not found: " + source.string() +
                     " (run mlspaces index-assets --compute-metadata again)");
      continue;
    }
    std::string now;
    try {
      now = SourceFileHash(source);
    } catch (const Error& e) {
      add(field, e.what());
      continue;
    }
    if (now != f.value().get_ref<const std::string&>()) {
      add(field, "stale: " + source.string() +
                     " changed since this file was computed (run mlspaces index-assets "
                     "--compute-metadata again)");
    }
  }
  return problems;
}

}  // namespace mlspaces
