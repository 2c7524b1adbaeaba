// The packed-store writers (include/mlspaces/resources/packed_store_writer.h; byte layout in
// docs/formats.md, "Packed stores"): grasp shards, metadata.mlsm and uid_index.mlsx, each
// written to a temp file and renamed into place. The reader is src/library/packed_store.cc.
#include "mlspaces/resources/packed_store_writer.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <deque>
#include <set>
#include <tuple>
#include <unordered_map>
#include <unordered_set>

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/library/annotation.h"
#include "mlspaces/library/msgpack.h"
#include "mlspaces/library/package_layout.h"
#include "mlspaces/library/packed_format.h"

namespace mlspaces {
namespace fs = std::filesystem;
using namespace packed;  // NOLINT(google-build-using-namespace): the layout's own names

namespace {

// ---------------------------------------------------------------------------------------------
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
        throw Error("non-finite value in grasp pose " + std::to_string(i), impl_->path.string());
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
    if (!DecodeMsgpackJson(msgpack, check)) {
      throw Error("annotation JSON holds binary values, which metadata JSON cannot", error_path, "",
                  uid);
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
  std::deque<WriterEntry> entries;  // stable addresses for `uids`
  std::unordered_set<std::string_view> uids;
  OutFile stream;  // metadata records in Add order
  bool finished = false;

  std::string MetaPath() const { return (dir / kMetadataStoreFile).string(); }
  std::string IndexPath() const { return (dir / kUidIndexFile).string(); }
  void WriteMetadata(const std::vector<WriterEntry*>& sorted, std::vector<uint64_t>& offsets);
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
  PutAt<uint64_t>(out, kIdxChecksum,
                  XXH3_64bits(out.data() + kHeaderSize, out.size() - kHeaderSize));
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

}  // namespace mlspaces
