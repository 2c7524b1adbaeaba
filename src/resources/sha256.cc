// SHA-256 through OpenSSL's EVP interface.
#include "mlspaces/resources/sha256.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include "mlspaces/core/error.h"

namespace mlspaces {

struct Sha256::Impl {
  EVP_MD_CTX* ctx = nullptr;
  bool done = false;
};

Sha256::Sha256() : impl_(std::make_unique<Impl>()) {
  impl_->ctx = EVP_MD_CTX_new();
  if (impl_->ctx == nullptr || EVP_DigestInit_ex(impl_->ctx, EVP_sha256(), nullptr) != 1) {
    throw Error("OpenSSL: cannot initialise SHA-256");
  }
}

Sha256::~Sha256() { EVP_MD_CTX_free(impl_->ctx); }

void Sha256::Update(const void* data, size_t size) {
  // A bug check, not bad input: a finished hash is not fed again.
  if (impl_->done) throw std::logic_error("Sha256::Update after HexDigest");
  if (size > 0 && EVP_DigestUpdate(impl_->ctx, data, size) != 1) {
    throw Error("OpenSSL: SHA-256 update failed");
  }
}

std::string Sha256::HexDigest() {
  // A bug check, not bad input: the digest is taken once.
  if (impl_->done) throw std::logic_error("Sha256::HexDigest called twice");
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_DigestFinal_ex(impl_->ctx, digest, &length) != 1) {
    throw Error("OpenSSL: SHA-256 final failed");
  }
  impl_->done = true;
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out(2 * length, '0');
  for (unsigned int i = 0; i < length; ++i) {
    out[2 * i] = kHex[digest[i] >> 4];
    out[2 * i + 1] = kHex[digest[i] & 15];
  }
  return out;
}

std::string Sha256Hex(std::string_view data) {
  Sha256 hash;
  hash.Update(data);
  return hash.HexDigest();
}

FileDigest Sha256File(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(std::string("cannot open: ") + std::strerror(errno), path.string());
  Sha256 hash;
  FileDigest out;
  std::vector<char> buffer(1 << 20);
  for (;;) {
    const ssize_t n = ::read(fd, buffer.data(), buffer.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      throw Error(std::string("cannot read: ") + std::strerror(err), path.string());
    }
    if (n == 0) break;
    hash.Update(buffer.data(), static_cast<size_t>(n));
    out.size += static_cast<uint64_t>(n);
  }
  ::close(fd);
  out.sha256 = hash.HexDigest();
  return out;
}

}  // namespace mlspaces
