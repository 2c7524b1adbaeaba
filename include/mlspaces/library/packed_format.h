// Byte layout of the packed stores (docs/formats.md, "Packed stores"): magics, sizes, header
// field offsets and the little-endian load/store helpers the reader (library) and the writers
// (resources, `mlspaces pack`) share. Storage internals: the lookup API (packed_store.h,
// registry.h) does not include this header; only the code that reads or writes the bytes does.
#pragma once

#include "mlspaces/core/export.h"

#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>

#include "mlspaces/core/npy.h"

namespace mlspaces::packed {

static_assert(std::endian::native == std::endian::little,
              "packed stores are read in place: little-endian hosts only");

inline constexpr char kIndexMagic[8] = {'M', 'L', 'S', 'U', 'I', 'D', 'X', '1'};
inline constexpr char kMetaMagic[8] = {'M', 'L', 'S', 'M', 'E', 'T', 'A', '1'};
inline constexpr char kShardMagic[8] = {'M', 'L', 'S', 'G', 'R', 'S', 'P', '1'};
inline constexpr uint32_t kFormatVersion = 1;
inline constexpr uint32_t kJsonMsgpack = 1;  // metadata.mlsm json_encoding

inline constexpr uint64_t kHeaderSize = 64;
inline constexpr uint64_t kBucketSize = 8;
inline constexpr uint64_t kRecordSize = 48;
inline constexpr uint64_t kGraspRefSize = 32;
inline constexpr uint64_t kNameSize = 8;
inline constexpr uint64_t kPoseSize = 16 * sizeof(double);
inline constexpr uint64_t kMetaRecordHeader = 24;
inline constexpr uint64_t kArrayHeader = 8;
/// Largest DType value a store may name.
inline constexpr uint32_t kMaxDType = static_cast<uint32_t>(DType::kB1);

// uid_index.mlsx header fields.
inline constexpr size_t kIdxVersion = 8, kIdxNumAssets = 12, kIdxFileSize = 16, kIdxNumBuckets = 24,
                        kIdxNumGrasps = 28, kIdxNumArchives = 32, kIdxNumRobots = 36,
                        kIdxRecordsOff = 40, kIdxGraspsOff = 44, kIdxNamesOff = 48,
                        kIdxStringsOff = 52, kIdxChecksum = 56;
// metadata.mlsm header fields.
inline constexpr size_t kMetaVersion = 8, kMetaNumRecords = 12, kMetaFileSize = 16,
                        kMetaRecordsOff = 24, kMetaRecordsSize = 32, kMetaEncoding = 40,
                        kMetaChecksum = 56;
// .mlsg header fields.
inline constexpr size_t kShardVersion = 8, kShardFileSize = 16, kShardNumPoses = 24,
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

inline void Pad8(std::string& out) { out.append(Align8(out.size()) - out.size(), '\0'); }

/// a + b, or UINT64_MAX on overflow (callers compare against a size, so the max fails).
inline uint64_t SatAdd(uint64_t a, uint64_t b) {
  uint64_t r;
  return __builtin_add_overflow(a, b, &r) ? std::numeric_limits<uint64_t>::max() : r;
}
inline uint64_t SatMul(uint64_t a, uint64_t b) {
  uint64_t r;
  return __builtin_mul_overflow(a, b, &r) ? std::numeric_limits<uint64_t>::max() : r;
}

/// XXH3-64 of a UID: the index's bucket hash (low bits) and tag (high 32 bits).
MLSPACES_API uint64_t HashUid(std::string_view uid);
/// XXH3-64 of a byte range: the files' and the metadata records' checksums.
MLSPACES_API uint64_t Checksum(const void* data, size_t size);

}  // namespace mlspaces::packed
