// The packed-store reader (include/mlspaces/library/packed_store.h; byte layout in
// docs/formats.md, "Packed stores"): uid_index.mlsx, metadata.mlsm and the per-archive grasp
// shards .mlsg, mapped read-only and checked before use. The writers are in
// src/resources/packed_store_writer.cc, the metadata JSON decoder in msgpack.cc.
#include "mlspaces/library/packed_store.h"

#include <sys/mman.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <mutex>
#include <tuple>

#include "mlspaces/core/error.h"
#include "mlspaces/library/annotation.h"
#include "mlspaces/library/msgpack.h"
#include "mlspaces/library/package_layout.h"
#include "mlspaces/library/packed_format.h"
#include "packed_io.h"

namespace mlspaces {
namespace fs = std::filesystem;
using namespace packed;  // NOLINT(google-build-using-namespace): the layout's own names

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
  if (a.metadata_size != 0 && (a.metadata_offset < kHeaderSize || a.metadata_offset % 8 != 0 ||
                               a.metadata_size < kMetaRecordHeader ||
                               SatAdd(a.metadata_offset, a.metadata_size) > meta_records_end)) {
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
  if (Load<uint64_t>(rec) != Checksum(rec + 8, size - 8)) throw bad("checksum mismatch");
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
  if (!DecodeMsgpackJson({rec + pos, static_cast<size_t>(json_len)}, out->json)) {
    throw bad("bad MessagePack JSON");
  }
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
  shard->map.Open(path,
                  "grasp shard " + path.string() + " is not installed (install the UID first)",
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
  if (Load<uint64_t>(h + kIdxChecksum) != Checksum(h + kHeaderSize, m.index.size() - kHeaderSize)) {
    throw Error("checksum mismatch", m.index_path);
  }
  const uint8_t* mh = m.meta.data();
  if (Load<uint64_t>(mh + kMetaChecksum) !=
      Checksum(mh + kHeaderSize, m.meta.size() - kHeaderSize)) {
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
      if (!(std::tie(refs[g - 1].robot, refs[g - 1].joint) <
            std::tie(refs[g].robot, refs[g].joint))) {
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

}  // namespace mlspaces
