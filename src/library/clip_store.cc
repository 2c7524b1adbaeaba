// The CLIP feature store: writer, reader and scans (include/mlspaces/library/clip_store.h,
// byte layout in docs/formats.md "CLIP feature store").
#include "mlspaces/library/clip_store.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <numeric>
#include <unordered_set>

#include "clip_kernels.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/parallel.h"
#include "mlspaces/library/packed_format.h"
#include "packed_io.h"

namespace mlspaces {
namespace fs = std::filesystem;
using packed::Load;
using packed::SatAdd;
using packed::SatMul;

namespace {

constexpr char kClipMagic[8] = {'M', 'L', 'S', 'C', 'L', 'I', 'P', '2'};
constexpr size_t kNumAssets = 12, kFileSize = 16, kViews = 24, kDim = 28, kVectorsOff = 32,
                 kUidsOff = 40, kApproxOff = 48, kChecksum = 56;
constexpr size_t kMaxApproxDim = 128;
constexpr size_t kBasisSample = 4096;
constexpr size_t kBasisIterations = 6;
// The smallest float >= v (v >= 0): stored norms must never be below the true ones.
float RoundUp(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, INFINITY);
  return f;
}

constexpr uint64_t Align64(uint64_t n) { return (n + 63) & ~uint64_t{63}; }

// Normalises `v` (double accumulation) into `out` as float16. @throws Error for bad values.
void PutUnit(std::span<const float> v, uint16_t* out, const std::string& source,
             std::string_view uid, const char* what) {
  double norm = 0;
  for (float x : v) {
    if (!std::isfinite(x)) {
      throw Error(std::string(what) + " holds a NaN or Inf", source, {}, std::string(uid));
    }
    norm += static_cast<double>(x) * x;
  }
  if (!(norm > 0))
    throw Error(std::string(what) + " is a zero vector", source, {}, std::string(uid));
  const double inv = 1.0 / std::sqrt(norm);
  for (size_t i = 0; i < v.size(); ++i) out[i] = clip::FloatToHalf(static_cast<float>(v[i] * inv));
}

void EncodeRecord(std::string_view uid, std::span<const float> img, std::span<const float> text,
                  size_t views, size_t dim, const std::string& source, uint16_t* out) {
  if (uid.empty()) throw Error("empty UID", source);
  if (img.size() != views * dim) {
    throw Error("clip_img_features has " + std::to_string(img.size()) + " values, expected " +
                    std::to_string(views) + " x " + std::to_string(dim),
                source, {}, std::string(uid));
  }
  if (text.size() != dim) {
    throw Error("clip_text_features has " + std::to_string(text.size()) + " values, expected " +
                    std::to_string(dim),
                source, {}, std::string(uid));
  }
  for (size_t v = 0; v < views; ++v) {
    PutUnit(img.subspan(v * dim, dim), out + v * dim, source, uid, "clip_img_features view");
  }
  PutUnit(text, out + views * dim, source, uid, "clip_text_features");
}

// The surrogate vector the approximate pass ranks by: mean of the views + 0.5 * text.
void Surrogate(const uint16_t* rec, size_t views, size_t dim, float* u) {
  for (size_t j = 0; j < dim; ++j) {
    float s = 0;
    for (size_t v = 0; v < views; ++v) s += clip::HalfToFloat(rec[v * dim + j]);
    u[j] = s / static_cast<float>(views) + 0.5f * clip::HalfToFloat(rec[views * dim + j]);
  }
}

// Orthonormalises the m rows (length dim) of `q` in place (modified Gram-Schmidt, twice).
void Orthonormalise(std::vector<float>& q, size_t m, size_t dim) {
  for (int pass = 0; pass < 2; ++pass) {
    for (size_t i = 0; i < m; ++i) {
      float* qi = q.data() + i * dim;
      for (size_t k = 0; k < i; ++k) {
        const float* qk = q.data() + k * dim;
        double d = 0;
        for (size_t j = 0; j < dim; ++j) d += static_cast<double>(qi[j]) * qk[j];
        for (size_t j = 0; j < dim; ++j) qi[j] -= static_cast<float>(d) * qk[j];
      }
      double n = 0;
      for (size_t j = 0; j < dim; ++j) n += static_cast<double>(qi[j]) * qi[j];
      const float inv = n > 0 ? static_cast<float>(1.0 / std::sqrt(n)) : 0.0f;
      for (size_t j = 0; j < dim; ++j) qi[j] *= inv;
    }
  }
}

void BuildBounds(const uint16_t* records, size_t n, size_t views, size_t dim, std::string& out);

// The approximate section: a basis of the top-m principal directions of the surrogate vectors
// (uncentred second moment of an evenly spaced sample, subspace iteration), then one int8 code
// and scale per asset. Appended to `out` (which starts 64-aligned).
void BuildApprox(const uint16_t* records, size_t n, size_t views, size_t dim, std::string& out) {
  const size_t m = std::min(kMaxApproxDim, dim);
  const size_t stride = (views + 1) * dim;
  const size_t sample = std::min(n, kBasisSample);
  std::vector<float> moment(dim * dim, 0.0f), u(dim);
  for (size_t s = 0; s < sample; ++s) {
    Surrogate(records + (s * n / sample) * stride, views, dim, u.data());
    for (size_t a = 0; a < dim; ++a) {
      float* row = moment.data() + a * dim;
      const float ua = u[a];
      for (size_t b = 0; b < dim; ++b) row[b] += ua * u[b];
    }
  }
  std::vector<float> basis(m * dim), next(m * dim);
  uint64_t state = 0x9E3779B97F4A7C15ull;  // deterministic start
  for (float& x : basis) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    x = static_cast<float>(static_cast<int64_t>(state >> 11) % 2001 - 1000) / 1000.0f;
  }
  Orthonormalise(basis, m, dim);
  for (size_t it = 0; it < kBasisIterations; ++it) {
    for (size_t i = 0; i < m; ++i) {
      const float* qi = basis.data() + i * dim;
      float* ni = next.data() + i * dim;
      for (size_t a = 0; a < dim; ++a) {
        const float* row = moment.data() + a * dim;
        float d = 0;
        for (size_t b = 0; b < dim; ++b) d += row[b] * qi[b];
        ni[a] = d;
      }
    }
    basis.swap(next);
    Orthonormalise(basis, m, dim);
  }
  packed::Put<uint32_t>(out, static_cast<uint32_t>(m));
  packed::Put<uint32_t>(out, static_cast<uint32_t>(dim));  // length of the bound codes
  out.append(reinterpret_cast<const char*>(basis.data()), basis.size() * sizeof(float));
  std::vector<float> scales(n);
  std::string codes(n * m, '\0');
  std::vector<float> p(m);
  for (size_t r = 0; r < n; ++r) {
    Surrogate(records + r * stride, views, dim, u.data());
    float amax = 0;
    for (size_t i = 0; i < m; ++i) {
      const float* qi = basis.data() + i * dim;
      float d = 0;
      for (size_t j = 0; j < dim; ++j) d += qi[j] * u[j];
      p[i] = d;
      amax = std::max(amax, std::fabs(d));
    }
    const float scale = amax > 0 ? amax / 127.0f : 1.0f;
    scales[r] = scale;
    for (size_t i = 0; i < m; ++i) {
      codes[r * m + i] = static_cast<char>(static_cast<int8_t>(std::lrint(p[i] / scale)));
    }
  }
  out.append(reinterpret_cast<const char*>(scales.data()), n * sizeof(float));
  out.append(Align64(out.size()) - out.size(), '\0');
  out += codes;
  BuildBounds(records, n, views, dim, out);
}

// The bound section (docs/search.md "Exact queries without a full scan"), appended to `out`
// (64-aligned): per vector x of every record, its int8 code c with scale s (s = max|x_j| / 127)
// and the norm of the rounding residual d = x - s c, computed in double and rounded up. Then
// <x, q> = s <c, q> + <d, q> <= s <c, q> + ||d|| ||q|| exactly, which Search evaluates.
void BuildBounds(const uint16_t* records, size_t n, size_t views, size_t dim, std::string& out) {
  const size_t vecs = views + 1;
  std::string codes(n * vecs * dim, '\0');
  std::vector<float> params(n * vecs * 2);
  std::vector<double> x(dim);
  for (size_t r = 0; r < n; ++r) {
    for (size_t v = 0; v < vecs; ++v) {
      const uint16_t* h = records + (r * vecs + v) * dim;
      double amax = 0;
      for (size_t j = 0; j < dim; ++j) {
        x[j] = clip::HalfToFloat(h[j]);
        amax = std::max(amax, std::fabs(x[j]));
      }
      const float scale = amax > 0 ? static_cast<float>(amax / 127.0) : 1.0f;
      int8_t* code = reinterpret_cast<int8_t*>(codes.data()) + (r * vecs + v) * dim;
      double d2 = 0;
      for (size_t j = 0; j < dim; ++j) {
        const long c = std::clamp<long>(std::lrint(x[j] / scale), -127, 127);
        code[j] = static_cast<int8_t>(c);
        const double d = x[j] - static_cast<double>(scale) * static_cast<double>(c);  // exact
        d2 += d * d;
      }
      float* prm = params.data() + (r * vecs + v) * 2;
      prm[0] = scale;
      prm[1] = RoundUp(std::sqrt(d2) * (1 + 1e-9) + 1e-12);  // covers the double rounding
    }
  }
  out.append(Align64(out.size()) - out.size(), '\0');
  out += codes;
  out.append(Align64(out.size()) - out.size(), '\0');
  out.append(reinterpret_cast<const char*>(params.data()), params.size() * sizeof(float));
}

// Everything after the vector section: the UID table, the strings, the approximate section.
// `vectors_end` is the file offset where `out` will start. Returns the header's uids/approx
// offsets through the out-parameters.
void BuildTail(const std::vector<std::string>& uids, const uint16_t* records, size_t views,
               size_t dim, uint64_t vectors_end, bool approx, std::string& out, uint64_t& uids_off,
               uint64_t& approx_off) {
  const size_t n = uids.size();
  uids_off = packed::Align8(vectors_end);
  out.assign(uids_off - vectors_end, '\0');
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return uids[a] < uids[b]; });
  uint64_t str = 0;
  for (const std::string& uid : uids) {
    packed::Put<uint32_t>(out, static_cast<uint32_t>(str));
    packed::Put<uint32_t>(out, static_cast<uint32_t>(uid.size()));
    str += uid.size();
  }
  for (uint32_t r : order) packed::Put<uint32_t>(out, r);
  packed::Pad8(out);
  for (const std::string& uid : uids) out += uid;
  approx_off = 0;
  if (approx && n > 0) {
    const uint64_t here = vectors_end + out.size();
    out.append(Align64(here) - here, '\0');
    approx_off = vectors_end + out.size();
    std::string section;
    BuildApprox(records, n, views, dim, section);
    out += section;
  }
}

std::string Header(size_t n, uint64_t file_size, size_t views, size_t dim, uint64_t uids_off,
                   uint64_t approx_off, uint64_t checksum) {
  std::string h(packed::kHeaderSize, '\0');
  std::memcpy(h.data(), kClipMagic, 8);
  packed::PutAt<uint32_t>(h, 8, packed::kFormatVersion);
  packed::PutAt<uint32_t>(h, kNumAssets, static_cast<uint32_t>(n));
  packed::PutAt<uint64_t>(h, kFileSize, file_size);
  packed::PutAt<uint32_t>(h, kViews, static_cast<uint32_t>(views));
  packed::PutAt<uint32_t>(h, kDim, static_cast<uint32_t>(dim));
  packed::PutAt<uint64_t>(h, kVectorsOff, packed::kHeaderSize);
  packed::PutAt<uint64_t>(h, kUidsOff, uids_off);
  packed::PutAt<uint64_t>(h, kApproxOff, approx_off);
  packed::PutAt<uint64_t>(h, kChecksum, checksum);
  return h;
}

void CheckSizes(size_t views, size_t dim, const std::string& source) {
  if (views == 0 || dim == 0 || views > 64 || dim > 65536) {
    throw UsageError("bad CLIP store shape " + std::to_string(views) + " x " + std::to_string(dim),
                     source);
  }
}

}  // namespace

// =============================================================================================
// Writer

struct ClipStoreWriter::Impl {
  fs::path file, temp;
  size_t views = 0, dim = 0;
  int fd = -1;
  bool finished = false;
  std::vector<std::string> uids;
  std::unordered_set<std::string> seen;
  std::vector<uint16_t> record;
  XXH3_state_t hash{};
};

ClipStoreWriter::ClipStoreWriter(fs::path file, size_t views, size_t dim)
    : impl_(std::make_unique<Impl>()) {
  CheckSizes(views, dim, file.string());
  impl_->file = std::move(file);
  impl_->views = views;
  impl_->dim = dim;
  impl_->record.resize((views + 1) * dim);
  const fs::path parent = impl_->file.parent_path();
  if (!parent.empty()) CreateDirectories(parent);
  impl_->temp = impl_->file;
  impl_->temp += TempSuffix();
  impl_->fd = ::open(impl_->temp.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (impl_->fd < 0) throw Error(Errno("cannot create"), impl_->temp.string());
  const std::string placeholder(packed::kHeaderSize, '\0');
  if (!WriteAll(impl_->fd, placeholder)) throw Error(Errno("cannot write"), impl_->temp.string());
  XXH3_64bits_reset(&impl_->hash);
}

ClipStoreWriter::~ClipStoreWriter() {
  if (impl_->fd >= 0) ::close(impl_->fd);
  if (!impl_->finished) {
    std::error_code ec;
    fs::remove(impl_->temp, ec);
  }
}

size_t ClipStoreWriter::size() const { return impl_->uids.size(); }

void ClipStoreWriter::Add(std::string_view uid, std::span<const float> img,
                          std::span<const float> text) {
  Impl& w = *impl_;
  if (w.finished) throw Error("Add after Finish", w.file.string(), {}, std::string(uid));
  EncodeRecord(uid, img, text, w.views, w.dim, w.file.string(), w.record.data());
  if (!w.seen.emplace(uid).second) {
    throw Error("UID added twice", w.file.string(), {}, std::string(uid));
  }
  if (w.uids.size() >= UINT32_MAX) throw Error("too many assets", w.file.string());
  const std::string_view bytes(reinterpret_cast<const char*>(w.record.data()),
                               w.record.size() * sizeof(uint16_t));
  if (!WriteAll(w.fd, bytes)) throw Error(Errno("cannot write"), w.temp.string());
  XXH3_64bits_update(&w.hash, bytes.data(), bytes.size());
  w.uids.emplace_back(uid);
}

void ClipStoreWriter::Finish() {
  Impl& w = *impl_;
  if (w.finished) throw Error("Finish called twice", w.file.string());
  const size_t n = w.uids.size();
  const uint64_t vectors_end = packed::kHeaderSize + n * w.record.size() * sizeof(uint16_t);
  const uint16_t* records = nullptr;
  void* map = MAP_FAILED;
  if (n > 0) {
    map = ::mmap(nullptr, vectors_end, PROT_READ, MAP_SHARED, w.fd, 0);
    if (map == MAP_FAILED) throw Error(Errno("cannot map"), w.temp.string());
    records =
        reinterpret_cast<const uint16_t*>(static_cast<const uint8_t*>(map) + packed::kHeaderSize);
  }
  std::string tail;
  uint64_t uids_off = 0, approx_off = 0;
  try {
    BuildTail(w.uids, records, w.views, w.dim, vectors_end, true, tail, uids_off, approx_off);
  } catch (...) {
    if (map != MAP_FAILED) ::munmap(map, vectors_end);
    throw;
  }
  if (map != MAP_FAILED) ::munmap(map, vectors_end);
  XXH3_64bits_update(&w.hash, tail.data(), tail.size());
  const uint64_t file_size = vectors_end + tail.size();
  const std::string header =
      Header(n, file_size, w.views, w.dim, uids_off, approx_off, XXH3_64bits_digest(&w.hash));
  if (!WriteAll(w.fd, tail) ||
      ::pwrite(w.fd, header.data(), header.size(), 0) != static_cast<ssize_t>(header.size())) {
    throw Error(Errno("cannot write"), w.temp.string());
  }
  if (::fsync(w.fd) != 0) throw Error(Errno("cannot fsync"), w.temp.string());
  ::close(w.fd);
  w.fd = -1;
  RenamePath(w.temp, w.file);
  w.finished = true;
  const fs::path parent = w.file.parent_path();
  FsyncPath(parent.empty() ? fs::path(".") : parent, true, w.file.string());
}

// =============================================================================================
// Reader

struct ClipStore::Impl {
  fs::path path;
  packed::Mapping map;         // file stores
  std::vector<uint8_t> owned;  // in-memory stores: the same bytes as a file
  const uint8_t* base = nullptr;
  uint64_t size = 0;
  size_t n = 0, views = 0, dim = 0;
  const uint16_t* records = nullptr;
  const uint8_t* table = nullptr;  // n x (u32 offset, u32 length)
  const uint8_t* order = nullptr;  // n x u32 rows sorted by UID
  const char* strings = nullptr;
  uint64_t strings_size = 0;
  size_t approx_dim = 0;
  const float* basis = nullptr;         // approx_dim x dim
  const float* scales = nullptr;        // n
  const int8_t* codes = nullptr;        // n x approx_dim
  size_t bound_dim = 0;                 // 0: no bound section
  const int8_t* bound_codes = nullptr;  // n x (views + 1) x bound_dim
  const float* bound_params = nullptr;  // n x (views + 1) x (scale, ||d||)

  std::string where() const {
    return path.empty() ? std::string("<in-memory CLIP store>") : path.string();
  }
  std::string_view Uid(size_t row) const {
    const uint8_t* e = table + row * 8;
    return {strings + Load<uint32_t>(e), Load<uint32_t>(e + 4)};
  }
  void Parse();
  std::vector<float> Bounds(const std::vector<float>& q) const;
};

void ClipStore::Impl::Parse() {
  const std::string file = where();
  packed::CheckMagic(base, kClipMagic, file);
  auto bad = [&](const std::string& what) { throw Error("damaged CLIP store: " + what, file); };
  if (Load<uint64_t>(base + kFileSize) != size) {
    bad("header says " + std::to_string(Load<uint64_t>(base + kFileSize)) + " bytes, file has " +
        std::to_string(size) + " (truncated?)");
  }
  n = Load<uint32_t>(base + kNumAssets);
  views = Load<uint32_t>(base + kViews);
  dim = Load<uint32_t>(base + kDim);
  if (views == 0 || dim == 0 || views > 64 || dim > 65536) bad("bad shape");
  const uint64_t vectors_off = Load<uint64_t>(base + kVectorsOff);
  const uint64_t uids_off = Load<uint64_t>(base + kUidsOff);
  const uint64_t approx_off = Load<uint64_t>(base + kApproxOff);
  const uint64_t record_bytes = (views + 1) * dim * sizeof(uint16_t);
  const uint64_t vectors_end = SatAdd(vectors_off, SatMul(n, record_bytes));
  if (vectors_off != packed::kHeaderSize || vectors_end > size) bad("vector section out of range");
  if (uids_off != packed::Align8(vectors_end)) bad("UID table offset");
  const uint64_t strings_off = packed::Align8(SatAdd(uids_off, SatMul(n, 12)));
  if (strings_off > size) bad("UID table out of range");
  const uint64_t strings_end = approx_off != 0 ? approx_off : size;
  if (strings_end < strings_off || strings_end > size) bad("string section out of range");
  records = reinterpret_cast<const uint16_t*>(base + vectors_off);
  table = base + uids_off;
  order = base + uids_off + 8 * n;
  strings = reinterpret_cast<const char*>(base + strings_off);
  strings_size = strings_end - strings_off;
  uint64_t total = 0;
  for (size_t r = 0; r < n; ++r) {
    const uint8_t* e = table + r * 8;
    total += Load<uint32_t>(e + 4);
    if (SatAdd(Load<uint32_t>(e), Load<uint32_t>(e + 4)) > strings_size ||
        Load<uint32_t>(e + 4) == 0) {
      bad("UID " + std::to_string(r) + " out of range");
    }
    if (Load<uint32_t>(order + 4 * r) >= n) bad("sorted UID table out of range");
  }
  // The strings fill their section (up to the padding before the approximate section).
  if (total > strings_size || strings_size - total >= (approx_off != 0 ? 64 : 1)) {
    bad("string section size");
  }
  if (approx_off != 0) {
    if (approx_off % 64 != 0 || SatAdd(approx_off, 8) > size) bad("approximate section offset");
    approx_dim = Load<uint32_t>(base + approx_off);
    if (approx_dim == 0 || approx_dim > dim) bad("approximate dimension");
    const uint64_t basis_off = approx_off + 8;
    const uint64_t scales_off = basis_off + approx_dim * dim * sizeof(float);
    const uint64_t codes_off = Align64(SatAdd(scales_off, SatMul(n, sizeof(float))));
    bound_dim = Load<uint32_t>(base + approx_off + 4);
    if (bound_dim != dim) bad("bound code length");
    const uint64_t bound_codes_off = Align64(SatAdd(codes_off, SatMul(n, approx_dim)));
    const uint64_t vecs = views + 1;
    const uint64_t bound_params_off =
        Align64(SatAdd(bound_codes_off, SatMul(SatMul(n, vecs), bound_dim)));
    if (SatAdd(bound_params_off, SatMul(SatMul(n, vecs), 2 * sizeof(float))) != size) {
      bad("approximate section size");
    }
    bound_codes = reinterpret_cast<const int8_t*>(base + bound_codes_off);
    bound_params = reinterpret_cast<const float*>(base + bound_params_off);
    basis = reinterpret_cast<const float*>(base + basis_off);
    scales = reinterpret_cast<const float*>(base + scales_off);
    codes = reinterpret_cast<const int8_t*>(base + codes_off);
  }
}

ClipStore::ClipStore() : impl_(std::make_unique<Impl>()) {}
ClipStore::~ClipStore() = default;

std::shared_ptr<const ClipStore> ClipStore::Open(const fs::path& file) {
  std::shared_ptr<ClipStore> store(new ClipStore());
  Impl& s = *store->impl_;
  s.path = file;
  s.map.Open(file, "no CLIP feature store (clip_features.mlsc) here", MADV_SEQUENTIAL);
  s.base = s.map.data();
  s.size = s.map.size();
  s.Parse();
  return store;
}

std::shared_ptr<const ClipStore> ClipStore::FromVectors(std::vector<std::string> uids, size_t views,
                                                        size_t dim, std::span<const float> img,
                                                        std::span<const float> text,
                                                        const std::string& source) {
  CheckSizes(views, dim, source);
  const size_t n = uids.size();
  if (img.size() != n * views * dim || text.size() != n * dim) {
    throw Error("feature arrays do not match " + std::to_string(n) + " UIDs", source);
  }
  const size_t rec = (views + 1) * dim;
  std::vector<uint16_t> records(n * rec);
  std::unordered_set<std::string_view> seen;
  for (size_t r = 0; r < n; ++r) {
    EncodeRecord(uids[r], img.subspan(r * views * dim, views * dim), text.subspan(r * dim, dim),
                 views, dim, source, records.data() + r * rec);
    if (!seen.insert(uids[r]).second) throw Error("UID given twice", source, {}, uids[r]);
  }
  const uint64_t vectors_end = packed::kHeaderSize + records.size() * sizeof(uint16_t);
  std::string tail;
  uint64_t uids_off = 0, approx_off = 0;
  BuildTail(uids, records.data(), views, dim, vectors_end, false, tail, uids_off, approx_off);
  std::shared_ptr<ClipStore> store(new ClipStore());
  Impl& s = *store->impl_;
  const std::string header = Header(n, vectors_end + tail.size(), views, dim, uids_off, 0, 0);
  s.owned.resize(vectors_end + tail.size());
  std::memcpy(s.owned.data(), header.data(), header.size());
  std::memcpy(s.owned.data() + packed::kHeaderSize, records.data(),
              records.size() * sizeof(uint16_t));
  std::memcpy(s.owned.data() + vectors_end, tail.data(), tail.size());
  s.base = s.owned.data();
  s.size = s.owned.size();
  s.Parse();
  return store;
}

size_t ClipStore::size() const { return impl_->n; }
size_t ClipStore::views() const { return impl_->views; }
size_t ClipStore::dim() const { return impl_->dim; }
bool ClipStore::has_approximate() const { return impl_->codes != nullptr; }
const fs::path& ClipStore::path() const { return impl_->path; }
std::string_view ClipStore::uid(size_t row) const { return impl_->Uid(row); }

std::optional<size_t> ClipStore::Find(std::string_view uid) const {
  const Impl& s = *impl_;
  size_t lo = 0, hi = s.n;
  while (lo < hi) {
    const size_t mid = lo + (hi - lo) / 2;
    const uint32_t row = Load<uint32_t>(s.order + 4 * mid);
    const std::string_view u = s.Uid(row);
    if (u == uid) return row;
    if (u < uid) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return std::nullopt;
}

std::vector<float> ClipStore::ImageFeatures(size_t row) const {
  const Impl& s = *impl_;
  const uint16_t* rec = s.records + row * (s.views + 1) * s.dim;
  std::vector<float> out(s.views * s.dim);
  for (size_t i = 0; i < out.size(); ++i) out[i] = clip::HalfToFloat(rec[i]);
  return out;
}

std::vector<float> ClipStore::TextFeature(size_t row) const {
  const Impl& s = *impl_;
  const uint16_t* rec = s.records + row * (s.views + 1) * s.dim + s.views * s.dim;
  std::vector<float> out(s.dim);
  for (size_t i = 0; i < out.size(); ++i) out[i] = clip::HalfToFloat(rec[i]);
  return out;
}

float ClipStore::Score(size_t row, std::span<const float> unit_query) const {
  const Impl& s = *impl_;
  float out = 0;
  clip::BestKernels().score(s.records + row * (s.views + 1) * s.dim, 1, s.views, s.dim,
                            unit_query.data(), &out);
  return out;
}

void ClipStore::Check() const {
  const Impl& s = *impl_;
  const std::string file = s.where();
  if (!s.path.empty() && XXH3_64bits(s.base + packed::kHeaderSize, s.size - packed::kHeaderSize) !=
                             Load<uint64_t>(s.base + kChecksum)) {
    throw Error("damaged CLIP store: checksum mismatch", file);
  }
  for (size_t i = 1; i < s.n; ++i) {
    if (!(s.Uid(Load<uint32_t>(s.order + 4 * (i - 1))) < s.Uid(Load<uint32_t>(s.order + 4 * i)))) {
      throw Error("damaged CLIP store: UID table not sorted or UIDs repeated", file);
    }
  }
  // Bounds are only as good as their parameters: finite, positive scales, non-negative norms.
  for (size_t i = 0; s.bound_params != nullptr && i < s.n * (s.views + 1); ++i) {
    const float* p = s.bound_params + 2 * i;
    if (!(std::isfinite(p[0]) && p[0] > 0 && std::isfinite(p[1]) && p[1] >= 0)) {
      throw Error(
          "damaged CLIP store: bound parameters of record " + std::to_string(i / (s.views + 1)),
          file);
    }
  }
}

namespace {

struct Candidate {
  float score;
  uint32_t row;
};

// Keeps the best k candidates: a heap whose top is the worst kept (lowest score, then the
// largest UID), so ties resolve by UID whatever order rows are seen in.
class TopK {
 public:
  TopK(size_t k, const ClipStore& store) : k_(k), store_(&store) {}
  // true when a ranks before b.
  bool Better(const Candidate& a, const Candidate& b) const {
    if (a.score != b.score) return a.score > b.score;
    return store_->uid(a.row) < store_->uid(b.row);
  }
  void Offer(const Candidate& c) {
    auto cmp = [this](const Candidate& a, const Candidate& b) { return Better(a, b); };
    if (heap_.size() < k_) {
      heap_.push_back(c);
      std::push_heap(heap_.begin(), heap_.end(), cmp);
    } else if (k_ > 0 && Better(c, heap_.front())) {
      std::pop_heap(heap_.begin(), heap_.end(), cmp);
      heap_.back() = c;
      std::push_heap(heap_.begin(), heap_.end(), cmp);
    }
  }
  const std::vector<Candidate>& items() const { return heap_; }
  bool full() const { return heap_.size() >= k_; }
  /// The worst kept score (only when full()).
  float worst() const { return heap_.front().score; }

 private:
  size_t k_;
  const ClipStore* store_;
  std::vector<Candidate> heap_;
};

constexpr size_t kBlockRows = 256;

}  // namespace

// An upper bound of every row's computed score for the unit query q (bound section present).
// With the int8 query code q = sw * wq + delta and each vector x = s c + d:
//   <x, q> = s sw <c, wq> + <s c, delta> + <d, q>
//         <= s sw <c, wq> + (||x|| + ||d||) ||delta|| + ||d|| ||q||,
// where ||x|| <= 1.001 (unit vectors rounded to float16), norms rounded up. `slack` covers float
// rounding: the exact kernel's float32 dot products differ from the real ones by at most dim *
// 2^-24 * ||x|| ||q|| each, and the bound's own few float operations by a few ulps of values
// below 4.
std::vector<float> ClipStore::Impl::Bounds(const std::vector<float>& q) const {
  double qq = 0, qmax = 0;
  for (float x : q) {
    qq += static_cast<double>(x) * x;
    qmax = std::max(qmax, std::fabs(static_cast<double>(x)));
  }
  const float sw = qmax > 0 ? static_cast<float>(qmax / 127.0) : 1.0f;
  std::vector<int8_t> wq(dim);
  double delta = 0;
  for (size_t j = 0; j < dim; ++j) {
    const long v = std::clamp<long>(std::lrint(q[j] / sw), -127, 127);
    wq[j] = static_cast<int8_t>(v);
    const double e = q[j] - static_cast<double>(sw) * static_cast<double>(v);
    delta += e * e;
  }
  const double dn = std::sqrt(delta) * (1 + 1e-9) + 1e-12;
  const float k[3] = {sw, RoundUp(std::sqrt(qq) * (1 + 1e-9) + 1e-12 + dn), RoundUp(1.001 * dn)};
  std::vector<float> out(n);
  clip::BestKernels().bound(bound_codes, bound_params, n, views + 1, dim, wq.data(), k, out.data());
  const float slack = static_cast<float>(2.0 * (dim + 64) * std::ldexp(1.0, -24) + 1e-5);
  for (float& b : out) b += slack;
  return out;
}

std::vector<ClipHit> ClipStore::Search(std::span<const float> query,
                                       const ClipSearchOptions& options) const {
  const Impl& s = *impl_;
  const std::string file = s.where();
  if (query.size() != s.dim) {
    throw Error("query has " + std::to_string(query.size()) + " values, the store holds " +
                    std::to_string(s.dim) + "-value vectors",
                file);
  }
  double norm = 0;
  for (float x : query) {
    if (!std::isfinite(x)) throw Error("query holds a NaN or Inf", file);
    norm += static_cast<double>(x) * x;
  }
  if (!(norm > 0)) throw Error("query is a zero vector", file);
  std::vector<float> q(s.dim);
  const double inv = 1.0 / std::sqrt(norm);
  for (size_t j = 0; j < s.dim; ++j) q[j] = static_cast<float>(query[j] * inv);

  const clip::Kernels& kernels = clip::BestKernels();
  const size_t k = options.top_k;
  const size_t stride = (s.views + 1) * s.dim;
  auto accept = [&](size_t row, float score) {
    return score >= options.threshold && (!options.keep || options.keep(row));
  };
  TopK best(k, *this);
  if (k == 0 || s.n == 0) return {};

  size_t scored = 0;
  if (options.approximate && s.codes != nullptr) {
    // First pass: int8 codes against the projected query; then the exact score of the best
    // `candidates` rows.
    std::vector<float> pq(s.approx_dim);
    for (size_t i = 0; i < s.approx_dim; ++i) {
      const float* bi = s.basis + i * s.dim;
      float d = 0;
      for (size_t j = 0; j < s.dim; ++j) d += bi[j] * q[j];
      pq[i] = d;
    }
    std::vector<float> approx(s.n);
    kernels.approx(s.codes, s.scales, s.n, s.approx_dim, pq.data(), approx.data());
    const size_t want = std::min(
        s.n, options.candidates != 0 ? options.candidates : std::max<size_t>(1000, 20 * k));
    std::vector<Candidate> cand(s.n);
    for (size_t r = 0; r < s.n; ++r) cand[r] = {approx[r], static_cast<uint32_t>(r)};
    if (want < s.n) {
      std::nth_element(cand.begin(), cand.begin() + static_cast<ptrdiff_t>(want), cand.end(),
                       [](const Candidate& a, const Candidate& b) {
                         return a.score != b.score ? a.score > b.score : a.row < b.row;
                       });
      cand.resize(want);
    }
    std::sort(cand.begin(), cand.end(),
              [](const Candidate& a, const Candidate& b) { return a.row < b.row; });
    for (const Candidate& c : cand) {
      float score = 0;
      kernels.score(s.records + c.row * stride, 1, s.views, s.dim, q.data(), &score);
      if (accept(c.row, score)) best.Offer({score, c.row});
    }
    scored = cand.size();
  } else if (!options.full_scan && s.bound_codes != nullptr) {
    // Upper bounds of every score from the bound codes, then exact scores best bound first
    // until the next bound is below the k-th best exact score (docs/search.md).
    const std::vector<float> bound = s.Bounds(q);
    std::vector<Candidate> cand;
    for (size_t r = 0; r < s.n; ++r) {
      if (bound[r] >= options.threshold) cand.push_back({bound[r], static_cast<uint32_t>(r)});
    }
    auto lower = [](const Candidate& a, const Candidate& b) { return a.score < b.score; };
    std::make_heap(cand.begin(), cand.end(), lower);
    while (!cand.empty()) {
      std::pop_heap(cand.begin(), cand.end(), lower);
      const Candidate c = cand.back();
      cand.pop_back();
      if (best.full() && c.score < best.worst()) break;
      float score = 0;
      kernels.score(s.records + c.row * stride, 1, s.views, s.dim, q.data(), &score);
      ++scored;
      if (accept(c.row, score)) best.Offer({score, c.row});
    }
  } else {
    scored = s.n;
    const int threads = ParallelThreads(options.threads, (s.n + kBlockRows - 1) / kBlockRows);
    std::vector<TopK> partial(static_cast<size_t>(threads), TopK(k, *this));
    const size_t per = (s.n + static_cast<size_t>(threads) - 1) / static_cast<size_t>(threads);
    ParallelFor(static_cast<size_t>(threads), threads, [&](size_t t) {
      float scores[kBlockRows];
      const size_t end = std::min(s.n, (t + 1) * per);
      for (size_t r0 = t * per; r0 < end; r0 += kBlockRows) {
        const size_t rows = std::min(kBlockRows, end - r0);
        kernels.score(s.records + r0 * stride, rows, s.views, s.dim, q.data(), scores);
        for (size_t i = 0; i < rows; ++i) {
          if (accept(r0 + i, scores[i]))
            partial[t].Offer({scores[i], static_cast<uint32_t>(r0 + i)});
        }
      }
    });
    for (const TopK& p : partial) {
      for (const Candidate& c : p.items()) best.Offer(c);
    }
  }
  if (options.scored != nullptr) *options.scored = scored;
  std::vector<Candidate> items = best.items();
  std::sort(items.begin(), items.end(),
            [&](const Candidate& a, const Candidate& b) { return best.Better(a, b); });
  std::vector<ClipHit> hits;
  hits.reserve(items.size());
  for (const Candidate& c : items) hits.push_back({s.Uid(c.row), c.score});
  return hits;
}

std::string_view ClipKernelName() { return clip::BestKernels().name; }

}  // namespace mlspaces
