#include "mlspaces/core/npy.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "npy_internal.h"

namespace mlspaces {
namespace {

static_assert(std::endian::native == std::endian::little, "mlspaces assumes a little-endian host");

constexpr char kMagic[] = "\x93NUMPY";
constexpr size_t kMagicLen = 6;
constexpr size_t kMaxDims = 64;
// numpy pads the header with room for the growth axis to reach this many digits.
constexpr size_t kGrowthAxisMaxDigits = 21;
constexpr size_t kArrayAlign = 64;

// A cursor over the python-literal header dict, e.g.
// {'descr': '<f8', 'fortran_order': False, 'shape': (3, 4), }
class DictParser {
 public:
  DictParser(std::string_view text, const std::string& path, const std::string& member)
      : text_(text), path_(path), member_(member) {}

  [[noreturn]] void Fail(const std::string& message) const {
    throw Error("bad .npy header: " + message, path_, member_);
  }

  void SkipSpace() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\t' ||
                                   text_[pos_] == '\n' || text_[pos_] == '\r')) {
      ++pos_;
    }
  }
  bool AtEnd() const { return pos_ >= text_.size(); }
  char Peek() const { return AtEnd() ? '\0' : text_[pos_]; }
  bool Consume(char c) {
    SkipSpace();
    if (Peek() != c) return false;
    ++pos_;
    return true;
  }
  void Expect(char c, const char* what) {
    if (!Consume(c)) Fail(std::string("expected ") + what);
  }

  std::string ParseString() {
    SkipSpace();
    char quote = Peek();
    if (quote != '\'' && quote != '"') Fail("expected a quoted string");
    ++pos_;
    size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != quote) {
      if (text_[pos_] == '\\' || text_[pos_] == '\n') Fail("unsupported character in string");
      ++pos_;
    }
    if (AtEnd()) Fail("unterminated string");
    std::string out(text_.substr(start, pos_ - start));
    ++pos_;
    return out;
  }

  bool ParseBool() {
    SkipSpace();
    if (text_.substr(pos_, 4) == "True") {
      pos_ += 4;
      return true;
    }
    if (text_.substr(pos_, 5) == "False") {
      pos_ += 5;
      return false;
    }
    Fail("'fortran_order' must be True or False");
  }

  size_t ParseInt() {
    SkipSpace();
    if (Peek() == '-') Fail("negative dimension in 'shape'");
    if (Peek() < '0' || Peek() > '9') Fail("'shape' must be a tuple of integers");
    if (Peek() == '0' && pos_ + 1 < text_.size() && text_[pos_ + 1] >= '0' &&
        text_[pos_ + 1] <= '9') {
      Fail("bad integer in 'shape'");
    }
    size_t value = 0;
    while (Peek() >= '0' && Peek() <= '9') {
      size_t digit = static_cast<size_t>(Peek() - '0');
      if (value > (std::numeric_limits<size_t>::max() - digit) / 10) {
        Fail("dimension too large in 'shape'");
      }
      value = value * 10 + digit;
      ++pos_;
    }
    return value;
  }

  // A python tuple of non-negative ints: (), (3,), (3, 4), (3, 4,).
  std::vector<size_t> ParseShape() {
    SkipSpace();
    if (!Consume('(')) Fail("'shape' must be a tuple");
    std::vector<size_t> shape;
    if (Consume(')')) return shape;
    for (;;) {
      shape.push_back(ParseInt());
      if (shape.size() > kMaxDims) Fail("too many dimensions in 'shape'");
      if (Consume(')')) {
        // "(3)" is an int in python, not a tuple.
        if (shape.size() == 1) Fail("'shape' must be a tuple");
        return shape;
      }
      if (!Consume(',')) Fail("expected ',' or ')' in 'shape'");
      if (Consume(')')) return shape;
    }
  }

 private:
  std::string_view text_;
  const std::string& path_;
  const std::string& member_;
  size_t pos_ = 0;
};

DType ParseDescr(const std::string& descr, bool* big_endian, const DictParser& parser) {
  if (descr.size() != 3 || std::string_view("<>|=").find(descr[0]) == std::string_view::npos) {
    if (descr.find('O') != std::string::npos) parser.Fail("object arrays are not supported");
    parser.Fail("unsupported dtype '" + descr + "'");
  }
  std::string_view kind = std::string_view(descr).substr(1);
  DType dtype;
  if (kind == "f2") {
    dtype = DType::kF2;
  } else if (kind == "f4") {
    dtype = DType::kF4;
  } else if (kind == "f8") {
    dtype = DType::kF8;
  } else if (kind == "i4") {
    dtype = DType::kI4;
  } else if (kind == "i8") {
    dtype = DType::kI8;
  } else if (kind == "u1") {
    dtype = DType::kU1;
  } else if (kind == "b1") {
    dtype = DType::kB1;
  } else if (kind[0] == 'O') {
    parser.Fail("object arrays are not supported");
  } else {
    parser.Fail("unsupported dtype '" + descr + "'");
  }
  // '|' (not applicable) and '=' (native) both mean little-endian on our hosts.
  *big_endian = descr[0] == '>' && DTypeSize(dtype) > 1;
  return dtype;
}

template <typename T>
T Load(const uint8_t* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  return value;
}

template <typename T>
void Store(uint8_t* p, T value) {
  std::memcpy(p, &value, sizeof(T));
}

// Copies one element of `size` bytes.
inline void CopyItem(uint8_t* dst, const uint8_t* src, size_t size) {
  switch (size) {
    case 1:
      *dst = *src;
      break;
    case 2:
      std::memcpy(dst, src, 2);
      break;
    case 4:
      std::memcpy(dst, src, 4);
      break;
    default:
      std::memcpy(dst, src, 8);
      break;
  }
}

// Reorders elements between C order and Fortran order. With `to_c` true, `src` is Fortran and
// `dst` C; otherwise the other way round.
void Transpose(const std::vector<size_t>& shape, size_t item_size, const uint8_t* src, uint8_t* dst,
               bool to_c) {
  size_t ndim = shape.size();
  size_t count = 1;
  for (size_t d : shape) count *= d;
  if (count == 0) return;
  std::vector<size_t> fstride(ndim), idx(ndim, 0);
  size_t stride = 1;
  for (size_t k = 0; k < ndim; ++k) {
    fstride[k] = stride * item_size;
    stride *= shape[k];
  }
  size_t foffset = 0;
  for (size_t i = 0; i < count; ++i) {
    uint8_t* c_ptr = to_c ? dst + i * item_size : nullptr;
    if (to_c) {
      CopyItem(c_ptr, src + foffset, item_size);
    } else {
      CopyItem(dst + foffset, src + i * item_size, item_size);
    }
    // Advance the C-order multi-index (last axis fastest).
    for (size_t k = ndim; k-- > 0;) {
      if (++idx[k] < shape[k]) {
        foffset += fstride[k];
        break;
      }
      foffset -= (shape[k] - 1) * fstride[k];
      idx[k] = 0;
    }
  }
}

size_t ShapeProduct(const std::vector<size_t>& shape) {
  size_t n = 1;
  for (size_t d : shape) n *= d;
  return n;
}

}  // namespace

namespace internal {

void SwapBytes(uint8_t* data, size_t count, size_t item_size) {
  switch (item_size) {
    case 2:
      for (size_t i = 0; i < count; ++i) {
        Store(data + 2 * i, __builtin_bswap16(Load<uint16_t>(data + 2 * i)));
      }
      break;
    case 4:
      for (size_t i = 0; i < count; ++i) {
        Store(data + 4 * i, __builtin_bswap32(Load<uint32_t>(data + 4 * i)));
      }
      break;
    case 8:
      for (size_t i = 0; i < count; ++i) {
        Store(data + 8 * i, __builtin_bswap64(Load<uint64_t>(data + 8 * i)));
      }
      break;
    default:
      break;
  }
}

void NormalizeBools(uint8_t* data, size_t count) {
  for (size_t i = 0; i < count; ++i) data[i] = data[i] != 0;
}

void ConvertToNative(const NpyHeader& header, const uint8_t* src, uint8_t* dst) {
  size_t count = header.num_elements();
  size_t item_size = DTypeSize(header.dtype);
  if (count == 0) return;
  if (header.fortran_order && header.shape.size() > 1) {
    Transpose(header.shape, item_size, src, dst, /*to_c=*/true);
  } else {
    std::memcpy(dst, src, count * item_size);
  }
  if (header.big_endian) SwapBytes(dst, count, item_size);
  if (header.dtype == DType::kB1) NormalizeBools(dst, count);
}

NpyArray ToNativeArray(NpyHeader header, std::span<const uint8_t> bytes) {
  NpyArray out;
  out.dtype = header.dtype;
  out.data.resize(header.data_bytes());
  ConvertToNative(header, bytes.data() + header.data_offset, out.data.data());
  out.shape = std::move(header.shape);
  return out;
}

NpyHeader ParseNpyHeader(std::span<const uint8_t> bytes, const std::string& path,
                         const std::string& member) {
  auto fail = [&](const std::string& message) -> void { throw Error(message, path, member); };
  if (bytes.size() < kMagicLen + 2 || std::memcmp(bytes.data(), kMagic, kMagicLen) != 0) {
    fail(bytes.size() < kMagicLen + 2 ? "not a .npy file (too short)"
                                      : "not a .npy file (bad magic)");
  }
  uint8_t major = bytes[6], minor = bytes[7];
  if (major < 1 || major > 3 || minor != 0) {
    fail("unsupported .npy format version " + std::to_string(major) + "." + std::to_string(minor));
  }
  size_t len_size = major == 1 ? 2 : 4;
  size_t prefix = kMagicLen + 2 + len_size;
  if (bytes.size() < prefix) fail("truncated .npy header");
  size_t header_len = major == 1 ? Load<uint16_t>(bytes.data() + 8)
                                 : static_cast<size_t>(Load<uint32_t>(bytes.data() + 8));
  if (header_len > bytes.size() - prefix) fail("truncated .npy header");

  std::string_view text(reinterpret_cast<const char*>(bytes.data() + prefix), header_len);
  DictParser parser(text, path, member);
  std::optional<std::string> descr;
  std::optional<bool> fortran;
  std::optional<std::vector<size_t>> shape;
  parser.Expect('{', "'{'");
  if (!parser.Consume('}')) {
    for (;;) {
      std::string key = parser.ParseString();
      parser.Expect(':', "':'");
      if (key == "descr") {
        if (descr) parser.Fail("duplicate key 'descr'");
        parser.SkipSpace();
        if (parser.Peek() == '[') parser.Fail("structured dtypes are not supported");
        descr = parser.ParseString();
      } else if (key == "fortran_order") {
        if (fortran) parser.Fail("duplicate key 'fortran_order'");
        fortran = parser.ParseBool();
      } else if (key == "shape") {
        if (shape) parser.Fail("duplicate key 'shape'");
        shape = parser.ParseShape();
      } else {
        parser.Fail("unexpected key '" + key + "'");
      }
      if (parser.Consume('}')) break;
      parser.Expect(',', "',' or '}'");
      if (parser.Consume('}')) break;
    }
  }
  parser.SkipSpace();
  if (!parser.AtEnd()) parser.Fail("trailing characters after the dict");
  if (!descr) parser.Fail("missing key 'descr'");
  if (!fortran) parser.Fail("missing key 'fortran_order'");
  if (!shape) parser.Fail("missing key 'shape'");

  NpyHeader header;
  header.dtype = ParseDescr(*descr, &header.big_endian, parser);
  header.fortran_order = *fortran;
  header.shape = std::move(*shape);
  header.data_offset = prefix + header_len;
  size_t total = DTypeSize(header.dtype);
  for (size_t d : header.shape) {
    if (__builtin_mul_overflow(total, d, &total)) parser.Fail("array size overflows");
  }
  return header;
}

}  // namespace internal

std::string ShapeRepr(const std::vector<size_t>& shape) {
  std::string out = "(";
  for (size_t i = 0; i < shape.size(); ++i) {
    if (i > 0) out += ", ";
    out += std::to_string(shape[i]);
  }
  if (shape.size() == 1) out += ",";
  out += ")";
  return out;
}

size_t DTypeSize(DType dtype) {
  switch (dtype) {
    case DType::kF2:
      return 2;
    case DType::kF4:
      return 4;
    case DType::kF8:
      return 8;
    case DType::kI4:
      return 4;
    case DType::kI8:
      return 8;
    case DType::kU1:
    case DType::kB1:
      return 1;
  }
  return 1;
}

std::string DTypeDescr(DType dtype, bool big_endian) {
  const char order = big_endian ? '>' : '<';
  switch (dtype) {
    case DType::kF2:
      return std::string(1, order) + "f2";
    case DType::kF4:
      return std::string(1, order) + "f4";
    case DType::kF8:
      return std::string(1, order) + "f8";
    case DType::kI4:
      return std::string(1, order) + "i4";
    case DType::kI8:
      return std::string(1, order) + "i8";
    case DType::kU1:
      return "|u1";
    case DType::kB1:
      return "|b1";
  }
  return "|u1";
}

size_t NpyHeader::num_elements() const { return ShapeProduct(shape); }

size_t NpyArray::num_elements() const { return ShapeProduct(shape); }

double NpyArray::AsDouble(size_t i) const {
  const uint8_t* p = data.data() + i * DTypeSize(dtype);
  switch (dtype) {
    case DType::kF2:
      return HalfToDouble(Load<uint16_t>(p));
    case DType::kF4:
      return Load<float>(p);
    case DType::kF8:
      return Load<double>(p);
    case DType::kI4:
      return Load<int32_t>(p);
    case DType::kI8:
      return static_cast<double>(Load<int64_t>(p));
    case DType::kU1:
      return *p;
    case DType::kB1:
      return *p != 0 ? 1.0 : 0.0;
  }
  return 0.0;
}

std::vector<double> NpyArray::ToDoubles() const {
  size_t n = std::min(num_elements(), data.size() / DTypeSize(dtype));
  std::vector<double> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = AsDouble(i);
  return out;
}

NpyArray NpyArray::FromDoubles(std::vector<size_t> shape, std::span<const double> values) {
  return FromDoubles(DType::kF8, std::move(shape), values);
}

namespace {

template <typename T>
T SaturatingCast(double v) {
  if (std::isnan(v)) return 0;
  constexpr double lo = static_cast<double>(std::numeric_limits<T>::min());
  // max()+1 is a power of two and exact in double.
  constexpr double hi_excl = static_cast<double>(std::numeric_limits<T>::max()) + 1.0;
  if (v <= lo) return std::numeric_limits<T>::min();
  if (v >= hi_excl) return std::numeric_limits<T>::max();
  return static_cast<T>(v);
}

}  // namespace

NpyArray NpyArray::FromDoubles(DType dtype, std::vector<size_t> shape,
                               std::span<const double> values) {
  NpyArray out;
  out.dtype = dtype;
  out.shape = std::move(shape);
  size_t n = out.num_elements();
  if (values.size() != n) {
    throw Error("NpyArray::FromDoubles: " + std::to_string(values.size()) + " values for shape " +
                ShapeRepr(out.shape));
  }
  size_t item = DTypeSize(dtype);
  out.data.resize(n * item);
  uint8_t* p = out.data.data();
  for (size_t i = 0; i < n; ++i, p += item) {
    double v = values[i];
    switch (dtype) {
      case DType::kF2:
        Store(p, DoubleToHalf(v));
        break;
      case DType::kF4:
        Store(p, static_cast<float>(v));
        break;
      case DType::kF8:
        Store(p, v);
        break;
      case DType::kI4:
        Store(p, SaturatingCast<int32_t>(v));
        break;
      case DType::kI8:
        Store(p, SaturatingCast<int64_t>(v));
        break;
      case DType::kU1:
        *p = SaturatingCast<uint8_t>(v);
        break;
      case DType::kB1:
        *p = v != 0.0 ? 1 : 0;
        break;
    }
  }
  return out;
}

NpyHeader ParseNpyHeader(std::span<const uint8_t> bytes, const std::string& source) {
  return internal::ParseNpyHeader(bytes, source, {});
}

NpyArray ParseNpy(std::span<const uint8_t> bytes, const std::string& source) {
  NpyHeader header = internal::ParseNpyHeader(bytes, source, {});
  size_t have = bytes.size() - header.data_offset;
  if (have != header.data_bytes()) {
    throw Error("array data is " + std::to_string(have) + " bytes, shape " +
                    ShapeRepr(header.shape) + " and dtype " +
                    DTypeDescr(header.dtype, header.big_endian) + " need " +
                    std::to_string(header.data_bytes()),
                source);
  }
  return internal::ToNativeArray(std::move(header), bytes);
}

std::string SerializeNpy(const NpyArray& array, const NpyWriteOptions& options) {
  size_t item = DTypeSize(array.dtype);
  size_t n = array.num_elements();
  if (array.data.size() != n * item) {
    throw Error("cannot write array: data is " + std::to_string(array.data.size()) +
                " bytes, shape " + ShapeRepr(array.shape) + " needs " + std::to_string(n * item));
  }
  // Exactly what numpy.lib.format writes: sorted keys, repr values, growth-axis padding.
  bool fortran = options.fortran_order && array.shape.size() > 1;
  std::string dict = "{'descr': '" + DTypeDescr(array.dtype, options.big_endian) +
                     "', 'fortran_order': " + (fortran ? "True" : "False") +
                     ", 'shape': " + ShapeRepr(array.shape) + ", }";
  if (!array.shape.empty()) {
    size_t growth = fortran ? array.shape.back() : array.shape.front();
    size_t digits = std::to_string(growth).size();
    if (digits < kGrowthAxisMaxDigits) dict.append(kGrowthAxisMaxDigits - digits, ' ');
  }
  size_t hlen = dict.size() + 1;  // + '\n'
  int major = 1;
  size_t len_size = 2;
  size_t padlen = kArrayAlign - ((kMagicLen + 2 + len_size + hlen) % kArrayAlign);
  if (hlen + padlen > 0xFFFF) {
    major = 2;
    len_size = 4;
    padlen = kArrayAlign - ((kMagicLen + 2 + len_size + hlen) % kArrayAlign);
  }
  std::string out;
  out.reserve(kMagicLen + 2 + len_size + hlen + padlen + n * item);
  out.append(kMagic, kMagicLen);
  out.push_back(static_cast<char>(major));
  out.push_back(0);
  uint32_t total = static_cast<uint32_t>(hlen + padlen);
  for (size_t i = 0; i < len_size; ++i) out.push_back(static_cast<char>((total >> (8 * i)) & 0xFF));
  out += dict;
  out.append(padlen, ' ');
  out.push_back('\n');
  size_t start = out.size();
  out.resize(start + n * item);
  uint8_t* dst = reinterpret_cast<uint8_t*>(out.data()) + start;
  if (n > 0) {
    if (fortran) {
      Transpose(array.shape, item, array.data.data(), dst, /*to_c=*/false);
    } else {
      std::memcpy(dst, array.data.data(), n * item);
    }
    if (options.big_endian) internal::SwapBytes(dst, n, item);
  }
  return out;
}

NpyArray ReadNpyFile(const std::string& path) {
  std::string bytes = ReadFile(path);
  return ParseNpy(std::span(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()), path);
}

void WriteNpyFile(const std::string& path, const NpyArray& array, const NpyWriteOptions& options) {
  WriteFileAtomic(path, SerializeNpy(array, options));
}

double HalfToDouble(uint16_t h) {
  bool negative = (h & 0x8000) != 0;
  uint32_t exp = (h >> 10) & 0x1F;
  uint32_t mant = h & 0x3FF;
  double value;
  if (exp == 0) {
    value = std::ldexp(static_cast<double>(mant), -24);  // zero or subnormal
  } else if (exp == 0x1F) {
    if (mant == 0) {
      value = std::numeric_limits<double>::infinity();
    } else {
      // NaN: keep the payload in the top significand bits (as numpy does).
      uint64_t bits = 0x7FF0000000000000ULL | (static_cast<uint64_t>(mant) << 42);
      value = std::bit_cast<double>(bits);
    }
  } else {
    value = std::ldexp(static_cast<double>(mant | 0x400), static_cast<int>(exp) - 25);
  }
  return negative ? -value : value;
}

float HalfToFloat(uint16_t h) {
  const uint32_t sign = static_cast<uint32_t>(h & 0x8000u) << 16;
  const uint32_t exp = (h >> 10) & 0x1fu;
  uint32_t mant = h & 0x3ffu;
  uint32_t bits;
  if (exp == 0x1f) {
    bits = sign | 0x7f800000u | (mant << 13);
  } else if (exp != 0) {
    bits = sign | ((exp + 112) << 23) | (mant << 13);
  } else if (mant == 0) {
    bits = sign;
  } else {  // subnormal: normalise
    uint32_t e = 113;
    while ((mant & 0x400u) == 0) {
      mant <<= 1;
      --e;
    }
    bits = sign | (e << 23) | ((mant & 0x3ffu) << 13);
  }
  return std::bit_cast<float>(bits);
}

uint16_t DoubleToHalf(double d) {
  // Same algorithm as numpy's npy_doublebits_to_halfbits: round to nearest, ties to even.
  uint64_t bits = std::bit_cast<uint64_t>(d);
  uint16_t sign = static_cast<uint16_t>((bits >> 48) & 0x8000);
  uint64_t exp = bits & 0x7FF0000000000000ULL;
  uint64_t mant = bits & 0x000FFFFFFFFFFFFFULL;
  if (exp >= 0x40F0000000000000ULL) {  // |d| >= 65536, inf or NaN
    if (exp == 0x7FF0000000000000ULL && mant != 0) {
      uint16_t nan = static_cast<uint16_t>(0x7C00 + (mant >> 42));
      if (nan == 0x7C00) ++nan;  // keep it a NaN
      return static_cast<uint16_t>(sign | nan);
    }
    return static_cast<uint16_t>(sign | 0x7C00);
  }
  if (exp <= 0x3F00000000000000ULL) {              // |d| < 2^-14: half subnormal or zero
    if (exp < 0x3E60000000000000ULL) return sign;  // < 2^-25: rounds to zero
    uint64_t e = exp >> 52;
    uint64_t sig = 0x0010000000000000ULL + mant;
    sig <<= (e - 998);
    if ((sig & 0x003FFFFFFFFFFFFFULL) != 0x0010000000000000ULL) sig += 0x0010000000000000ULL;
    return static_cast<uint16_t>(sign + (sig >> 53));
  }
  uint64_t hexp = (exp - 0x3F00000000000000ULL) >> 42;
  if ((mant & 0x000007FFFFFFFFFFULL) != 0x0000020000000000ULL) mant += 0x0000020000000000ULL;
  // A carry out of the significand bumps the exponent, possibly to inf: both correct.
  return static_cast<uint16_t>(sign + hexp + (mant >> 42));
}

}  // namespace mlspaces
