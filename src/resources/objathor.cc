// objathor metadata: the original's LMDB or source files -> our packed store and CLIP store
// (include/mlspaces/resources/objathor.h).
#include "mlspaces/resources/objathor.h"

#include <lmdb.h>
#include <poll.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <map>
#include <memory>
#include <unordered_map>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/file_lock.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/subprocess.h"
#include "mlspaces/library/clip_store.h"
#include "mlspaces/library/package_layout.h"
#include "mlspaces/resources/molmo_remote.h"
#include "mlspaces/resources/packed_store_writer.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

constexpr uint64_t kMaxValueBytes = uint64_t{256} << 20;
constexpr const char* kVersionsFile = "mjthor_data_type_to_source_to_versions.json";
/// The converted store's marker: what it was converted from (ObjathorSourceMarker). A store
/// without it, or with another format or source identity, is rebuilt (an older index-builtin
/// left stores made from the tries, without annotations).
constexpr const char* kMarkerFile = "objathor_source.json";
/// Bump when the converted store's content changes for the same input.
constexpr int64_t kStoreFormat = 1;

// --- the LMDB child's stream: 'K' u32 key-size key u64 value-size value | 'E' u32 n msg | 'D'

bool WriteAll(int fd, const void* data, size_t n) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= static_cast<size_t>(w);
  }
  return true;
}

bool WriteMessage(int fd, char tag, std::string_view message) {
  const auto n = static_cast<uint32_t>(message.size());
  return WriteAll(fd, &tag, 1) && WriteAll(fd, &n, 4) && WriteAll(fd, message.data(), n);
}

/// The child: opens the LMDB read-only without a lock file and streams every entry.
int LmdbChild(int fd, const fs::path& dir) {
  MDB_env* env = nullptr;
  int rc = mdb_env_create(&env);
  auto fail = [&](const std::string& what) {
    WriteMessage(fd, 'E', what + ": " + mdb_strerror(rc));
    return 0;
  };
  if (rc != 0) return fail("mdb_env_create");
  rc = mdb_env_open(env, dir.c_str(), MDB_RDONLY | MDB_NOLOCK, 0644);
  if (rc != 0) return fail("cannot open the LMDB");
  MDB_txn* txn = nullptr;
  if ((rc = mdb_txn_begin(env, nullptr, MDB_RDONLY, &txn)) != 0) return fail("mdb_txn_begin");
  MDB_dbi dbi;
  if ((rc = mdb_dbi_open(txn, nullptr, 0, &dbi)) != 0) return fail("mdb_dbi_open");
  MDB_cursor* cursor = nullptr;
  if ((rc = mdb_cursor_open(txn, dbi, &cursor)) != 0) return fail("mdb_cursor_open");
  MDB_val key, value;
  while ((rc = mdb_cursor_get(cursor, &key, &value, MDB_NEXT)) == 0) {
    const char tag = 'K';
    const auto key_size = static_cast<uint32_t>(key.mv_size);
    const uint64_t value_size = value.mv_size;
    if (!WriteAll(fd, &tag, 1) || !WriteAll(fd, &key_size, 4) ||
        !WriteAll(fd, key.mv_data, key_size) || !WriteAll(fd, &value_size, 8) ||
        !WriteAll(fd, value.mv_data, value_size)) {
      return 1;  // the parent stopped reading
    }
  }
  if (rc != MDB_NOTFOUND) return fail("reading the LMDB");
  const char done = 'D';
  WriteAll(fd, &done, 1);
  return 0;  // the process exits: no need to close the environment
}

// --- converting values to JSON ----------------------------------------------------------

Json ArrayJson(const NpyArray& a, size_t dim, size_t& flat) {
  if (dim == a.shape.size()) {
    const size_t i = flat++;
    switch (a.dtype) {
      case DType::kB1:
        return Json(a.data[i] != 0);
      case DType::kU1:
        return Json(static_cast<uint64_t>(a.data[i]));
      case DType::kI4: {
        int32_t v;
        std::memcpy(&v, a.data.data() + i * 4, 4);
        return Json(static_cast<int64_t>(v));
      }
      case DType::kI8: {
        int64_t v;
        std::memcpy(&v, a.data.data() + i * 8, 8);
        return Json(v);
      }
      default:
        return Json(a.AsDouble(i));
    }
  }
  Json list = Json::array();
  for (size_t k = 0; k < a.shape[dim]; ++k) list.push_back(ArrayJson(a, dim + 1, flat));
  return list;
}

struct ToAnnotation {
  const std::string& uid;
  const std::string& source;
  Annotation& out;

  [[noreturn]] void Fail(const std::string& message, const std::string& pointer) const {
    throw Error(message, source, pointer, uid);
  }

  Json Convert(PickleValue& v, const std::string& pointer, bool in_dict) {
    using Kind = PickleValue::Kind;
    switch (v.kind) {
      case Kind::kNone:
        return nullptr;
      case Kind::kBool:
        return v.boolean;
      case Kind::kInt:
        return v.integer;
      case Kind::kFloat:
        return v.real;
      case Kind::kStr:
        return std::move(v.text);
      case Kind::kBytes:
      case Kind::kByteArray:
        Fail(std::string(PickleValue::KindName(v.kind)) + " values cannot be stored", pointer);
      case Kind::kList:
      case Kind::kTuple: {
        Json list = Json::array();
        for (size_t i = 0; i < v.items.size(); ++i) {
          list.push_back(Convert(v.items[i], pointer + "/" + std::to_string(i), false));
        }
        return list;
      }
      case Kind::kDict: {
        Json object = Json::object();
        for (auto& [key, value] : v.entries) {
          if (key.kind != Kind::kStr) {
            Fail(std::string("dict key of type ") + PickleValue::KindName(key.kind) +
                     " (only str keys can be stored)",
                 pointer);
          }
          const std::string child = pointer + "/" + JsonPointerToken(key.text);
          if (value.kind == Kind::kArray && !value.numpy_scalar) {
            out.arrays.emplace_back(child, std::move(value.array));
            continue;
          }
          object[key.text] = Convert(value, child, true);
        }
        return object;
      }
      case Kind::kArray: {
        size_t flat = 0;
        (void)in_dict;
        return ArrayJson(v.array, 0, flat);
      }
    }
    return nullptr;
  }
};

/// A row of an (N, ...) array as an array of its own.
NpyArray Row(const NpyArray& a, size_t i) {
  NpyArray row;
  row.dtype = a.dtype;
  row.shape.assign(a.shape.begin() + 1, a.shape.end());
  const size_t bytes = row.num_elements() * DTypeSize(a.dtype);
  row.data.assign(a.data.begin() + static_cast<ptrdiff_t>(i * bytes),
                  a.data.begin() + static_cast<ptrdiff_t>((i + 1) * bytes));
  return row;
}

/// An array's elements as floats, into `out` (float16 and float32 without a detour through
/// double, the common case of the CLIP features).
void ToFloats(const NpyArray& a, std::vector<float>& out) {
  const size_t n = a.num_elements();
  out.resize(n);
  if (a.dtype == DType::kF2) {
    for (size_t i = 0; i < n; ++i) {
      uint16_t h;
      std::memcpy(&h, a.data.data() + 2 * i, 2);
      out[i] = HalfToFloat(h);
    }
  } else if (a.dtype == DType::kF4) {
    std::memcpy(out.data(), a.data.data(), 4 * n);
  } else {
    for (size_t i = 0; i < n; ++i) out[i] = static_cast<float>(a.AsDouble(i));
  }
}

/// Streams annotations into both stores, in the order given.
class StoreSink {
 public:
  explicit StoreSink(fs::path dir)
      : dir_(std::move(dir)),
        packed_(dir_, std::string(kObjathorLibrary), {std::string(kObjathorLibrary)}) {}

  void Add(const Annotation& a, const std::string& source) {
    PackedAssetInput in;
    in.uid = a.uid;
    in.annotation = &a;
    packed_.Add(in);
    ++annotations_;
    const NpyArray* img = a.FindArray("/clip_img_features");
    const NpyArray* text = a.FindArray("/clip_text_features");
    if (img == nullptr && text == nullptr) return;
    if (img == nullptr || text == nullptr || img->shape.size() != 2 || text->shape.size() != 1 ||
        img->shape[1] != text->shape[0] || img->shape[0] == 0 || text->shape[0] == 0) {
      throw Error("clip_img_features must be (views, dim) and clip_text_features (dim,), got " +
                      (img ? ShapeRepr(img->shape) : std::string("none")) + " and " +
                      (text ? ShapeRepr(text->shape) : std::string("none")),
                  source, "/clip_img_features", a.uid);
    }
    if (!clip_) {
      clip_ = std::make_unique<ClipStoreWriter>(dir_ / std::string(kClipStoreFileName),
                                                img->shape[0], text->shape[0]);
      views_ = img->shape[0];
      dim_ = text->shape[0];
    } else if (img->shape[0] != views_ || text->shape[0] != dim_) {
      throw Error("CLIP features " + ShapeRepr(img->shape) + " differ from the first asset's (" +
                      std::to_string(views_) + ", " + std::to_string(dim_) + ")",
                  source, "/clip_img_features", a.uid);
    }
    ToFloats(*img, img32_);
    ToFloats(*text, text32_);
    clip_->Add(a.uid, img32_, text32_);
    ++clip_count_;
  }

  void Finish(ObjathorReport& report) {
    packed_.Finish();
    // Always written: its presence tells a conversion from an index-builtin tries index.
    if (!clip_)
      clip_ = std::make_unique<ClipStoreWriter>(dir_ / std::string(kClipStoreFileName), 3, 768);
    clip_->Finish();
    report.annotations = annotations_;
    report.clip_features = clip_count_;
  }

 private:
  fs::path dir_;
  PackedStoreWriter packed_;
  std::unique_ptr<ClipStoreWriter> clip_;
  size_t views_ = 0, dim_ = 0, annotations_ = 0, clip_count_ = 0;
  std::vector<float> img32_, text32_;  // reused between assets
};

/// True when the LMDB holds the sentinel decoding to itself (read in a child as well).
bool LmdbComplete(const fs::path& lmdb_dir, std::string& why) {
  if (!IsFile(lmdb_dir / "data.mdb")) {
    why = "no " + (lmdb_dir / "data.mdb").string();
    return false;
  }
  bool found = false;
  ReadLmdbEntries(lmdb_dir, [&](std::string_view key, std::string_view value) {
    if (key != kObjathorSentinel) return;
    const PickleValue v =
        DecodeLmdbValue(value, (lmdb_dir / "data.mdb").string(), std::string(key));
    found = v.kind == PickleValue::Kind::kStr && v.text == kObjathorSentinel;
  });
  if (!found) why = (lmdb_dir / "data.mdb").string() + " has no " + std::string(kObjathorSentinel);
  return found;
}

void ConvertFromLmdb(const fs::path& lmdb_dir, StoreSink& sink) {
  const std::string file = (lmdb_dir / "data.mdb").string();
  ReadLmdbEntries(lmdb_dir, [&](std::string_view key, std::string_view value) {
    if (key == kObjathorSentinel) return;
    const std::string uid(key);
    const Annotation a = AnnotationFromPickle(DecodeLmdbValue(value, file, uid), uid,
                                              std::string(kObjathorLibrary), file);
    sink.Add(a, file);
  });
}

void ConvertFromSources(const fs::path& source_dir, StoreSink& sink) {
  const fs::path json_path = source_dir / "objects_metadata.json.gz";
  const fs::path pkl_path = source_dir / "clip_features.pkl";
  Json annotations =
      ParseJson(InflateGzip(ReadFile(json_path), json_path.string()), json_path.string());
  if (!annotations.is_object()) {
    throw Error("expected a JSON object {uid: annotation}, got " + JsonTypeName(annotations),
                json_path.string());
  }
  PickleValue clip;
  {  // the file's bytes are released once decoded (the rest of the conversion runs without)
    const std::string pkl = ReadFile(pkl_path);
    PickleLimits limits;
    limits.max_output_bytes = std::max<uint64_t>(limits.max_output_bytes, 2 * pkl.size());
    clip = ParsePickle({reinterpret_cast<const uint8_t*>(pkl.data()), pkl.size()},
                       pkl_path.string(), "", limits);
  }
  const PickleValue* uids = clip.Find("uids");
  const PickleValue* img = clip.Find("img_features");
  const PickleValue* text = clip.Find("text_features");
  using Kind = PickleValue::Kind;
  if (uids == nullptr || (uids->kind != Kind::kList && uids->kind != Kind::kTuple)) {
    throw Error("expected a dict with a list \"uids\"", pkl_path.string(), "/uids");
  }
  const size_t n = uids->items.size();
  if (n != annotations.size()) {
    throw Error("# clip entries " + std::to_string(n) + " != # annotation entries " +
                    std::to_string(annotations.size()),
                pkl_path.string());
  }
  for (const auto& [name, a, rank] : {std::tuple{"/img_features", img, size_t{3}},
                                      std::tuple{"/text_features", text, size_t{2}}}) {
    if (a == nullptr || a->kind != Kind::kArray || a->array.shape.size() != rank ||
        a->array.shape[0] != n) {
      throw Error("expected an array of " + std::to_string(rank) + " dimensions with " +
                      std::to_string(n) + " rows",
                  pkl_path.string(), name);
    }
  }
  std::vector<std::pair<std::string, size_t>> order;  // sorted like the LMDB's keys
  for (size_t i = 0; i < n; ++i) {
    if (uids->items[i].kind != Kind::kStr) {
      throw Error("a UID that is not a str", pkl_path.string(), "/uids/" + std::to_string(i));
    }
    order.emplace_back(uids->items[i].text, i);
  }
  std::sort(order.begin(), order.end());
  // ordered_json's find is a linear scan: index the UIDs once (the first of equal keys, as find).
  std::unordered_map<std::string_view, Json*> by_uid;
  by_uid.reserve(annotations.size());
  for (auto it = annotations.begin(); it != annotations.end(); ++it) {
    by_uid.emplace(std::string_view(it.key()), &it.value());
  }
  for (const auto& [uid, i] : order) {
    auto found = by_uid.find(uid);
    Json* it = found == by_uid.end() ? nullptr : found->second;
    if (it == nullptr || !it->is_object()) {
      throw Error("clip UID " + uid + " has no annotation object", json_path.string(),
                  "/" + JsonPointerToken(uid), uid);
    }
    Annotation a;
    a.uid = uid;
    a.library = std::string(kObjathorLibrary);
    a.json = std::move(*it);
    a.json.erase("clip_img_features");
    a.json.erase("clip_text_features");
    a.arrays.emplace_back("/clip_img_features", Row(img->array, i));
    a.arrays.emplace_back("/clip_text_features", Row(text->array, i));
    sink.Add(a, json_path.string());
  }
}

}  // namespace

std::optional<ObjathorLocation> FindObjathor(const fs::path& assets) {
  ObjathorLocation where;
  where.source_dir = assets / "objects" / std::string(kObjathorLibrary);
  std::error_code ec;
  if (!fs::is_directory(where.source_dir, ec)) return std::nullopt;
  const fs::path versions = assets / kVersionsFile;
  if (IsFile(versions)) {
    const Json j = ParseJsonFile(versions);
    const Json* v = nullptr;
    if (j.is_object() && j.contains("objects") && j["objects"].is_object() &&
        j["objects"].contains(std::string(kObjathorLibrary))) {
      v = &j["objects"][std::string(kObjathorLibrary)];
    }
    if (v != nullptr && v->is_string()) where.version = v->get<std::string>();
  }
  if (where.version.empty()) {
    where.version = fs::canonical(where.source_dir, ec).filename().string();
    if (ec) throw Error("cannot resolve: " + ec.message(), where.source_dir.string());
  }
  where.lmdb_dir = assets / ".lmdb" / std::string(kObjathorLibrary) / where.version;
  where.index_dir = where.source_dir / std::string(kLegacyIndexDir);
  return where;
}

void ReadLmdbEntries(const fs::path& lmdb_dir,
                     const std::function<void(std::string_view, std::string_view)>& on_entry) {
  const std::string file = (lmdb_dir / "data.mdb").string();
  if (!IsFile(lmdb_dir / "data.mdb")) throw Error("no such LMDB file", file);
  // A corrupt page can make liblmdb loop: the child gets a generous time limit, 60 s plus
  // 1 s per 10 MB of data.mdb.
  std::error_code size_ec;
  const uintmax_t file_size = fs::file_size(lmdb_dir / "data.mdb", size_ec);
  const auto limit = std::chrono::seconds(60 + (size_ec ? 0 : file_size / 10'000'000));
  const auto deadline = std::chrono::steady_clock::now() + limit;
  Child child = Child::Start([&](int fd) { return LmdbChild(fd, lmdb_dir); });
  std::string buf, last_key, error;
  size_t pos = 0;
  bool done = false;
  char chunk[1 << 16];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    pollfd pfd{child.fd(), POLLIN, 0};
    const int ready = left.count() > 0 ? ::poll(&pfd, 1, static_cast<int>(left.count())) : 0;
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) {
      child.Kill();
      child.Wait();
      throw Error("liblmdb did not finish within " + std::to_string(limit.count()) + " s reading " +
                      (last_key.empty() ? std::string("the first entry") : "past key " + last_key) +
                      ": the file is damaged",
                  file, last_key);
    }
    const ssize_t n = ::read(child.fd(), chunk, sizeof chunk);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    buf.append(chunk, static_cast<size_t>(n));
    for (;;) {  // every complete frame
      const size_t left = buf.size() - pos;
      if (left < 1) break;
      const char tag = buf[pos];
      if (tag == 'D') {
        done = true;
        pos += 1;
        continue;
      }
      if (left < 5) break;
      uint32_t a;
      std::memcpy(&a, buf.data() + pos + 1, 4);
      if (tag == 'E') {
        if (left < 5 + uint64_t{a}) break;
        error = buf.substr(pos + 5, a);
        pos += 5 + a;
        continue;
      }
      if (left < 5 + uint64_t{a} + 8) break;
      uint64_t b;
      std::memcpy(&b, buf.data() + pos + 5 + a, 8);
      if (left < 13 + uint64_t{a} + b) break;
      const std::string_view key(buf.data() + pos + 5, a);
      last_key.assign(key);
      on_entry(key, std::string_view(buf.data() + pos + 13 + a, b));  // throws: child killed
      pos += 13 + a + b;
    }
    if (pos > (1 << 20)) {
      buf.erase(0, pos);
      pos = 0;
    }
  }
  const ChildExit exit = child.Wait();
  if (!error.empty()) throw Error("liblmdb: " + error, file, last_key);
  if (exit.signaled) {
    throw Error("liblmdb crashed (" + std::string(strsignal(exit.number)) + ") reading " +
                    (last_key.empty() ? std::string("the first entry") : "past key " + last_key) +
                    ": the file is damaged",
                file, last_key);
  }
  if (!done || exit.number != 0) {
    throw Error("the LMDB reader ended early (exit status " + std::to_string(exit.number) + ")",
                file, last_key);
  }
}

PickleValue DecodeLmdbValue(std::string_view value, const std::string& file,
                            const std::string& key) {
  std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> ctx(ZSTD_createDCtx(), ZSTD_freeDCtx);
  if (!ctx) throw Error("out of memory", file, key);
  std::string out;
  size_t used = 0;
  ZSTD_inBuffer in{value.data(), value.size(), 0};
  for (;;) {
    if (out.size() - used < ZSTD_DStreamOutSize()) {
      out.resize(std::max(out.size() * 2, used + ZSTD_DStreamOutSize()));
    }
    ZSTD_outBuffer o{out.data() + used, out.size() - used, 0};
    const size_t ret = ZSTD_decompressStream(ctx.get(), &o, &in);
    used += o.pos;
    if (ZSTD_isError(ret)) throw Error(std::string("zstd: ") + ZSTD_getErrorName(ret), file, key);
    if (used > kMaxValueBytes) throw Error("zstd value larger than 256 MiB", file, key);
    if (ret == 0 && in.pos == in.size) break;
    if (in.pos == in.size && o.pos < o.size) throw Error("zstd: truncated frame", file, key);
  }
  out.resize(used);
  return ParsePickle({reinterpret_cast<const uint8_t*>(out.data()), out.size()}, file, key);
}

Annotation AnnotationFromPickle(PickleValue value, const std::string& uid,
                                const std::string& library, const std::string& source) {
  if (value.kind != PickleValue::Kind::kDict) {
    throw Error(std::string("expected a dict, got ") + PickleValue::KindName(value.kind), source,
                "", uid);
  }
  Annotation out;
  out.uid = uid;
  out.library = library;
  ToAnnotation convert{uid, source, out};
  out.json = convert.Convert(value, "", true);
  return out;
}

namespace {

fs::path LockPath(const ObjathorLocation& where) {
  return where.index_dir.parent_path() / "objathor.lock";
}

constexpr const char* kFromLmdb = "lmdb";
constexpr const char* kFromSources = "source files";

/// The marker of a conversion from `kind`: the store format and the size and modification
/// time (ns) of each input file, as they are now (a missing file has size -1).
Json SourceMarker(const ObjathorLocation& where, std::string_view kind) {
  std::vector<fs::path> files;
  if (kind == kFromLmdb) {
    files = {where.lmdb_dir / "data.mdb"};
  } else {
    files = {where.source_dir / "objects_metadata.json.gz", where.source_dir / "clip_features.pkl"};
  }
  Json out = Json::object();
  out["format"] = kStoreFormat;
  out["kind"] = std::string(kind);
  Json list = Json::array();
  for (const fs::path& f : files) {
    struct stat st {};
    const bool there = ::stat(f.c_str(), &st) == 0;
    Json entry = Json::object();
    entry["file"] = f.filename().string();
    entry["size"] = there ? static_cast<int64_t>(st.st_size) : int64_t{-1};
    entry["mtime_ns"] =
        there ? int64_t{st.st_mtim.tv_sec} * 1'000'000'000 + st.st_mtim.tv_nsec : int64_t{0};
    list.push_back(std::move(entry));
  }
  out["from"] = std::move(list);
  return out;
}

/// The marker file's text for `marker` (compared as text: no JSON parse on the lookup path).
std::string MarkerText(const Json& marker) { return marker.dump(1) + "\n"; }

/// True when index_dir holds a whole store whose marker matches its input as it is now.
bool StoreCurrent(const ObjathorLocation& where) {
  for (std::string_view f : {kUidIndexFile, kMetadataStoreFile, kClipStoreFileName}) {
    if (!IsFile(where.index_dir / std::string(f))) return false;
  }
  const fs::path marker = where.index_dir / kMarkerFile;
  if (!IsFile(marker)) return false;  // e.g. an older index-builtin's store from the tries
  std::string text;
  try {
    text = ReadFile(marker);
  } catch (const Error&) {
    return false;  // unreadable: rebuilt
  }
  const std::string_view kind = text.find("\"kind\": \"lmdb\"") != std::string::npos
                                    ? std::string_view(kFromLmdb)
                                    : std::string_view(kFromSources);
  return text == MarkerText(SourceMarker(where, kind));
}

/// ConvertObjathor with the lock held.
ObjathorReport ConvertLocked(const ObjathorLocation& where) {
  ObjathorReport report;
  report.index_dir = where.index_dir;
  const fs::path parent = where.index_dir.parent_path();
  fs::create_directories(parent);
  const fs::path tmp = parent / ("index" + TempSuffix());
  struct Cleanup {
    fs::path path;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  } cleanup{tmp};
  fs::create_directories(tmp);
  StoreSink sink(tmp);
  std::string why;
  Json marker;  // taken before reading, so an input changed meanwhile is converted again
  if (LmdbComplete(where.lmdb_dir, why)) {
    report.from = "lmdb " + where.lmdb_dir.string();
    marker = SourceMarker(where, kFromLmdb);
    ConvertFromLmdb(where.lmdb_dir, sink);
  } else if (IsFile(where.source_dir / "objects_metadata.json.gz") ||
             IsFile(where.source_dir / "clip_features.pkl")) {
    report.from = "source files " + where.source_dir.string();
    marker = SourceMarker(where, kFromSources);
    ConvertFromSources(where.source_dir, sink);
  } else {
    throw Error("objathor metadata has neither a complete LMDB (" + why + ") nor " +
                    "objects_metadata.json.gz and clip_features.pkl",
                where.source_dir.string());
  }
  sink.Finish(report);
  WriteFileAtomic(tmp / kMarkerFile, MarkerText(marker));
  // Swap in: the old store (if any) moves aside first, so a reader sees a whole store.
  const fs::path old = parent / ("index.old" + TempSuffix());
  std::error_code ec;
  if (fs::exists(where.index_dir, ec)) fs::rename(where.index_dir, old);
  fs::rename(tmp, where.index_dir);
  fs::remove_all(old, ec);
  report.converted = true;
  return report;
}

}  // namespace

ObjathorReport ConvertObjathor(const ObjathorLocation& where) {
  FileLock lock(LockPath(where));
  return ConvertLocked(where);
}

std::optional<ObjathorReport> EnsureObjathorStore(const fs::path& assets) {
  std::optional<ObjathorLocation> where = FindObjathor(assets);
  if (!where) return std::nullopt;
  auto ready = [&] { return StoreCurrent(*where); };
  ObjathorReport report;
  report.index_dir = where->index_dir;
  if (ready()) return report;
  FileLock lock(LockPath(*where));
  if (ready()) return report;  // another process converted it while we waited
  return ConvertLocked(*where);
}

}  // namespace mlspaces
