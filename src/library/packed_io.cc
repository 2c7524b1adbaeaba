// Read-only file mappings, header checks and the hashes of the packed stores
// (src/library/packed_io.h, include/mlspaces/library/packed_format.h).
#include "packed_io.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <cerrno>
#include <cstring>

#include "mlspaces/core/error.h"
#include "mlspaces/library/packed_format.h"

namespace mlspaces::packed {
namespace fs = std::filesystem;

uint64_t HashUid(std::string_view uid) { return XXH3_64bits(uid.data(), uid.size()); }

uint64_t Checksum(const void* data, size_t size) { return XXH3_64bits(data, size); }

Mapping::~Mapping() {
  if (data_ != nullptr) ::munmap(const_cast<uint8_t*>(data_), size_);
}

void Mapping::Open(const fs::path& path, const std::string& missing, int advice) {
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

}  // namespace mlspaces::packed
