// Packed stores (include/mlspaces/library/packed_store.h; byte layout in docs/formats.md,
// "Packed stores"): uid_index.mlsx, metadata.mlsm and the per-archive grasp shards .mlsg.
//
// How the metadata JSON is stored, chosen by measurement. Decoding the 303-byte compact form
// of examples/custom_assets/asset_library/red_block/red_block_computed.json into a Json
// (nlohmann::ordered_json), -O2, one core of the build machine, mean of 200,000 decodes:
//
//   nlohmann::json::parse of the compact text           3,670 ns
//   ParseJson (simdjson DOM + conversion) of the text    1,590 ns
//   nlohmann::json::from_msgpack (258 bytes)             2,710 ns
//   nlohmann::json::from_cbor (258 bytes)                2,750 ns
//   copying the finished Json (allocation floor)           670 ns
//
// bench/packed_store_bench.cc repeats these (BM_JsonDecode*, BM_JsonCopy) beside
// BM_LoadAnnotation, which decodes a whole red_block-like record with the decoder below.
//
// nlohmann's own binary readers are slower than simdjson on the text (they go through a
// generic SAX interface byte by byte), so records hold MessagePack as nlohmann::to_msgpack
// writes it (standard, 15% smaller than the text) and this file decodes it with a small
// direct decoder that builds the ordered_json in place (about two allocations per value,
// bounds-checked, depth-limited). That leaves the whole LoadAnnotation of a small record
// (checksum, UID check, decode) at 0.9 us (BM_LoadAnnotation, 150,000-asset store; same run:
// simdjson text 1.33 us, nlohmann msgpack 2.10 us, Json copy 0.47 us), under the 2 us target.
#include "mlspaces/core/crash_point.h"
#include "mlspaces/library/packed_store.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>
#include <mutex>
#include <set>
#include <tuple>
#include <unordered_map>
#include <unordered_set>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"

namespace mlspaces {
namespace fs = std::filesystem;

static_assert(std::endian::native == std::endian::little,
              "packed stores are read in place: little-endian hosts only");

namespace {

// ---------------------------------------------------------------------------------------------
// Layout constants (docs/formats.md, "Packed stores").

constexpr char kIndexMagic[8] = {'M', 'L', 'S', 'U', 'I', 'D', 'X', '1'};
constexpr char kMetaMagic[8] = {'M', 'L', 'S', 'M', 'E', 'T', 'A', '1'};
constexpr char kShardMagic[8] = {'M', 'L', 'S', 'G', 'R', 'S', 'P', '1'};
constexpr uint32_t kFormatVersion = 1;
constexpr uint32_t kJsonMsgpack = 1;  // metadata.mlsm json_encoding

constexpr uint64_t kHeaderSize = 64;
constexpr uint64_t kBucketSize = 8;
constexpr uint64_t kRecordSize = 48;
constexpr uint64_t kGraspRefSize = 32;
constexpr uint64_t kNameSize = 8;
constexpr uint64_t kPoseSize = 16 * sizeof(double);
constexpr uint64_t kMetaRecordHeader = 24;
constexpr uint64_t kArrayHeader = 8;
constexpr int kMaxJsonDepth = 256;
constexpr uint32_t kMaxDType = static_cast<uint32_t>(DType::kB1);

// uid_index.mlsx header fields.
constexpr size_t kIdxVersion = 8, kIdxNumAssets = 12, kIdxFileSize = 16, kIdxNumBuckets = 24,
                 kIdxNumGrasps = 28, kIdxNumArchives = 32, kIdxNumRobots = 36,
                 kIdxRecordsOff = 40, kIdxGraspsOff = 44, kIdxNamesOff = 48,
                 kIdxStringsOff = 52, kIdxChecksum = 56;
// metadata.mlsm header fields.
constexpr size_t kMetaVersion = 8, kMetaNumRecords = 12, kMetaFileSize = 16,
                 kMetaRecordsOff = 24, kMetaRecordsSize = 32, kMetaEncoding = 40,
                 kMetaChecksum = 56;
// .mlsg header fields.
constexpr size_t kShardVersion = 8, kShardFileSize = 16, kShardNumPoses = 24,
                 kShardPosesOff = 32;

template <class T>
T Load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

template <class T>
void Put(std::string& out, T v) {
  char buf[sizeof v];
  std::memcpy(buf, &v, sizeof v);
  out.append(buf, sizeof v);
}

template <class T>
void PutAt(std::string& out, size_t pos, T v) {
  std::memcpy(out.data() + pos, &v, sizeof v);
}

constexpr uint64_t Align8(uint64_t n) { return (n + 7) & ~uint64_t{7}; }

void Pad8(std::string& out) { out.append(Align8(out.size()) - out.size(), '\0'); }

uint64_t HashUid(std::string_view uid) { return XXH3_64bits(uid.data(), uid.size()); }

/// a + b, or nullopt-like max on overflow (callers compare against a size, so max fails).
uint64_t SatAdd(uint64_t a, uint64_t b) {
  uint64_t r;
  return __builtin_add_overflow(a, b, &r) ? std::numeric_limits<uint64_t>::max() : r;
}
uint64_t SatMul(uint64_t a, uint64_t b) {
  uint64_t r;
  return __builtin_mul_overflow(a, b, &r) ? std::numeric_limits<uint64_t>::max() : r;
}

// ---------------------------------------------------------------------------------------------
// Read-only file mappings.

class Mapping {
 public:
  Mapping() = default;
  ~Mapping() {
    if (data_ != nullptr) ::munmap(const_cast<uint8_t*>(data_), size_);
  }
  Mapping(const Mapping&) = delete;
  Mapping& operator=(const Mapping&) = delete;

  /// Maps a whole file read-only. `missing` is the message for a file that does not exist.
  void Open(const fs::path& path, const std::string& missing, int advice) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
      throw Error(errno == ENOENT ? missing : std::string("cannot open: ") + std::strerror(errno),
                  path.string());
    }
    struct stat st {};
    if (::fstat(fd, &st) != 0) {
      const int err = errno;
      ::close(fd);
      throw Error(std::string("cannot stat: ") + std::strerror(err), path.string());
    }
    if (!S_ISREG(st.st_mode)) {
      ::close(fd);
      throw Error("not a regular file", path.string());
    }
    size_ = static_cast<size_t>(st.st_size);
    if (size_ < kHeaderSize) {
      ::close(fd);
      throw Error("truncated: " + std::to_string(size_) + " bytes, shorter than the " +
                      std::to_string(kHeaderSize) + "-byte header",
                  path.string());
    }
    void* addr = ::mmap(nullptr, size_, PROT_READ, MAP_SHARED, fd, 0);
    const int err = errno;
    ::close(fd);
    if (addr == MAP_FAILED) {
      throw Error(std::string("cannot map: ") + std::strerror(err), path.string());
    }
    data_ = static_cast<const uint8_t*>(addr);
    if (advice != MADV_NORMAL) ::madvise(addr, size_, advice);
  }

  const uint8_t* data() const { return data_; }
  uint64_t size() const { return size_; }

 private:
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
};

/// Checks the magic and version of a 64-byte header.
void CheckMagic(const uint8_t* p, const char (&magic)[8], const fs::path& path) {
  if (std::memcmp(p, magic, 8) != 0) {
    throw Error("not a packed store file of this kind (bad magic, expected \"" +
                    std::string(magic, 8) + "\")",
                path.string());
  }
  const uint32_t version = Load<uint32_t>(p + 8);
  if (version != kFormatVersion) {
    throw Error("unsupported format version " + std::to_string(version) + " (this build reads " +
                    std::to_string(kFormatVersion) + ")",
                path.string());
  }
}

// ---------------------------------------------------------------------------------------------
// MessagePack -> ordered_json, for the subset nlohmann::to_msgpack writes for JSON values.

class MsgpackDecoder {
 public:
  MsgpackDecoder(const uint8_t* p, const uint8_t* end) : p_(p), end_(end) {}

  /// Decodes one value that must span the whole input. Returns false on any malformation.
  bool DecodeAll(Json& out) {
    if (!Value(out, 0)) return false;
    return p_ == end_;
  }

 private:
  bool Need(uint64_t n) const { return static_cast<uint64_t>(end_ - p_) >= n; }

  template <class T>
  bool BigEndian(T& v) {
    if (!Need(sizeof v)) return false;
    std::memcpy(&v, p_, sizeof v);
    p_ += sizeof v;
    if constexpr (sizeof v == 2) v = __builtin_bswap16(v);
    if constexpr (sizeof v == 4) v = __builtin_bswap32(v);
    if constexpr (sizeof v == 8) v = __builtin_bswap64(v);
    return true;
  }

  bool Str(uint64_t n, std::string& s) {
    if (!Need(n)) return false;
    s.assign(reinterpret_cast<const char*>(p_), n);
    p_ += n;
    return true;
  }

  /// Reads a string header + bytes (map keys).
  bool Key(std::string& s) {
    if (!Need(1)) return false;
    const uint8_t b = *p_++;
    uint64_t n;
    if (b >= 0xa0 && b <= 0xbf) {
      n = b & 0x1f;
    } else if (b == 0xd9) {
      uint8_t v;
      if (!BigEndian(v)) return false;
      n = v;
    } else if (b == 0xda) {
      uint16_t v;
      if (!BigEndian(v)) return false;
      n = v;
    } else if (b == 0xdb) {
      uint32_t v;
      if (!BigEndian(v)) return false;
      n = v;
    } else {
      return false;
    }
    return Str(n, s);
  }

  bool Array(Json& out, uint64_t n, int depth) {
    out = Json(Json::value_t::array);
    auto& items = out.get_ref<Json::array_t&>();
    // Every element takes at least one byte: a damaged count cannot reserve more than that.
    items.reserve(std::min<uint64_t>(n, static_cast<uint64_t>(end_ - p_)));
    for (uint64_t i = 0; i < n; ++i) {
      items.emplace_back();
      if (!Value(items.back(), depth + 1)) return false;
    }
    return true;
  }

  bool Map(Json& out, uint64_t n, int depth) {
    out = Json(Json::value_t::object);
    auto& fields = out.get_ref<Json::object_t&>();
    fields.reserve(std::min<uint64_t>(n, static_cast<uint64_t>(end_ - p_) / 2));
    std::string key;
    for (uint64_t i = 0; i < n; ++i) {
      if (!Key(key)) return false;
      Json value;
      if (!Value(value, depth + 1)) return false;
      // ordered_map::emplace keeps the first of duplicate keys, as nlohmann's reader does.
      fields.emplace(std::move(key), std::move(value));
      key.clear();
    }
    return true;
  }

  bool Value(Json& out, int depth) {
    if (depth > kMaxJsonDepth || !Need(1)) return false;
    const uint8_t b = *p_++;
    if (b <= 0x7f) {
      out = static_cast<uint64_t>(b);
      return true;
    }
    if (b >= 0xe0) {
      out = static_cast<int64_t>(static_cast<int8_t>(b));
      return true;
    }
    if (b >= 0xa0 && b <= 0xbf) {
      out = Json(Json::value_t::string);
      return Str(b & 0x1f, out.get_ref<std::string&>());
    }
    if (b >= 0x90 && b <= 0x9f) return Array(out, b & 0x0f, depth);
    if (b >= 0x80 && b <= 0x8f) return Map(out, b & 0x0f, depth);
    switch (b) {
      case 0xc0: out = nullptr; return true;
      case 0xc2: out = false; return true;
      case 0xc3: out = true; return true;
      case 0xca: {
        uint32_t bits;
        if (!BigEndian(bits)) return false;
        out = static_cast<double>(std::bit_cast<float>(bits));
        return true;
      }
      case 0xcb: {
        uint64_t bits;
        if (!BigEndian(bits)) return false;
        out = std::bit_cast<double>(bits);
        return true;
      }
      case 0xcc: { uint8_t v; if (!BigEndian(v)) return false; out = uint64_t{v}; return true; }
      case 0xcd: { uint16_t v; if (!BigEndian(v)) return false; out = uint64_t{v}; return true; }
      case 0xce: { uint32_t v; if (!BigEndian(v)) return false; out = uint64_t{v}; return true; }
      case 0xcf: { uint64_t v; if (!BigEndian(v)) return false; out = v; return true; }
      case 0xd0: { uint8_t v; if (!BigEndian(v)) return false; out = int64_t{static_cast<int8_t>(v)}; return true; }
      case 0xd1: { uint16_t v; if (!BigEndian(v)) return false; out = int64_t{static_cast<int16_t>(v)}; return true; }
      case 0xd2: { uint32_t v; if (!BigEndian(v)) return false; out = int64_t{static_cast<int32_t>(v)}; return true; }
      case 0xd3: { uint64_t v; if (!BigEndian(v)) return false; out = static_cast<int64_t>(v); return true; }
      case 0xd9: case 0xda: case 0xdb: {
        --p_;
        out = Json(Json::value_t::string);
        return Key(out.get_ref<std::string&>());
      }
      case 0xdc: { uint16_t n; if (!BigEndian(n)) return false; return Array(out, n, depth); }
      case 0xdd: { uint32_t n; if (!BigEndian(n)) return false; return Array(out, n, depth); }
      case 0xde: { uint16_t n; if (!BigEndian(n)) return false; return Map(out, n, depth); }
      case 0xdf: { uint32_t n; if (!BigEndian(n)) return false; return Map(out, n, depth); }
      default: return false;  // bin, ext, reserved: never written for JSON values
    }
  }

  const uint8_t* p_;
  const uint8_t* end_;
};

/// A buffered, append-only file (the writers' temp files).
class OutFile {
 public:
  OutFile() = default;
  ~OutFile() { Abandon(); }
  OutFile(const OutFile&) = delete;
  OutFile& operator=(const OutFile&) = delete;

  void Create(fs::path tmp, std::string error_path) {
    tmp_ = std::move(tmp);
    error_path_ = std::move(error_path);
    fd_ = ::open(tmp_.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd_ < 0) throw Error(std::string("cannot write: ") + std::strerror(errno), error_path_);
  }
  uint64_t size() const { return written_ + buf_.size(); }
  void Write(const void* data, size_t n) {
    buf_.append(static_cast<const char*>(data), n);
    if (buf_.size() >= (1u << 20)) Flush();
  }
  void Write(std::string_view s) { Write(s.data(), s.size()); }
  void Flush() {
    const char* p = buf_.data();
    size_t left = buf_.size();
    while (left > 0) {
      const ssize_t n = ::write(fd_, p, left);
      if (n < 0) {
        if (errno == EINTR) continue;
        throw Error(std::string("write failed: ") + std::strerror(errno), error_path_);
      }
      p += n;
      left -= static_cast<size_t>(n);
    }
    written_ += buf_.size();
    buf_.clear();
  }
  /// Overwrites bytes already flushed (the header).
  void WriteAt(uint64_t offset, std::string_view data) {
    if (::pwrite(fd_, data.data(), data.size(), static_cast<off_t>(offset)) !=
        static_cast<ssize_t>(data.size())) {
      throw Error(std::string("write failed: ") + std::strerror(errno), error_path_);
    }
  }
  int fd() const { return fd_; }
  const fs::path& tmp() const { return tmp_; }
  /// Flushes, fsyncs (unless `sync` is false), closes and renames over `dest`; fsyncs the
  /// folder.
  void Commit(const fs::path& dest, bool sync = true) {
    Flush();
    int err = sync && ::fsync(fd_) != 0 ? errno : 0;
    if (::close(fd_) != 0 && err == 0) err = errno;
    fd_ = -1;
    if (err != 0) throw Error(std::string("write failed: ") + std::strerror(err), error_path_);
    if (::rename(tmp_.c_str(), dest.c_str()) != 0) {
      throw Error(std::string("cannot rename into place: ") + std::strerror(errno), error_path_);
    }
    tmp_.clear();
    CrashPoint("store file renamed into place");
    const fs::path parent = dest.parent_path();
    if (sync) FsyncPath(parent.empty() ? fs::path(".") : parent, true, error_path_);
  }
  /// Closes and removes the temp file (no-op after Commit).
  void Abandon() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    if (!tmp_.empty()) ::unlink(tmp_.c_str());
    tmp_.clear();
  }

 private:
  fs::path tmp_;
  std::string error_path_;
  int fd_ = -1;
  std::string buf_;
  uint64_t written_ = 0;
};

void CreateParent(const fs::path& path) {
  std::error_code ec;
  const fs::path parent = path.parent_path();
  if (!parent.empty()) {
    fs::create_directories(parent, ec);
    if (ec) throw Error("cannot create folder: " + ec.message(), parent.string());
  }
}

}  // namespace

// =============================================================================================
// GraspShardWriter

struct GraspShardWriter::Impl {
  fs::path path;
  OutFile out;
  uint64_t num_poses = 0;
  bool finished = false;
};

GraspShardWriter::GraspShardWriter(fs::path path) : impl_(std::make_unique<Impl>()) {
  impl_->path = std::move(path);
  CreateParent(impl_->path);
  fs::path tmp = impl_->path;
  tmp += TempSuffix();
  impl_->out.Create(tmp, impl_->path.string());
  const std::string header(kHeaderSize, '\0');  // written for real by Finish
  impl_->out.Write(header);
}

GraspShardWriter::~GraspShardWriter() = default;

uint64_t GraspShardWriter::Append(std::span<const Mat4> poses) {
  if (impl_->finished) throw Error("grasp shard already finished", impl_->path.string());
  for (size_t i = 0; i < poses.size(); ++i) {
    for (double v : poses[i].m) {
      if (!std::isfinite(v)) {
        throw Error("non-finite value in grasp pose " + std::to_string(i),
                    impl_->path.string());
      }
    }
  }
  const uint64_t offset = impl_->out.size();
  static_assert(sizeof(Mat4) == kPoseSize);
  impl_->out.Write(poses.data(), poses.size() * sizeof(Mat4));
  impl_->num_poses += poses.size();
  return offset;
}

void GraspShardWriter::Finish(bool sync) {
  if (impl_->finished) throw Error("grasp shard already finished", impl_->path.string());
  impl_->out.Flush();
  std::string header;
  header.append(kShardMagic, 8);
  Put<uint32_t>(header, kFormatVersion);
  Put<uint32_t>(header, 0);
  Put<uint64_t>(header, impl_->out.size());
  Put<uint64_t>(header, impl_->num_poses);
  Put<uint64_t>(header, kHeaderSize);
  header.resize(kHeaderSize, '\0');
  impl_->out.WriteAt(0, header);
  impl_->out.Commit(impl_->path, sync);
  impl_->finished = true;
}

// =============================================================================================
// PackedStoreWriter

namespace {

/// One asset as the writer keeps it until Finish: no metadata, just where its record is.
struct WriterEntry {
  std::string uid, mjcf;
  uint32_t archive = 0;
  uint64_t tmp_offset = 0, tmp_size = 0;  // record in the stream file; size 0: none
  std::vector<PackedAssetInput::Grasps> grasps;
};

/// Serialises one metadata record (see docs/formats.md).
std::string EncodeMetadataRecord(const std::string& uid, const Annotation& a,
                                 const std::string& error_path) {
  if (!a.uid.empty() && a.uid != uid) {
    throw Error("annotation is for UID " + a.uid, error_path, "", uid);
  }
  const std::vector<uint8_t> msgpack = Json::to_msgpack(a.json);
  {
    Json check;
    MsgpackDecoder decoder(msgpack.data(), msgpack.data() + msgpack.size());
    if (!decoder.DecodeAll(check)) {
      throw Error("annotation JSON holds binary values, which metadata JSON cannot", error_path,
                  "", uid);
    }
  }
  if (uid.size() > UINT32_MAX || msgpack.size() > UINT32_MAX || a.arrays.size() > UINT32_MAX) {
    throw Error("metadata record too large", error_path, "", uid);
  }
  std::string rec;
  rec.reserve(kMetaRecordHeader + uid.size() + msgpack.size() + 16);
  Put<uint64_t>(rec, 0);  // checksum, below
  Put<uint32_t>(rec, static_cast<uint32_t>(uid.size()));
  Put<uint32_t>(rec, static_cast<uint32_t>(msgpack.size()));
  Put<uint32_t>(rec, static_cast<uint32_t>(a.arrays.size()));
  Put<uint32_t>(rec, 0);
  rec += uid;
  rec.append(reinterpret_cast<const char*>(msgpack.data()), msgpack.size());
  Pad8(rec);
  for (const auto& [pointer, array] : a.arrays) {
    if (pointer.size() > UINT32_MAX || array.shape.size() > 255) {
      throw Error("array too large to pack", error_path, pointer, uid);
    }
    uint64_t elements = 1;
    for (size_t d : array.shape) elements = SatMul(elements, d);
    if (SatMul(elements, DTypeSize(array.dtype)) != array.data.size()) {
      throw Error("array data is " + std::to_string(array.data.size()) +
                      " bytes, its shape and dtype say " +
                      std::to_string(SatMul(elements, DTypeSize(array.dtype))),
                  error_path, pointer, uid);
    }
    Put<uint32_t>(rec, static_cast<uint32_t>(pointer.size()));
    Put<uint8_t>(rec, static_cast<uint8_t>(array.dtype));
    Put<uint8_t>(rec, static_cast<uint8_t>(array.shape.size()));
    Put<uint16_t>(rec, 0);
    for (size_t d : array.shape) Put<uint64_t>(rec, d);
    rec += pointer;
    Pad8(rec);
    rec.append(reinterpret_cast<const char*>(array.data.data()), array.data.size());
    Pad8(rec);
  }
  PutAt<uint64_t>(rec, 0, XXH3_64bits(rec.data() + 8, rec.size() - 8));
  return rec;
}

/// Interned strings of the index's string section.
class StringTable {
 public:
  std::pair<uint32_t, uint32_t> Add(const std::string& s, const std::string& error_path) {
    auto it = offsets_.find(s);
    if (it != offsets_.end()) return {it->second, static_cast<uint32_t>(s.size())};
    if (data_.size() + s.size() > UINT32_MAX) {
      throw Error("string section over 4 GiB", error_path);
    }
    const auto off = static_cast<uint32_t>(data_.size());
    data_ += s;
    offsets_.emplace(s, off);
    return {off, static_cast<uint32_t>(s.size())};
  }
  const std::string& data() const { return data_; }

 private:
  std::string data_;
  std::unordered_map<std::string, uint32_t> offsets_;
};

}  // namespace

struct PackedStoreWriter::Impl {
  fs::path dir;
  std::string library;
  std::vector<std::string> archives;
  std::deque<WriterEntry> entries;               // stable addresses for `uids`
  std::unordered_set<std::string_view> uids;
  OutFile stream;                                // metadata records in Add order
  bool finished = false;

  std::string MetaPath() const { return (dir / kMetadataStoreFile).string(); }
  std::string IndexPath() const { return (dir / kUidIndexFile).string(); }
  void WriteMetadata(const std::vector<WriterEntry*>& sorted,
                     std::vector<uint64_t>& offsets);
  void WriteIndex(const std::vector<WriterEntry*>& sorted, const std::vector<uint64_t>& offsets);
};

PackedStoreWriter::PackedStoreWriter(fs::path dir, std::string library,
                                     std::vector<std::string> archives)
    : impl_(std::make_unique<Impl>()) {
  impl_->dir = std::move(dir);
  impl_->library = std::move(library);
  impl_->archives = std::move(archives);
  std::error_code ec;
  fs::create_directories(impl_->dir, ec);
  if (ec) throw Error("cannot create folder: " + ec.message(), impl_->dir.string());
  fs::path tmp = impl_->dir / kMetadataStoreFile;
  tmp += TempSuffix();
  impl_->stream.Create(tmp, impl_->MetaPath());
}

PackedStoreWriter::~PackedStoreWriter() = default;

void PackedStoreWriter::Add(const PackedAssetInput& asset) {
  Impl& w = *impl_;
  const std::string index_path = w.IndexPath();
  if (w.finished) throw Error("packed store already finished", index_path, "", asset.uid);
  if (asset.uid.empty()) throw Error("empty UID", index_path);
  if (w.uids.contains(asset.uid)) {
    throw Error("duplicate UID " + asset.uid + " in library " + w.library, index_path, "",
                asset.uid);
  }
  auto check_archive = [&](uint32_t archive, const std::string& what) {
    if (archive >= w.archives.size()) {
      throw Error(what + " archive index " + std::to_string(archive) + " out of range (" +
                      std::to_string(w.archives.size()) + " archives)",
                  index_path, "", asset.uid);
    }
  };
  check_archive(asset.archive, "asset");
  std::vector<PackedAssetInput::Grasps> grasps = asset.grasps;
  std::sort(grasps.begin(), grasps.end(), [](const auto& a, const auto& b) {
    return std::tie(a.robot, a.joint) < std::tie(b.robot, b.joint);
  });
  for (size_t i = 0; i < grasps.size(); ++i) {
    const auto& g = grasps[i];
    check_archive(g.archive, "grasp");
    if (g.robot.empty()) throw Error("grasps with an empty robot name", index_path, "", asset.uid);
    if (g.robot.size() > UINT16_MAX || g.joint.size() > UINT16_MAX) {
      throw Error("robot or joint name longer than 65535 bytes", index_path, "", asset.uid);
    }
    if (static_cast<uint32_t>(g.stored_dtype) > kMaxDType) {
      throw Error("bad grasp dtype", index_path, "", asset.uid);
    }
    if (i > 0 && g.robot == grasps[i - 1].robot && g.joint == grasps[i - 1].joint) {
      throw Error("duplicate grasps for robot " + g.robot +
                      (g.joint.empty() ? std::string(" (pickup)") : " joint " + g.joint),
                  index_path, "", asset.uid);
    }
  }
  WriterEntry entry;
  if (asset.annotation != nullptr) {
    const std::string rec = EncodeMetadataRecord(asset.uid, *asset.annotation, w.MetaPath());
    entry.tmp_offset = w.stream.size();
    entry.tmp_size = rec.size();
    w.stream.Write(rec);
  }
  entry.uid = asset.uid;
  entry.mjcf = asset.mjcf;
  entry.archive = asset.archive;
  entry.grasps = std::move(grasps);
  w.entries.push_back(std::move(entry));
  w.uids.insert(w.entries.back().uid);
}

void PackedStoreWriter::Impl::WriteMetadata(const std::vector<WriterEntry*>& sorted,
                                            std::vector<uint64_t>& offsets) {
  stream.Flush();
  const uint64_t stream_size = stream.size();
  // Map the stream file and copy its records out in UID order: the output does not depend
  // on the order of Add calls.
  const uint8_t* src = nullptr;
  if (stream_size > 0) {
    void* addr = ::mmap(nullptr, stream_size, PROT_READ, MAP_SHARED, stream.fd(), 0);
    if (addr == MAP_FAILED) {
      throw Error(std::string("cannot map temp file: ") + std::strerror(errno), MetaPath());
    }
    src = static_cast<const uint8_t*>(addr);
  }
  struct Unmap {
    const uint8_t* p;
    uint64_t n;
    ~Unmap() {
      if (p != nullptr) ::munmap(const_cast<uint8_t*>(p), n);
    }
  } unmap{src, stream_size};

  const fs::path dest = dir / kMetadataStoreFile;
  fs::path tmp = dest;
  tmp += TempSuffix();
  OutFile out;
  out.Create(tmp, MetaPath());
  out.Write(std::string(kHeaderSize, '\0'));
  XXH3_state_t* state = XXH3_createState();
  if (state == nullptr) throw std::bad_alloc();
  struct FreeState {
    XXH3_state_t* s;
    ~FreeState() { XXH3_freeState(s); }
  } free_state{state};
  XXH3_64bits_reset(state);
  uint32_t num_records = 0;
  offsets.assign(sorted.size(), 0);
  for (size_t i = 0; i < sorted.size(); ++i) {
    const WriterEntry& e = *sorted[i];
    if (e.tmp_size == 0) continue;
    offsets[i] = out.size();
    out.Write(src + e.tmp_offset, e.tmp_size);
    XXH3_64bits_update(state, src + e.tmp_offset, e.tmp_size);
    ++num_records;
  }
  out.Flush();
  std::string header;
  header.append(kMetaMagic, 8);
  Put<uint32_t>(header, kFormatVersion);
  Put<uint32_t>(header, num_records);
  Put<uint64_t>(header, out.size());
  Put<uint64_t>(header, kHeaderSize);
  Put<uint64_t>(header, out.size() - kHeaderSize);
  Put<uint32_t>(header, kJsonMsgpack);
  Put<uint32_t>(header, 0);
  Put<uint64_t>(header, 0);
  Put<uint64_t>(header, XXH3_64bits_digest(state));
  out.WriteAt(0, header);
  out.Commit(dest);
}

void PackedStoreWriter::Impl::WriteIndex(const std::vector<WriterEntry*>& sorted,
                                         const std::vector<uint64_t>& offsets) {
  const std::string path = IndexPath();
  const uint64_t n = sorted.size();
  if (n > UINT32_MAX / 4) throw Error("too many assets for one index", path);
  uint64_t buckets = 2;
  while (buckets < 2 * n) buckets *= 2;

  std::set<std::string> robot_set;
  uint64_t num_grasps = 0;
  for (const WriterEntry* e : sorted) {
    for (const auto& g : e->grasps) robot_set.insert(g.robot);
    num_grasps += e->grasps.size();
  }
  if (num_grasps > UINT32_MAX) throw Error("too many grasp sets for one index", path);

  StringTable strings;
  std::vector<std::pair<uint32_t, uint32_t>> names;
  for (const std::string& a : archives) names.push_back(strings.Add(a, path));
  for (const std::string& r : robot_set) names.push_back(strings.Add(r, path));

  const uint64_t records_off = kHeaderSize + buckets * kBucketSize;
  const uint64_t grasps_off = records_off + n * kRecordSize;
  const uint64_t names_off = grasps_off + num_grasps * kGraspRefSize;
  const uint64_t strings_off = Align8(names_off + names.size() * kNameSize);

  std::string records, grasp_refs;
  records.reserve(n * kRecordSize);
  grasp_refs.reserve(num_grasps * kGraspRefSize);
  std::vector<uint64_t> table(buckets, 0);
  // All UIDs together, then all MJCF paths: Find compares only UIDs, so the pages it
  // touches (and keeps resident) are the 5 MB of UIDs, not the whole string section.
  std::vector<std::pair<uint32_t, uint32_t>> uid_refs(n), mjcf_refs(n);
  for (uint64_t i = 0; i < n; ++i) uid_refs[i] = strings.Add(sorted[i]->uid, path);
  for (uint64_t i = 0; i < n; ++i) mjcf_refs[i] = strings.Add(sorted[i]->mjcf, path);
  uint32_t first_grasp = 0;
  for (uint64_t i = 0; i < n; ++i) {
    const WriterEntry& e = *sorted[i];
    const auto uid = uid_refs[i];
    const auto mjcf = mjcf_refs[i];
    Put<uint32_t>(records, uid.first);
    Put<uint32_t>(records, uid.second);
    Put<uint32_t>(records, mjcf.first);
    Put<uint32_t>(records, mjcf.second);
    Put<uint64_t>(records, offsets[i]);
    Put<uint64_t>(records, e.tmp_size);
    Put<uint32_t>(records, e.archive);
    Put<uint32_t>(records, first_grasp);
    Put<uint32_t>(records, static_cast<uint32_t>(e.grasps.size()));
    Put<uint32_t>(records, 0);
    for (const auto& g : e.grasps) {
      const auto robot = strings.Add(g.robot, path);
      const auto joint = strings.Add(g.joint, path);
      Put<uint32_t>(grasp_refs, robot.first);
      Put<uint32_t>(grasp_refs, joint.first);
      Put<uint16_t>(grasp_refs, static_cast<uint16_t>(robot.second));
      Put<uint16_t>(grasp_refs, static_cast<uint16_t>(joint.second));
      Put<uint32_t>(grasp_refs, g.archive);
      Put<uint64_t>(grasp_refs, g.offset);
      Put<uint32_t>(grasp_refs, g.count);
      Put<uint8_t>(grasp_refs, static_cast<uint8_t>(g.stored_dtype));
      grasp_refs.append(3, '\0');
    }
    first_grasp += static_cast<uint32_t>(e.grasps.size());
    // Linear probing; records go in in UID order, so the table is deterministic.
    const uint64_t h = HashUid(e.uid);
    uint64_t b = h & (buckets - 1);
    while (table[b] != 0) b = (b + 1) & (buckets - 1);
    table[b] = (i + 1) | ((h >> 32) << 32);
  }
  const uint64_t file_size = Align8(strings_off + strings.data().size());
  if (file_size > UINT32_MAX) throw Error("index over 4 GiB", path);

  std::string out;
  out.reserve(file_size);
  out.append(kIndexMagic, 8);
  Put<uint32_t>(out, kFormatVersion);
  Put<uint32_t>(out, static_cast<uint32_t>(n));
  Put<uint64_t>(out, file_size);
  Put<uint32_t>(out, static_cast<uint32_t>(buckets));
  Put<uint32_t>(out, static_cast<uint32_t>(num_grasps));
  Put<uint32_t>(out, static_cast<uint32_t>(archives.size()));
  Put<uint32_t>(out, static_cast<uint32_t>(robot_set.size()));
  Put<uint32_t>(out, static_cast<uint32_t>(records_off));
  Put<uint32_t>(out, static_cast<uint32_t>(grasps_off));
  Put<uint32_t>(out, static_cast<uint32_t>(names_off));
  Put<uint32_t>(out, static_cast<uint32_t>(strings_off));
  Put<uint64_t>(out, 0);  // checksum, below
  for (uint64_t v : table) Put<uint64_t>(out, v);
  out += records;
  out += grasp_refs;
  for (const auto& [off, len] : names) {
    Put<uint32_t>(out, off);
    Put<uint32_t>(out, len);
  }
  Pad8(out);
  out += strings.data();
  Pad8(out);
  PutAt<uint64_t>(out, kIdxChecksum, XXH3_64bits(out.data() + kHeaderSize, out.size() - kHeaderSize));
  WriteFileAtomic(dir / kUidIndexFile, out, true);
}

void PackedStoreWriter::Finish() {
  Impl& w = *impl_;
  if (w.finished) throw Error("packed store already finished", w.IndexPath());
  std::vector<WriterEntry*> sorted;
  sorted.reserve(w.entries.size());
  for (WriterEntry& e : w.entries) sorted.push_back(&e);
  std::sort(sorted.begin(), sorted.end(),
            [](const WriterEntry* a, const WriterEntry* b) { return a->uid < b->uid; });
  std::vector<uint64_t> offsets;
  w.WriteMetadata(sorted, offsets);
  w.WriteIndex(sorted, offsets);
  FsyncPath(w.dir, true, w.dir.string());
  w.stream.Abandon();  // the stream temp file is not needed any more
  w.finished = true;
}

// =============================================================================================
// PackedLibrary

namespace {

/// A mapped grasp shard, validated at first use.
struct Shard {
  Mapping map;
  uint64_t poses_end = 0;
};

}  // namespace

struct PackedLibrary::Impl {
  std::string name;
  fs::path dir;
  std::string index_path, meta_path;
  Mapping index, meta;
  std::vector<std::string> archives;

  // Index header.
  uint32_t num_assets = 0, num_buckets = 0, num_grasps = 0, num_archives = 0, num_robots = 0;
  const uint8_t* buckets = nullptr;
  const uint8_t* records = nullptr;
  const uint8_t* grasps = nullptr;
  const uint8_t* names = nullptr;
  const uint8_t* strings = nullptr;
  uint64_t strings_size = 0;
  // Metadata header.
  uint64_t meta_records_end = 0;

  // Grasp shards, mapped on first use. The pointers are read lock-free; the mutex only
  // serialises first opens.
  std::unique_ptr<std::atomic<const Shard*>[]> shards;
  mutable std::vector<std::unique_ptr<Shard>> owned_shards;
  mutable std::mutex shard_mutex;

  [[noreturn]] void Damaged(const std::string& what, std::string_view uid = {}) const {
    throw Error("damaged index: " + what, index_path, "", std::string(uid));
  }
  std::string_view Str(uint64_t off, uint64_t len, const char* what) const {
    if (SatAdd(off, len) > strings_size) {
      Damaged(std::string(what) + " string out of bounds");
    }
    return {reinterpret_cast<const char*>(strings + off), static_cast<size_t>(len)};
  }
  std::string_view Name(uint32_t i) const {
    const uint8_t* p = names + uint64_t{i} * kNameSize;
    return Str(Load<uint32_t>(p), Load<uint32_t>(p + 4), "name");
  }
  std::string_view RecordUid(uint32_t r) const {
    const uint8_t* p = records + uint64_t{r} * kRecordSize;
    return Str(Load<uint32_t>(p), Load<uint32_t>(p + 4), "UID");
  }
  PackedAsset Record(uint32_t r) const;
  const Shard& GetShard(uint32_t archive) const;
};

PackedAsset PackedLibrary::Impl::Record(uint32_t r) const {
  const uint8_t* p = records + uint64_t{r} * kRecordSize;
  PackedAsset a;
  a.uid = Str(Load<uint32_t>(p), Load<uint32_t>(p + 4), "UID");
  a.mjcf = Str(Load<uint32_t>(p + 8), Load<uint32_t>(p + 12), "MJCF path");
  a.metadata_offset = Load<uint64_t>(p + 16);
  a.metadata_size = Load<uint64_t>(p + 24);
  a.archive = Load<uint32_t>(p + 32);
  a.first_grasp = Load<uint32_t>(p + 36);
  a.num_grasps = Load<uint32_t>(p + 40);
  if (a.archive >= num_archives) Damaged("archive index out of range", a.uid);
  if (uint64_t{a.first_grasp} + a.num_grasps > num_grasps) {
    Damaged("grasp range out of bounds", a.uid);
  }
  if (a.metadata_size != 0 &&
      (a.metadata_offset < kHeaderSize || a.metadata_offset % 8 != 0 ||
       a.metadata_size < kMetaRecordHeader || SatAdd(a.metadata_offset, a.metadata_size) >
                                                  meta_records_end)) {
    Damaged("metadata record out of bounds of " + meta_path, a.uid);
  }
  return a;
}

PackedLibrary::PackedLibrary() : impl_(std::make_unique<Impl>()) {}
PackedLibrary::~PackedLibrary() = default;

std::shared_ptr<const PackedLibrary> PackedLibrary::Open(const fs::path& dir, std::string name,
                                                         const fs::path& root) {
  std::shared_ptr<PackedLibrary> lib(new PackedLibrary());
  Impl& m = *lib->impl_;
  m.name = std::move(name);
  m.dir = root.empty() ? dir : root;
  const fs::path index_path = dir / kUidIndexFile, meta_path = dir / kMetadataStoreFile;
  m.index_path = index_path.string();
  m.meta_path = meta_path.string();

  // uid_index.mlsx
  m.index.Open(index_path, "packed store index not found", MADV_RANDOM);
  const uint8_t* h = m.index.data();
  CheckMagic(h, kIndexMagic, index_path);
  const uint64_t file_size = Load<uint64_t>(h + kIdxFileSize);
  if (file_size != m.index.size()) {
    throw Error("truncated or extended: header says " + std::to_string(file_size) +
                    " bytes, file has " + std::to_string(m.index.size()),
                m.index_path);
  }
  m.num_assets = Load<uint32_t>(h + kIdxNumAssets);
  m.num_buckets = Load<uint32_t>(h + kIdxNumBuckets);
  m.num_grasps = Load<uint32_t>(h + kIdxNumGrasps);
  m.num_archives = Load<uint32_t>(h + kIdxNumArchives);
  m.num_robots = Load<uint32_t>(h + kIdxNumRobots);
  const uint64_t records_off = Load<uint32_t>(h + kIdxRecordsOff);
  const uint64_t grasps_off = Load<uint32_t>(h + kIdxGraspsOff);
  const uint64_t names_off = Load<uint32_t>(h + kIdxNamesOff);
  const uint64_t strings_off = Load<uint32_t>(h + kIdxStringsOff);
  if (m.num_buckets < 2 || !std::has_single_bit(m.num_buckets) ||
      uint64_t{m.num_buckets} < 2 * uint64_t{m.num_assets}) {
    throw Error("bad header: " + std::to_string(m.num_buckets) + " buckets for " +
                    std::to_string(m.num_assets) + " assets",
                m.index_path);
  }
  const uint64_t num_names = uint64_t{m.num_archives} + m.num_robots;
  if (records_off != kHeaderSize + uint64_t{m.num_buckets} * kBucketSize ||
      grasps_off != records_off + uint64_t{m.num_assets} * kRecordSize ||
      names_off != grasps_off + uint64_t{m.num_grasps} * kGraspRefSize ||
      strings_off != Align8(names_off + num_names * kNameSize) || strings_off > file_size) {
    throw Error("bad header: section offsets do not match the counts or the file size",
                m.index_path);
  }
  m.buckets = h + kHeaderSize;
  m.records = h + records_off;
  m.grasps = h + grasps_off;
  m.names = h + names_off;
  m.strings = h + strings_off;
  m.strings_size = file_size - strings_off;
  m.archives.reserve(m.num_archives);
  for (uint32_t i = 0; i < m.num_archives; ++i) m.archives.emplace_back(m.Name(i));
  m.shards = std::make_unique<std::atomic<const Shard*>[]>(m.num_archives);
  for (uint32_t i = 0; i < m.num_archives; ++i) m.shards[i].store(nullptr);

  // metadata.mlsm
  m.meta.Open(meta_path, "packed metadata store not found", MADV_RANDOM);
  const uint8_t* mh = m.meta.data();
  CheckMagic(mh, kMetaMagic, meta_path);
  const uint64_t meta_size = Load<uint64_t>(mh + kMetaFileSize);
  if (meta_size != m.meta.size()) {
    throw Error("truncated or extended: header says " + std::to_string(meta_size) +
                    " bytes, file has " + std::to_string(m.meta.size()),
                m.meta_path);
  }
  if (Load<uint64_t>(mh + kMetaRecordsOff) != kHeaderSize ||
      Load<uint64_t>(mh + kMetaRecordsSize) != meta_size - kHeaderSize) {
    throw Error("bad header: record section does not match the file size", m.meta_path);
  }
  if (Load<uint32_t>(mh + kMetaEncoding + 4) != 0 || Load<uint64_t>(mh + kMetaEncoding + 8) != 0) {
    throw Error("bad header: reserved bytes are not zero", m.meta_path);
  }
  const uint32_t encoding = Load<uint32_t>(mh + kMetaEncoding);
  if (encoding != kJsonMsgpack) {
    throw Error("unsupported JSON encoding " + std::to_string(encoding), m.meta_path);
  }
  m.meta_records_end = meta_size;
  return lib;
}

const std::string& PackedLibrary::name() const { return impl_->name; }
const fs::path& PackedLibrary::dir() const { return impl_->dir; }
size_t PackedLibrary::size() const { return impl_->num_assets; }
std::span<const std::string> PackedLibrary::archives() const { return impl_->archives; }

std::vector<std::string> PackedLibrary::robots() const {
  std::vector<std::string> out;
  out.reserve(impl_->num_robots);
  for (uint32_t i = 0; i < impl_->num_robots; ++i) {
    out.emplace_back(impl_->Name(impl_->num_archives + i));
  }
  return out;
}

std::optional<PackedAsset> PackedLibrary::Find(std::string_view uid) const {
  const Impl& m = *impl_;
  const uint64_t h = HashUid(uid);
  const auto tag = static_cast<uint32_t>(h >> 32);
  const uint64_t mask = m.num_buckets - 1;
  uint64_t b = h & mask;
  // At most num_buckets probes: a damaged table with no empty bucket still ends.
  for (uint64_t probe = 0; probe < m.num_buckets; ++probe, b = (b + 1) & mask) {
    const uint64_t bucket = Load<uint64_t>(m.buckets + b * kBucketSize);
    const auto rec1 = static_cast<uint32_t>(bucket);
    if (rec1 == 0) return std::nullopt;
    if (static_cast<uint32_t>(bucket >> 32) != tag) continue;
    const uint32_t r = rec1 - 1;
    if (r >= m.num_assets) m.Damaged("bucket " + std::to_string(b) + " points past the records");
    if (m.RecordUid(r) == uid) return m.Record(r);
  }
  return std::nullopt;
}

PackedAsset PackedLibrary::At(size_t i) const {
  if (i >= impl_->num_assets) {
    throw Error("asset index " + std::to_string(i) + " out of range (" +
                    std::to_string(impl_->num_assets) + " assets)",
                impl_->index_path);
  }
  return impl_->Record(static_cast<uint32_t>(i));
}

std::vector<PackedGraspRef> PackedLibrary::Grasps(const PackedAsset& asset) const {
  const Impl& m = *impl_;
  if (uint64_t{asset.first_grasp} + asset.num_grasps > m.num_grasps) {
    throw Error("grasp range out of bounds", m.index_path, "", std::string(asset.uid));
  }
  std::vector<PackedGraspRef> out;
  out.reserve(asset.num_grasps);
  for (uint32_t i = 0; i < asset.num_grasps; ++i) {
    const uint8_t* p = m.grasps + (uint64_t{asset.first_grasp} + i) * kGraspRefSize;
    PackedGraspRef ref;
    ref.robot = m.Str(Load<uint32_t>(p), Load<uint16_t>(p + 8), "robot");
    ref.joint = m.Str(Load<uint32_t>(p + 4), Load<uint16_t>(p + 10), "joint");
    ref.archive = Load<uint32_t>(p + 12);
    ref.offset = Load<uint64_t>(p + 16);
    ref.count = Load<uint32_t>(p + 24);
    const uint8_t dtype = p[28];
    if (ref.archive >= m.num_archives) m.Damaged("grasp archive index out of range", asset.uid);
    if (dtype > kMaxDType) m.Damaged("bad grasp dtype", asset.uid);
    ref.stored_dtype = static_cast<DType>(dtype);
    out.push_back(ref);
  }
  return out;
}

std::optional<PackedGraspRef> PackedLibrary::FindGrasps(const PackedAsset& asset,
                                                        std::string_view robot,
                                                        std::string_view joint) const {
  for (const PackedGraspRef& ref : Grasps(asset)) {
    if (ref.robot == robot && ref.joint == joint) return ref;
  }
  return std::nullopt;
}

std::shared_ptr<const Annotation> PackedLibrary::LoadAnnotation(const PackedAsset& asset) const {
  const Impl& m = *impl_;
  if (asset.metadata_size == 0) return nullptr;
  const std::string uid(asset.uid);
  auto bad = [&](const std::string& what, const std::string& field = {}) -> Error {
    return Error("damaged metadata record: " + what, m.meta_path, field, uid);
  };
  if (asset.metadata_offset < kHeaderSize || asset.metadata_offset % 8 != 0 ||
      asset.metadata_size < kMetaRecordHeader ||
      SatAdd(asset.metadata_offset, asset.metadata_size) > m.meta_records_end) {
    throw bad("out of bounds");
  }
  const uint8_t* rec = m.meta.data() + asset.metadata_offset;
  const uint64_t size = asset.metadata_size;
  if (Load<uint64_t>(rec) != XXH3_64bits(rec + 8, size - 8)) throw bad("checksum mismatch");
  const uint64_t uid_len = Load<uint32_t>(rec + 8);
  const uint64_t json_len = Load<uint32_t>(rec + 12);
  const uint64_t num_arrays = Load<uint32_t>(rec + 16);
  uint64_t pos = kMetaRecordHeader;
  if (SatAdd(pos, SatAdd(uid_len, json_len)) > size) throw bad("lengths past its end");
  if (std::string_view(reinterpret_cast<const char*>(rec + pos), uid_len) != asset.uid) {
    throw bad("it belongs to another UID (index and metadata store do not match)");
  }
  pos += uid_len;
  auto out = std::make_shared<Annotation>();
  out->uid = uid;
  out->library = m.name;
  MsgpackDecoder decoder(rec + pos, rec + pos + json_len);
  if (!decoder.DecodeAll(out->json)) throw bad("bad MessagePack JSON");
  pos = Align8(pos + json_len);
  // Every array takes at least its 8-byte header: a damaged count cannot reserve more.
  out->arrays.reserve(std::min<uint64_t>(num_arrays, size / kArrayHeader));
  for (uint64_t a = 0; a < num_arrays; ++a) {
    const std::string field = "array " + std::to_string(a);
    if (SatAdd(pos, kArrayHeader) > size) throw bad("array header past its end", field);
    const uint64_t pointer_len = Load<uint32_t>(rec + pos);
    const uint8_t dtype = rec[pos + 4];
    const uint64_t ndim = rec[pos + 5];
    pos += kArrayHeader;
    if (dtype > kMaxDType) throw bad("bad dtype " + std::to_string(dtype), field);
    if (SatAdd(pos, SatAdd(ndim * 8, pointer_len)) > size) throw bad("array past its end", field);
    NpyArray array;
    array.dtype = static_cast<DType>(dtype);
    array.shape.resize(ndim);
    uint64_t elements = 1;
    for (uint64_t d = 0; d < ndim; ++d) {
      const uint64_t dim = Load<uint64_t>(rec + pos + d * 8);
      array.shape[d] = static_cast<size_t>(dim);
      elements = SatMul(elements, dim);
    }
    pos += ndim * 8;
    std::string pointer(reinterpret_cast<const char*>(rec + pos), pointer_len);
    pos = Align8(pos + pointer_len);
    const uint64_t bytes = SatMul(elements, DTypeSize(array.dtype));
    if (SatAdd(pos, bytes) > size) throw bad("array data past its end", pointer);
    array.data.assign(rec + pos, rec + pos + bytes);
    pos = Align8(pos + bytes);
    out->arrays.emplace_back(std::move(pointer), std::move(array));
  }
  if (pos != size) throw bad("record size does not match its contents");
  return out;
}

fs::path PackedLibrary::GraspShardPath(uint32_t archive) const {
  const Impl& m = *impl_;
  if (archive >= m.num_archives) {
    throw Error("archive index " + std::to_string(archive) + " out of range (" +
                    std::to_string(m.num_archives) + " archives)",
                m.index_path);
  }
  return m.dir / GraspShardMember(m.archives[archive]);
}

const Shard& PackedLibrary::Impl::GetShard(uint32_t archive) const {
  if (const Shard* s = shards[archive].load(std::memory_order_acquire)) return *s;
  std::lock_guard<std::mutex> lock(shard_mutex);
  if (const Shard* s = shards[archive].load(std::memory_order_acquire)) return *s;
  const fs::path path = dir / GraspShardMember(archives[archive]);
  auto shard = std::make_unique<Shard>();
  shard->map.Open(path, "grasp shard " + path.string() +
                            " is not installed (install the UID first)",
                  MADV_NORMAL);
  const uint8_t* h = shard->map.data();
  CheckMagic(h, kShardMagic, path);
  const uint64_t file_size = Load<uint64_t>(h + kShardFileSize);
  const uint64_t num_poses = Load<uint64_t>(h + kShardNumPoses);
  if (file_size != shard->map.size()) {
    throw Error("truncated or extended: header says " + std::to_string(file_size) +
                    " bytes, file has " + std::to_string(shard->map.size()),
                path.string());
  }
  bool reserved_zero = Load<uint32_t>(h + 12) == 0;
  for (size_t off = kShardPosesOff + 8; off < kHeaderSize; off += 8) {
    reserved_zero = reserved_zero && Load<uint64_t>(h + off) == 0;
  }
  if (!reserved_zero) throw Error("bad header: reserved bytes are not zero", path.string());
  if (Load<uint64_t>(h + kShardPosesOff) != kHeaderSize ||
      SatAdd(kHeaderSize, SatMul(num_poses, kPoseSize)) != file_size) {
    throw Error("bad header: pose count does not match the file size", path.string());
  }
  shard->poses_end = file_size;
  const Shard* raw = shard.get();
  owned_shards.push_back(std::move(shard));
  shards[archive].store(raw, std::memory_order_release);
  return *raw;
}

std::vector<Mat4> PackedLibrary::ReadGrasps(const PackedGraspRef& ref,
                                            const std::vector<size_t>* rows) const {
  const Impl& m = *impl_;
  if (ref.archive >= m.num_archives) {
    throw Error("grasp archive index " + std::to_string(ref.archive) + " out of range",
                m.index_path);
  }
  const Shard& shard = m.GetShard(ref.archive);
  auto shard_path = [&] { return GraspShardPath(ref.archive).string(); };
  if (ref.offset < kHeaderSize || (ref.offset - kHeaderSize) % kPoseSize != 0 ||
      SatAdd(ref.offset, SatMul(ref.count, kPoseSize)) > shard.poses_end) {
    throw Error("grasps at offset " + std::to_string(ref.offset) + " (" +
                    std::to_string(ref.count) + " poses) are outside the shard (" +
                    std::to_string(shard.poses_end) + " bytes)",
                shard_path());
  }
  const uint8_t* base = shard.map.data() + ref.offset;
  const size_t n = rows != nullptr ? rows->size() : ref.count;
  std::vector<Mat4> out(n);
  for (size_t i = 0; i < n; ++i) {
    const size_t row = rows != nullptr ? (*rows)[i] : i;
    if (row >= ref.count) {
      throw Error("grasp row " + std::to_string(row) + " out of range (" +
                      std::to_string(ref.count) + " poses)",
                  shard_path());
    }
    std::memcpy(out[i].m.data(), base + row * kPoseSize, kPoseSize);
    for (double v : out[i].m) {
      if (!std::isfinite(v)) {
        throw Error("non-finite value in grasp pose " + std::to_string(row) + " of robot " +
                        std::string(ref.robot) +
                        (ref.joint.empty() ? std::string() : " joint " + std::string(ref.joint)),
                    shard_path());
      }
    }
  }
  return out;
}

void PackedLibrary::Check() const {
  const Impl& m = *impl_;
  const uint8_t* h = m.index.data();
  if (Load<uint64_t>(h + kIdxChecksum) !=
      XXH3_64bits(h + kHeaderSize, m.index.size() - kHeaderSize)) {
    throw Error("checksum mismatch", m.index_path);
  }
  const uint8_t* mh = m.meta.data();
  if (Load<uint64_t>(mh + kMetaChecksum) !=
      XXH3_64bits(mh + kHeaderSize, m.meta.size() - kHeaderSize)) {
    throw Error("checksum mismatch", m.meta_path);
  }
  std::vector<std::string> robots_list = robots();
  for (size_t i = 1; i < robots_list.size(); ++i) {
    if (!(robots_list[i - 1] < robots_list[i])) m.Damaged("robot names not sorted");
  }
  uint64_t used = 0;
  for (uint64_t b = 0; b < m.num_buckets; ++b) {
    const uint64_t bucket = Load<uint64_t>(m.buckets + b * kBucketSize);
    const auto rec1 = static_cast<uint32_t>(bucket);
    if (rec1 == 0) continue;
    ++used;
    if (rec1 - 1 >= m.num_assets) m.Damaged("bucket points past the records");
    const std::string_view uid = m.RecordUid(rec1 - 1);
    if (static_cast<uint32_t>(bucket >> 32) != static_cast<uint32_t>(HashUid(uid) >> 32)) {
      m.Damaged("bucket tag does not match its UID", uid);
    }
  }
  if (used != m.num_assets) m.Damaged("bucket count does not match the asset count");
  uint64_t next_grasp = 0, num_records = 0;
  std::string_view previous;
  for (uint32_t i = 0; i < m.num_assets; ++i) {
    const PackedAsset a = m.Record(i);
    if (i > 0 && !(previous < a.uid)) m.Damaged("UIDs not sorted", a.uid);
    previous = a.uid;
    const std::optional<PackedAsset> found = Find(a.uid);
    if (!found || found->uid.data() != a.uid.data()) m.Damaged("UID not found by hash", a.uid);
    if (a.first_grasp != next_grasp) m.Damaged("grasp ranges not contiguous", a.uid);
    next_grasp += a.num_grasps;
    const std::vector<PackedGraspRef> refs = Grasps(a);
    for (size_t g = 1; g < refs.size(); ++g) {
      if (!(std::tie(refs[g - 1].robot, refs[g - 1].joint) < std::tie(refs[g].robot, refs[g].joint))) {
        m.Damaged("grasp refs not sorted", a.uid);
      }
    }
    if (a.metadata_size != 0) {
      LoadAnnotation(a);
      ++num_records;
    }
  }
  if (next_grasp != m.num_grasps) m.Damaged("grasp refs not all used");
  if (num_records != Load<uint32_t>(mh + kMetaNumRecords)) {
    throw Error("record count does not match the index", m.meta_path);
  }
}

std::string ArchiveStem(const std::string& archive) {
  constexpr std::string_view kTarZst = ".tar.zst";
  if (archive.size() > kTarZst.size() && archive.ends_with(kTarZst)) {
    return archive.substr(0, archive.size() - kTarZst.size());
  }
  return fs::path(archive).stem().string();
}

std::string GraspShardMember(const std::string& archive) {
  return std::string(kGraspShardDir) + "/" + ArchiveStem(archive) +
         std::string(kGraspShardExtension);
}

std::string ExtractFlagName(const std::string& archive) {
  std::string name = archive;
  for (size_t pos = 0; (pos = name.find('/', pos)) != std::string::npos; pos += 2) {
    name.replace(pos, 1, "__");
  }
  return "." + name + "_complete_extract";
}

}  // namespace mlspaces
