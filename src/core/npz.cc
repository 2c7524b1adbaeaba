#include "mlspaces/core/npz.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>
#include <span>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "npy_internal.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;

constexpr uint32_t kLocalSig = 0x04034b50;
constexpr uint32_t kCentralSig = 0x02014b50;
constexpr uint32_t kEocdSig = 0x06054b50;
constexpr uint32_t kZip64EocdSig = 0x06064b50;
constexpr uint32_t kZip64LocatorSig = 0x07064b50;
constexpr size_t kLocalSize = 30;
constexpr size_t kCentralSize = 46;
constexpr size_t kEocdSize = 22;
constexpr size_t kZip64EocdSize = 56;
constexpr size_t kZip64LocatorSize = 20;
constexpr uint16_t kStored = 0;
constexpr uint16_t kDeflated = 8;
constexpr uint16_t kZip64ExtraId = 0x0001;
// DEFLATE cannot expand data by more than about 1032:1; a larger claimed size is corrupt.
constexpr uint64_t kMaxDeflateRatio = 1040;

inline uint16_t Le16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
inline uint32_t Le32(const uint8_t* p) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}
inline uint64_t Le64(const uint8_t* p) {
  uint64_t v;
  std::memcpy(&v, p, 8);
  return v;
}

// True if [offset, offset + length) lies within [0, size).
inline bool InBounds(uint64_t offset, uint64_t length, uint64_t size) {
  return offset <= size && length <= size - offset;
}

struct Member {
  std::string name;  // as in the archive
  std::string key;   // name without ".npy"
  uint16_t method = 0;
  uint16_t flags = 0;
  uint32_t crc = 0;
  uint64_t comp_size = 0;
  uint64_t uncomp_size = 0;
  uint64_t local_offset = 0;
};

// Raw-DEFLATE decompression of one member, continuing across calls.
class Inflater {
 public:
  explicit Inflater(std::span<const uint8_t> in) : in_(in) {
    std::memset(&z_, 0, sizeof z_);
    ok_ = inflateInit2(&z_, -MAX_WBITS) == Z_OK;
  }
  ~Inflater() {
    if (ok_) inflateEnd(&z_);
  }
  Inflater(const Inflater&) = delete;
  Inflater& operator=(const Inflater&) = delete;

  // Appends up to `n` bytes to `out`. Returns false with `error` set on a bad stream.
  bool Read(uint8_t* out, size_t n, size_t* produced, std::string* error) {
    *produced = 0;
    if (!ok_) {
      *error = "cannot initialise zlib";
      return false;
    }
    while (*produced < n && !ended_) {
      if (z_.avail_in == 0 && consumed_ < in_.size()) {
        size_t chunk = std::min<size_t>(in_.size() - consumed_, UINT_MAX);
        z_.next_in = const_cast<Bytef*>(in_.data() + consumed_);
        z_.avail_in = static_cast<uInt>(chunk);
        consumed_ += chunk;
      }
      size_t want = std::min<size_t>(n - *produced, UINT_MAX);
      z_.next_out = out + *produced;
      z_.avail_out = static_cast<uInt>(want);
      int rc = inflate(&z_, Z_NO_FLUSH);
      *produced += want - z_.avail_out;
      if (rc == Z_STREAM_END) {
        ended_ = true;
      } else if (rc == Z_BUF_ERROR && z_.avail_in == 0 && consumed_ >= in_.size()) {
        *error = "DEFLATE stream is truncated";
        return false;
      } else if (rc != Z_OK && rc != Z_BUF_ERROR) {
        *error = std::string("bad DEFLATE stream") + (z_.msg ? std::string(": ") + z_.msg : "");
        return false;
      }
    }
    return true;
  }
  bool ended() const { return ended_; }

 private:
  std::span<const uint8_t> in_;
  size_t consumed_ = 0;
  z_stream z_;
  bool ok_ = false;
  bool ended_ = false;
};

// Encodes little-endian integers into a byte string.
void Put16(std::string& out, uint16_t v) {
  out.push_back(static_cast<char>(v & 0xFF));
  out.push_back(static_cast<char>(v >> 8));
}
void Put32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
void Put64(std::string& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}

uint32_t Crc32(const uint8_t* data, size_t size) {
  uLong crc = crc32(0L, Z_NULL, 0);
  while (size > 0) {
    size_t chunk = std::min<size_t>(size, UINT_MAX);
    crc = crc32(crc, data, static_cast<uInt>(chunk));
    data += chunk;
    size -= chunk;
  }
  return static_cast<uint32_t>(crc);
}

}  // namespace

struct NpzReader::Impl {
  fs::path path;
  std::string path_str;
  const uint8_t* base = nullptr;
  size_t size = 0;
  std::vector<Member> members;

  ~Impl() {
    if (base != nullptr) ::munmap(const_cast<uint8_t*>(base), size);
  }

  [[noreturn]] void Fail(const std::string& message, const std::string& member = {}) const {
    throw Error(message, path_str, member);
  }

  void Open();
  void ReadCentralDirectory();
  const Member& Find(std::string_view key) const;
  std::span<const uint8_t> MemberBytes(const Member& m) const;
  std::vector<uint8_t> Inflate(const Member& m) const;
  NpyHeader Header(const Member& m, std::span<const uint8_t> stored,
                   std::vector<uint8_t>* inflated_prefix) const;
  void CheckCrc(const Member& m, const uint8_t* data, size_t size) const;
};

void NpzReader::Impl::Open() {
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    Fail(errno == ENOENT ? "file not found" : std::string("cannot open: ") + std::strerror(errno));
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    int err = errno;
    ::close(fd);
    Fail(std::string("cannot stat: ") + std::strerror(err));
  }
  if (S_ISDIR(st.st_mode)) {
    ::close(fd);
    Fail("is a directory, expected a file");
  }
  size_t file_size = static_cast<size_t>(st.st_size);
  if (file_size < kEocdSize) {
    ::close(fd);
    Fail("not a zip file (too short)");
  }
  void* map = ::mmap(nullptr, file_size, PROT_READ, MAP_PRIVATE, fd, 0);
  int err = errno;
  ::close(fd);
  if (map == MAP_FAILED) Fail(std::string("cannot map: ") + std::strerror(err));
  base = static_cast<const uint8_t*>(map);
  size = file_size;
  ReadCentralDirectory();
}

void NpzReader::Impl::ReadCentralDirectory() {
  // The end-of-central-directory record is within the last 22 + 65535 bytes.
  size_t lowest = size > kEocdSize + 0xFFFF ? size - kEocdSize - 0xFFFF : 0;
  size_t eocd = SIZE_MAX;
  for (size_t pos = size - kEocdSize + 1; pos-- > lowest;) {
    if (base[pos] == 0x50 && Le32(base + pos) == kEocdSig &&
        pos + kEocdSize + Le16(base + pos + 20) <= size) {
      eocd = pos;
      break;
    }
  }
  if (eocd == SIZE_MAX) Fail("not a zip file (no end of central directory record)");
  const uint8_t* e = base + eocd;
  if (Le16(e + 4) != 0 || Le16(e + 6) != 0) Fail("multi-disk zip archives are not supported");
  uint64_t entries = Le16(e + 10);
  uint64_t cd_size = Le32(e + 12);
  uint64_t cd_offset = Le32(e + 16);
  uint64_t cd_limit = eocd;  // the central directory ends before this offset

  if (eocd >= kZip64LocatorSize && Le32(base + eocd - kZip64LocatorSize) == kZip64LocatorSig) {
    const uint8_t* loc = base + eocd - kZip64LocatorSize;
    uint64_t z64 = Le64(loc + 8);
    if (Le32(loc + 4) != 0 || Le32(loc + 16) > 1) Fail("multi-disk zip archives are not supported");
    if (!InBounds(z64, kZip64EocdSize, eocd - kZip64LocatorSize) ||
        Le32(base + z64) != kZip64EocdSig) {
      Fail("bad zip64 end of central directory record");
    }
    const uint8_t* z = base + z64;
    if (Le32(z + 16) != 0 || Le32(z + 20) != 0) Fail("multi-disk zip archives are not supported");
    entries = Le64(z + 32);
    cd_size = Le64(z + 40);
    cd_offset = Le64(z + 48);
    cd_limit = z64;
  }
  if (!InBounds(cd_offset, cd_size, cd_limit)) {
    Fail("central directory lies outside the file (truncated or corrupt zip)");
  }
  if (entries > cd_size / kCentralSize) Fail("central directory is truncated");
  members.reserve(entries);
  const uint8_t* p = base + cd_offset;
  const uint8_t* end = p + cd_size;
  for (uint64_t i = 0; i < entries; ++i) {
    if (static_cast<size_t>(end - p) < kCentralSize || Le32(p) != kCentralSig) {
      Fail("central directory is truncated or corrupt (entry " + std::to_string(i) + ")");
    }
    size_t name_len = Le16(p + 28), extra_len = Le16(p + 30), comment_len = Le16(p + 32);
    if (static_cast<size_t>(end - p) - kCentralSize < name_len + extra_len + comment_len) {
      Fail("central directory is truncated (entry " + std::to_string(i) + ")");
    }
    Member m;
    m.name.assign(reinterpret_cast<const char*>(p + kCentralSize), name_len);
    m.flags = Le16(p + 8);
    m.method = Le16(p + 10);
    m.crc = Le32(p + 16);
    m.comp_size = Le32(p + 20);
    m.uncomp_size = Le32(p + 24);
    m.local_offset = Le32(p + 42);
    uint16_t disk = Le16(p + 34);
    // ZIP64 extra field: the 64-bit values present are those whose 32-bit field is all ones.
    const uint8_t* x = p + kCentralSize + name_len;
    const uint8_t* x_end = x + extra_len;
    while (x_end - x >= 4) {
      uint16_t id = Le16(x), len = Le16(x + 2);
      if (static_cast<size_t>(x_end - x - 4) < len) Fail("bad extra field", m.name);
      if (id == kZip64ExtraId) {
        const uint8_t* f = x + 4;
        const uint8_t* f_end = f + len;
        auto next64 = [&](uint64_t* value) {
          if (f_end - f < 8) Fail("bad zip64 extra field", m.name);
          *value = Le64(f);
          f += 8;
        };
        if (m.uncomp_size == 0xFFFFFFFF) next64(&m.uncomp_size);
        if (m.comp_size == 0xFFFFFFFF) next64(&m.comp_size);
        if (m.local_offset == 0xFFFFFFFF) next64(&m.local_offset);
        if (disk == 0xFFFF) {
          if (f_end - f < 4) Fail("bad zip64 extra field", m.name);
          disk = static_cast<uint16_t>(Le32(f) != 0);
        }
      }
      x += 4 + len;
    }
    if (disk != 0) Fail("multi-disk zip archives are not supported", m.name);
    p += kCentralSize + name_len + extra_len + comment_len;
    m.key = m.name.size() > 4 && m.name.ends_with(".npy") ? m.name.substr(0, m.name.size() - 4)
                                                          : m.name;
    members.push_back(std::move(m));
  }
}

const Member& NpzReader::Impl::Find(std::string_view key) const {
  for (const Member& m : members) {
    if (m.key == key) return m;
  }
  for (const Member& m : members) {
    if (m.name == key) return m;
  }
  Fail("no array '" + std::string(key) + "' in archive");
}

std::span<const uint8_t> NpzReader::Impl::MemberBytes(const Member& m) const {
  if (m.flags & 0x1) Fail("encrypted zip members are not supported", m.name);
  if (m.method != kStored && m.method != kDeflated) {
    Fail("unsupported zip compression method " + std::to_string(m.method), m.name);
  }
  if (!InBounds(m.local_offset, kLocalSize, size) || Le32(base + m.local_offset) != kLocalSig) {
    Fail("bad local file header (truncated or corrupt zip)", m.name);
  }
  const uint8_t* h = base + m.local_offset;
  uint64_t name_len = Le16(h + 26), extra_len = Le16(h + 28);
  if (name_len != m.name.size() || !InBounds(m.local_offset + kLocalSize, name_len, size) ||
      std::memcmp(h + kLocalSize, m.name.data(), name_len) != 0) {
    Fail("local file header does not match the central directory", m.name);
  }
  uint64_t data_offset = m.local_offset + kLocalSize + name_len + extra_len;
  if (!InBounds(data_offset, m.comp_size, size)) {
    Fail("member data extends past the end of the file", m.name);
  }
  if (m.method == kStored && m.comp_size != m.uncomp_size) {
    Fail("stored member has different compressed and uncompressed sizes", m.name);
  }
  if (m.method == kDeflated && m.uncomp_size > m.comp_size * kMaxDeflateRatio + 1024) {
    Fail("implausible uncompressed size (corrupt zip)", m.name);
  }
  return {base + data_offset, static_cast<size_t>(m.comp_size)};
}

void NpzReader::Impl::CheckCrc(const Member& m, const uint8_t* data, size_t size) const {
  if (Crc32(data, size) != m.crc) Fail("CRC-32 mismatch (corrupt member)", m.name);
}

std::vector<uint8_t> NpzReader::Impl::Inflate(const Member& m) const {
  std::span<const uint8_t> in = MemberBytes(m);
  std::vector<uint8_t> out(m.uncomp_size);
  Inflater inflater(in);
  size_t produced = 0;
  std::string error;
  if (!inflater.Read(out.data(), out.size(), &produced, &error)) Fail(error, m.name);
  if (produced != out.size()) Fail("DEFLATE stream is shorter than the member size", m.name);
  if (!inflater.ended()) {
    uint8_t extra;
    if (!inflater.Read(&extra, 1, &produced, &error)) Fail(error, m.name);
    if (produced != 0 || !inflater.ended()) {
      Fail("DEFLATE stream is longer than the member size", m.name);
    }
  }
  CheckCrc(m, out.data(), out.size());
  return out;
}

NpyHeader NpzReader::Impl::Header(const Member& m, std::span<const uint8_t> stored,
                                  std::vector<uint8_t>* inflated_prefix) const {
  std::span<const uint8_t> bytes = stored;
  if (m.method == kDeflated) {
    // Inflate just the magic, version and length, then the rest of the header.
    std::span<const uint8_t> in = MemberBytes(m);
    Inflater inflater(in);
    std::vector<uint8_t>& buf = *inflated_prefix;
    buf.assign(std::min<uint64_t>(m.uncomp_size, 12), 0);
    size_t produced = 0;
    std::string error;
    if (!inflater.Read(buf.data(), buf.size(), &produced, &error)) Fail(error, m.name);
    buf.resize(produced);
    if (produced >= 12 && buf[6] >= 1 && buf[6] <= 3) {
      uint64_t need = buf[6] == 1 ? 10 + Le16(buf.data() + 8) : 12 + uint64_t{Le32(buf.data() + 8)};
      need = std::min<uint64_t>(need, m.uncomp_size);
      size_t have = buf.size();
      if (need > have) {
        buf.resize(need);
        if (!inflater.Read(buf.data() + have, need - have, &produced, &error)) {
          Fail(error, m.name);
        }
        buf.resize(have + produced);
      }
    }
    bytes = std::span<const uint8_t>(buf);
  }
  NpyHeader header = internal::ParseNpyHeader(bytes, path_str, m.name);
  uint64_t data_size = m.uncomp_size - header.data_offset;
  if (header.data_offset > m.uncomp_size || data_size != header.data_bytes()) {
    Fail("array data is " + std::to_string(header.data_offset > m.uncomp_size ? 0 : data_size) +
             " bytes but its shape and dtype need " + std::to_string(header.data_bytes()),
         m.name);
  }
  return header;
}

NpzReader::NpzReader(const fs::path& path) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->path_str = path.string();
  impl_->Open();
}

NpzReader::~NpzReader() = default;
NpzReader::NpzReader(NpzReader&&) noexcept = default;
NpzReader& NpzReader::operator=(NpzReader&&) noexcept = default;

const fs::path& NpzReader::path() const { return impl_->path; }

std::vector<std::string> NpzReader::keys() const {
  std::vector<std::string> out;
  out.reserve(impl_->members.size());
  for (const Member& m : impl_->members) out.push_back(m.key);
  return out;
}

bool NpzReader::Contains(std::string_view key) const {
  for (const Member& m : impl_->members) {
    if (m.key == key || m.name == key) return true;
  }
  return false;
}

NpyHeader NpzReader::ReadHeader(std::string_view key) const {
  const Member& m = impl_->Find(key);
  std::vector<uint8_t> prefix;
  std::span<const uint8_t> bytes = impl_->MemberBytes(m);
  return impl_->Header(m, bytes, &prefix);
}

NpyArray NpzReader::Read(std::string_view key) const {
  const Member& m = impl_->Find(key);
  std::span<const uint8_t> bytes = impl_->MemberBytes(m);
  std::vector<uint8_t> inflated;
  if (m.method == kDeflated) {
    // Check the header before trusting the claimed size enough to allocate it.
    std::vector<uint8_t> prefix;
    impl_->Header(m, bytes, &prefix);
    inflated = impl_->Inflate(m);
    bytes = std::span<const uint8_t>(inflated);
  } else {
    impl_->CheckCrc(m, bytes.data(), bytes.size());
  }
  NpyHeader header = internal::ParseNpyHeader(bytes, impl_->path_str, m.name);
  if (bytes.size() - header.data_offset != header.data_bytes()) {
    impl_->Fail("array data size does not match its shape and dtype", m.name);
  }
  return internal::ToNativeArray(std::move(header), bytes);
}

NpyArray NpzReader::ReadRows(std::string_view key, const std::vector<size_t>& rows) const {
  const Member& m = impl_->Find(key);
  std::span<const uint8_t> bytes = impl_->MemberBytes(m);
  std::vector<uint8_t> prefix;
  NpyHeader header = impl_->Header(m, bytes, &prefix);
  if (header.shape.empty()) impl_->Fail("cannot read rows of a 0-d array", m.name);
  size_t num_rows = header.shape[0];
  for (size_t r : rows) {
    if (r >= num_rows) {
      impl_->Fail("row " + std::to_string(r) + " out of range (array has " +
                      std::to_string(num_rows) + " rows)",
                  m.name);
    }
  }
  size_t item = DTypeSize(header.dtype);
  size_t row_elems = 1;
  for (size_t i = 1; i < header.shape.size(); ++i) row_elems *= header.shape[i];
  size_t row_bytes = row_elems * item;

  NpyArray out;
  out.dtype = header.dtype;
  out.shape = header.shape;
  out.shape[0] = rows.size();
  out.data.resize(rows.size() * row_bytes);
  if (m.method == kStored && (!header.fortran_order || header.shape.size() == 1)) {
    // Copy just the rows straight from the map.
    const uint8_t* data = bytes.data() + header.data_offset;
    uint8_t* dst = out.data.data();
    for (size_t r : rows) {
      std::memcpy(dst, data + r * row_bytes, row_bytes);
      dst += row_bytes;
    }
    if (header.big_endian) internal::SwapBytes(out.data.data(), rows.size() * row_elems, item);
    if (header.dtype == DType::kB1) internal::NormalizeBools(out.data.data(), out.data.size());
    return out;
  }
  NpyArray all = Read(key);
  uint8_t* dst = out.data.data();
  for (size_t r : rows) {
    std::memcpy(dst, all.data.data() + r * row_bytes, row_bytes);
    dst += row_bytes;
  }
  return out;
}

std::vector<std::pair<std::string, NpyArray>> ReadNpz(const fs::path& path) {
  NpzReader reader(path);
  std::vector<std::pair<std::string, NpyArray>> out;
  for (std::string& key : reader.keys()) {
    NpyArray array = reader.Read(key);
    out.emplace_back(std::move(key), std::move(array));
  }
  return out;
}

void WriteNpz(const fs::path& path, const std::vector<std::pair<std::string, NpyArray>>& arrays,
              const NpzWriteOptions& options) {
  constexpr uint16_t kDosTime = 0;                        // 00:00:00
  constexpr uint16_t kDosDate = (0 << 9) | (1 << 5) | 1;  // 1980-01-01
  std::string out, central;
  uint64_t count = 0;
  for (size_t i = 0; i < arrays.size(); ++i) {
    const auto& [key, array] = arrays[i];
    std::string name = key + ".npy";
    if (name.size() > 0xFFFF) throw Error("array name too long", path.string(), key);
    for (size_t j = 0; j < i; ++j) {
      if (arrays[j].first == key) throw Error("duplicate array name", path.string(), key);
    }
    std::string npy = SerializeNpy(array, options.npy);
    uint32_t crc = Crc32(reinterpret_cast<const uint8_t*>(npy.data()), npy.size());
    std::string compressed;
    uint16_t method = kStored;
    if (options.compress) {
      method = kDeflated;
      z_stream z;
      std::memset(&z, 0, sizeof z);
      if (deflateInit2(&z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY) !=
          Z_OK) {
        throw Error("cannot initialise zlib", path.string(), name);
      }
      size_t in_pos = 0;
      int rc = Z_OK;
      char buf[65536];
      while (rc != Z_STREAM_END) {
        if (z.avail_in == 0 && in_pos < npy.size()) {
          size_t chunk = std::min<size_t>(npy.size() - in_pos, UINT_MAX);
          z.next_in = reinterpret_cast<Bytef*>(npy.data() + in_pos);
          z.avail_in = static_cast<uInt>(chunk);
          in_pos += chunk;
        }
        z.next_out = reinterpret_cast<Bytef*>(buf);
        z.avail_out = sizeof buf;
        rc = deflate(&z, in_pos < npy.size() ? Z_NO_FLUSH : Z_FINISH);
        if (rc == Z_STREAM_ERROR) {
          deflateEnd(&z);
          throw Error("DEFLATE failed", path.string(), name);
        }
        compressed.append(buf, sizeof buf - z.avail_out);
      }
      deflateEnd(&z);
    }
    const std::string& payload = options.compress ? compressed : npy;
    uint64_t comp_size = payload.size(), uncomp_size = npy.size();
    uint64_t offset = out.size();
    bool big = comp_size >= 0xFFFFFFFF || uncomp_size >= 0xFFFFFFFF;
    bool big_offset = offset >= 0xFFFFFFFF;
    uint16_t version = big || big_offset ? 45 : 20;
    bool utf8 = std::any_of(name.begin(), name.end(), [](char c) { return c & 0x80; });
    uint16_t flags = utf8 ? 0x800 : 0;

    // Local header.
    Put32(out, kLocalSig);
    Put16(out, version);
    Put16(out, flags);
    Put16(out, method);
    Put16(out, kDosTime);
    Put16(out, kDosDate);
    Put32(out, crc);
    Put32(out, big ? 0xFFFFFFFF : static_cast<uint32_t>(comp_size));
    Put32(out, big ? 0xFFFFFFFF : static_cast<uint32_t>(uncomp_size));
    Put16(out, static_cast<uint16_t>(name.size()));
    Put16(out, big ? 20 : 0);
    out += name;
    if (big) {
      Put16(out, kZip64ExtraId);
      Put16(out, 16);
      Put64(out, uncomp_size);
      Put64(out, comp_size);
    }
    out += payload;

    // Central directory entry.
    std::string extra;
    if (big) {
      Put64(extra, uncomp_size);
      Put64(extra, comp_size);
    }
    if (big_offset) Put64(extra, offset);
    Put32(central, kCentralSig);
    Put16(central, static_cast<uint16_t>((3 << 8) | version));  // made by: unix
    Put16(central, version);
    Put16(central, flags);
    Put16(central, method);
    Put16(central, kDosTime);
    Put16(central, kDosDate);
    Put32(central, crc);
    Put32(central, big ? 0xFFFFFFFF : static_cast<uint32_t>(comp_size));
    Put32(central, big ? 0xFFFFFFFF : static_cast<uint32_t>(uncomp_size));
    Put16(central, static_cast<uint16_t>(name.size()));
    Put16(central, static_cast<uint16_t>(extra.empty() ? 0 : extra.size() + 4));
    Put16(central, 0);            // comment length
    Put16(central, 0);            // disk number
    Put16(central, 0);            // internal attributes
    Put32(central, 0644u << 16);  // external attributes: -rw-r--r--
    Put32(central, big_offset ? 0xFFFFFFFF : static_cast<uint32_t>(offset));
    central += name;
    if (!extra.empty()) {
      Put16(central, kZip64ExtraId);
      Put16(central, static_cast<uint16_t>(extra.size()));
      central += extra;
    }
    ++count;
  }
  uint64_t cd_offset = out.size(), cd_size = central.size();
  out += central;
  if (count >= 0xFFFF || cd_offset >= 0xFFFFFFFF || cd_size >= 0xFFFFFFFF) {
    uint64_t z64 = out.size();
    Put32(out, kZip64EocdSig);
    Put64(out, kZip64EocdSize - 12);
    Put16(out, 45);
    Put16(out, 45);
    Put32(out, 0);
    Put32(out, 0);
    Put64(out, count);
    Put64(out, count);
    Put64(out, cd_size);
    Put64(out, cd_offset);
    Put32(out, kZip64LocatorSig);
    Put32(out, 0);
    Put64(out, z64);
    Put32(out, 1);
  }
  Put32(out, kEocdSig);
  Put16(out, 0);
  Put16(out, 0);
  Put16(out, static_cast<uint16_t>(std::min<uint64_t>(count, 0xFFFF)));
  Put16(out, static_cast<uint16_t>(std::min<uint64_t>(count, 0xFFFF)));
  Put32(out, static_cast<uint32_t>(std::min<uint64_t>(cd_size, 0xFFFFFFFF)));
  Put32(out, static_cast<uint32_t>(std::min<uint64_t>(cd_offset, 0xFFFFFFFF)));
  Put16(out, 0);
  WriteFileAtomic(path, out);
}

}  // namespace mlspaces
