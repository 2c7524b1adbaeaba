#include "mlspaces/core/npy.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ExpectError;
using ::mlspaces::testing::RunPython;
using ::mlspaces::testing::TempDir;
using ::testing::HasSubstr;

std::span<const uint8_t> Bytes(const std::string& s) {
  return {reinterpret_cast<const uint8_t*>(s.data()), s.size()};
}

// Builds a .npy image by hand: magic, version, header text (padded with '\n'), data.
std::string MakeNpy(int major, const std::string& dict, const std::string& data, int minor = 0) {
  std::string out = "\x93NUMPY";
  out.push_back(static_cast<char>(major));
  out.push_back(static_cast<char>(minor));
  std::string header = dict + "\n";
  uint32_t len = static_cast<uint32_t>(header.size());
  int len_bytes = major == 1 ? 2 : 4;
  for (int i = 0; i < len_bytes; ++i) out.push_back(static_cast<char>((len >> (8 * i)) & 0xFF));
  return out + header + data;
}

template <typename T>
std::string Raw(std::initializer_list<T> values) {
  std::string out;
  for (T v : values) out.append(reinterpret_cast<const char*>(&v), sizeof v);
  return out;
}

// The values the interop tests use at flat C index i, shared with the python scripts.
double TestValue(const std::string& code, size_t i) {
  double x = static_cast<double>(i);
  if (code[0] == 'f') return x * 0.75 - 3.5;
  if (code == "i4") return x * 100000 - 50;
  if (code == "i8") return x * 3000000000.0 - 5;
  if (code == "u1") return static_cast<double>((i * 37) % 256);
  return i % 3 == 0 ? 1.0 : 0.0;  // b1
}

constexpr char kPythonValues[] = R"(
import sys, os
import numpy as np
def vals(code, n):
    i = np.arange(n, dtype=np.int64)
    if code[0] == 'f': return i * 0.75 - 3.5
    if code == 'i4': return i * 100000 - 50
    if code == 'i8': return i * 3000000000 - 5
    if code == 'u1': return (i * 37) % 256
    return i % 3 == 0
CODES = ['f2', 'f4', 'f8', 'i4', 'i8', 'u1', 'b1']
SHAPES = [(), (5,), (3, 4), (2, 3, 4), (2, 3, 2, 3), (0, 3)]
def make(code, order, fortran, shape):
    a = vals(code, int(np.prod(shape))).astype(np.dtype(order + code)).reshape(shape)
    return np.asfortranarray(a) if fortran and a.ndim > 1 else a
def cases():
    # (code, order, fortran, shape, file name) of every interop case; names as FileName().
    for code in CODES:
        for order in '<>':
            for fortran in (False, True):
                for si, shape in enumerate(SHAPES):
                    yield code, order, fortran, shape, '%s_%s_%s_%d.npy' % (
                        code, 'le' if order == '<' else 'be', 'F' if fortran else 'C', si)
)";

const std::vector<std::pair<std::string, DType>> kCodes = {
    {"f2", DType::kF2}, {"f4", DType::kF4}, {"f8", DType::kF8}, {"i4", DType::kI4},
    {"i8", DType::kI8}, {"u1", DType::kU1}, {"b1", DType::kB1}};
const std::vector<std::vector<size_t>> kShapes = {{}, {5}, {3, 4}, {2, 3, 4}, {2, 3, 2, 3}, {0, 3}};

size_t Product(const std::vector<size_t>& shape) {
  size_t n = 1;
  for (size_t d : shape) n *= d;
  return n;
}

NpyArray MakeTestArray(const std::string& code, DType dtype, const std::vector<size_t>& shape) {
  std::vector<double> values(Product(shape));
  for (size_t i = 0; i < values.size(); ++i) values[i] = TestValue(code, i);
  return NpyArray::FromDoubles(dtype, shape, values);
}

std::string FileName(const std::string& code, char order, bool fortran, size_t shape_index) {
  return code + "_" + (order == '<' ? "le" : "be") + "_" + (fortran ? "F" : "C") + "_" +
         std::to_string(shape_index) + ".npy";
}

TEST(NpyTest, DTypeSizeAndDescr) {
  EXPECT_EQ(DTypeSize(DType::kF2), 2u);
  EXPECT_EQ(DTypeSize(DType::kF4), 4u);
  EXPECT_EQ(DTypeSize(DType::kF8), 8u);
  EXPECT_EQ(DTypeSize(DType::kI4), 4u);
  EXPECT_EQ(DTypeSize(DType::kI8), 8u);
  EXPECT_EQ(DTypeSize(DType::kU1), 1u);
  EXPECT_EQ(DTypeSize(DType::kB1), 1u);
  EXPECT_EQ(DTypeDescr(DType::kF8), "<f8");
  EXPECT_EQ(DTypeDescr(DType::kF2, true), ">f2");
  EXPECT_EQ(DTypeDescr(DType::kI8, true), ">i8");
  EXPECT_EQ(DTypeDescr(DType::kU1, true), "|u1");
  EXPECT_EQ(DTypeDescr(DType::kB1), "|b1");
}

TEST(NpyTest, SerializeMatchesNumpyLayout) {
  NpyArray a = NpyArray::FromDoubles({1, 4, 4}, std::vector<double>(16, 0.0));
  std::string npy = SerializeNpy(a);
  // np.save of a (1, 4, 4) <f8 array: 10-byte prefix + 118-byte header, data at 128.
  ASSERT_EQ(npy.size(), 128u + 16 * 8);
  EXPECT_EQ(npy.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  EXPECT_EQ(static_cast<uint8_t>(npy[8]) | (static_cast<uint8_t>(npy[9]) << 8), 118);
  EXPECT_EQ(npy.substr(10, 62), "{'descr': '<f8', 'fortran_order': False, 'shape': (1, 4, 4), }");
  EXPECT_EQ(npy[127], '\n');
}

TEST(NpyTest, RoundTripEveryDtypeOrderAndShape) {
  for (const auto& [code, dtype] : kCodes) {
    for (bool big : {false, true}) {
      for (bool fortran : {false, true}) {
        for (const auto& shape : kShapes) {
          SCOPED_TRACE(code + (big ? " big" : " little") + (fortran ? " F" : " C") + " ndim " +
                       std::to_string(shape.size()));
          NpyArray a = MakeTestArray(code, dtype, shape);
          std::string npy = SerializeNpy(a, {.big_endian = big, .fortran_order = fortran});
          EXPECT_EQ(npy.size() % 64, a.data.size() % 64);
          NpyHeader h = ParseNpyHeader(Bytes(npy), "mem");
          EXPECT_EQ(h.dtype, dtype);
          EXPECT_EQ(h.big_endian, big && DTypeSize(dtype) > 1);
          EXPECT_EQ(h.fortran_order, fortran && shape.size() > 1);
          EXPECT_EQ(h.shape, shape);
          EXPECT_EQ(h.data_offset % 64, 0u);
          NpyArray b = ParseNpy(Bytes(npy), "mem");
          EXPECT_EQ(b.dtype, dtype);
          EXPECT_EQ(b.shape, shape);
          EXPECT_EQ(b.data, a.data);
          std::vector<double> values = b.ToDoubles();
          ASSERT_EQ(values.size(), Product(shape));
          for (size_t i = 0; i < values.size(); ++i) EXPECT_EQ(values[i], TestValue(code, i));
        }
      }
    }
  }
}

TEST(NpyTest, FortranOrderIsConvertedToC) {
  // A (2, 3) array stored column-major: columns (0, 3), (1, 4), (2, 5).
  std::string npy = MakeNpy(1, "{'descr': '<i4', 'fortran_order': True, 'shape': (2, 3)}",
                            Raw<int32_t>({0, 3, 1, 4, 2, 5}));
  NpyArray a = ParseNpy(Bytes(npy), "f.npy");
  EXPECT_EQ(a.shape, (std::vector<size_t>{2, 3}));
  EXPECT_THAT(a.ToDoubles(), ::testing::ElementsAre(0, 1, 2, 3, 4, 5));
}

TEST(NpyTest, BigEndianIsConvertedToNative) {
  std::string data = {'\x3f', '\xf0', 0, 0, 0, 0, 0, 0, '\xc0', 0, 0, 0, 0, 0, 0, 0};
  std::string npy = MakeNpy(1, "{'descr': '>f8', 'fortran_order': False, 'shape': (2,), }", data);
  EXPECT_THAT(ParseNpy(Bytes(npy), "x").ToDoubles(), ::testing::ElementsAre(1.0, -2.0));
}

TEST(NpyTest, HeaderDictVariants) {
  std::string d8 = Raw<double>({1.5, 2.5, 3.5});
  // Any key order, double quotes, odd spacing, no trailing comma, v2 and v3 headers.
  for (const std::string& dict :
       {std::string("{'shape': (3,), 'fortran_order': False, 'descr': '<f8'}"),
        std::string("{ \"descr\" : \"<f8\" ,\n 'shape':( 3 , ) ,'fortran_order':False,}"),
        std::string("{'descr': '=f8', 'fortran_order': False, 'shape': (3,)}"),
        std::string("{'descr': '|f8', 'fortran_order': True, 'shape': (3,)}")}) {
    for (int major : {1, 2, 3}) {
      SCOPED_TRACE(dict + " v" + std::to_string(major));
      NpyArray a = ParseNpy(Bytes(MakeNpy(major, dict, d8)), "x.npy");
      EXPECT_EQ(a.dtype, DType::kF8);
      EXPECT_THAT(a.ToDoubles(), ::testing::ElementsAre(1.5, 2.5, 3.5));
    }
  }
  // 0-d arrays and multi-dimensional tuples with a trailing comma.
  NpyArray scalar =
      ParseNpy(Bytes(MakeNpy(1, "{'descr': '<i8', 'fortran_order': False, 'shape': ()}",
                             Raw<int64_t>({-7}))),
               "s.npy");
  EXPECT_TRUE(scalar.shape.empty());
  EXPECT_EQ(scalar.num_elements(), 1u);
  EXPECT_EQ(scalar.AsDouble(0), -7.0);
  NpyHeader h = ParseNpyHeader(
      Bytes(
          MakeNpy(1, "{'descr': '|u1', 'fortran_order': False, 'shape': (2, 3, 1,), }", "abcdef")),
      "h.npy");
  EXPECT_EQ(h.shape, (std::vector<size_t>{2, 3, 1}));
  EXPECT_EQ(h.dtype, DType::kU1);
  EXPECT_EQ(h.data_bytes(), 6u);
  // Bools are normalised to 0/1.
  NpyArray b = ParseNpy(Bytes(MakeNpy(1, "{'descr': '|b1', 'fortran_order': False, 'shape': (3,)}",
                                      std::string("\x00\x01\x05", 3))),
                        "b.npy");
  EXPECT_EQ(b.data, (std::vector<uint8_t>{0, 1, 1}));
}

TEST(NpyTest, RejectsBadHeaders) {
  const std::string d8 = Raw<double>({1.0, 2.0});
  struct Case {
    std::string npy;
    std::string message;
  };
  std::vector<Case> cases = {
      {"", "too short"},
      {std::string("\x93NUMPX\x01\x00\x10\x00", 10), "bad magic"},
      {MakeNpy(4, "{'descr': '<f8', 'fortran_order': False, 'shape': (2,)}", d8), "version 4.0"},
      {MakeNpy(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2,)}", d8, 1), "1.1"},
      {MakeNpy(1, "{'descr': '|O', 'fortran_order': False, 'shape': (2,)}", d8), "object"},
      {MakeNpy(1, "{'descr': [('a', '<f8')], 'fortran_order': False, 'shape': (2,)}", d8),
       "structured"},
      {MakeNpy(1, "{'descr': '<u4', 'fortran_order': False, 'shape': (4,)}", d8),
       "unsupported dtype '<u4'"},
      {MakeNpy(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2,), 'x': 1}", d8),
       "unexpected key 'x'"},
      {MakeNpy(1, "{'descr': '<f8', 'shape': (2,)}", d8), "missing key 'fortran_order'"},
      {MakeNpy(1, "{'descr': '<f8', 'descr': '<f8', 'fortran_order': False, 'shape': (2,)}", d8),
       "duplicate key 'descr'"},
      {MakeNpy(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2)}", d8), "tuple"},
      {MakeNpy(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (-2,)}", d8), "negative"},
      {MakeNpy(1, "{'descr': '<f8', 'fortran_order': 0, 'shape': (2,)}", d8), "True or False"},
      {MakeNpy(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2,)", d8), "expected"},
      {MakeNpy(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2,)} x", d8), "trailing"},
      {MakeNpy(1,
               "{'descr': '<f8', 'fortran_order': False, 'shape': (4294967296, "
               "4294967296)}",
               d8),
       "overflows"},
      {MakeNpy(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (3,)}", d8), "need 24"},
      {MakeNpy(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (1,)}", d8), "need 8"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.message);
    ExpectError([&] { ParseNpy(Bytes(c.npy), "bad.npy"); }, {"bad.npy: ", c.message});
  }
  // Header length beyond the bytes.
  std::string npy = MakeNpy(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2,)}", d8);
  ExpectError([&] { ParseNpyHeader(Bytes(npy).first(40), "t.npy"); }, {"t.npy", "truncated"});
}

TEST(NpyTest, EveryTruncationThrowsError) {
  NpyArray a = MakeTestArray("f8", DType::kF8, {3, 4});
  for (bool fortran : {false, true}) {
    std::string npy = SerializeNpy(a, {.big_endian = false, .fortran_order = fortran});
    for (size_t len = 0; len < npy.size(); ++len) {
      std::string prefix = npy.substr(0, len);  // own allocation, so ASan sees overreads
      EXPECT_THROW(ParseNpy(Bytes(prefix), "t.npy"), Error) << len;
    }
  }
}

TEST(NpyTest, EveryBitFlipLoadsOrThrowsError) {
  NpyArray a = MakeTestArray("i4", DType::kI4, {2, 3});
  std::string npy = SerializeNpy(a, {.big_endian = true, .fortran_order = true});
  size_t loaded = 0, rejected = 0;
  for (size_t i = 0; i < npy.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      std::string bad = npy;
      bad[i] = static_cast<char>(bad[i] ^ (1 << bit));
      try {
        NpyArray b = ParseNpy(Bytes(bad), "flip.npy");
        EXPECT_EQ(b.data.size(), b.num_elements() * DTypeSize(b.dtype));
        ++loaded;
      } catch (const Error&) {
        ++rejected;
      }
    }
  }
  EXPECT_GT(loaded, 0u);    // data bytes and padding
  EXPECT_GT(rejected, 0u);  // magic and header
}

TEST(NpyTest, FileReadWrite) {
  TempDir dir;
  NpyArray a = MakeTestArray("f4", DType::kF4, {2, 3, 4});
  std::string path = (dir.path() / "sub" / "a.npy").string();
  WriteNpyFile(path, a, {.big_endian = true, .fortran_order = true});
  NpyArray b = ReadNpyFile(path);
  EXPECT_EQ(b.shape, a.shape);
  EXPECT_EQ(b.data, a.data);
  ExpectError([&] { ReadNpyFile((dir.path() / "missing.npy").string()); },
              {"missing.npy", "not found"});
  WriteFileAtomic(dir.path() / "junk.npy", "hello, this is not numpy");
  ExpectError([&] { ReadNpyFile((dir.path() / "junk.npy").string()); }, {"junk.npy", "magic"});
}

TEST(NpyTest, FromDoublesConvertsAndChecksCount) {
  std::vector<double> v = {-1e10, -1.5, 0.4, 300.0, 1e30};
  EXPECT_THAT(NpyArray::FromDoubles(DType::kI4, {5}, v).ToDoubles(),
              ::testing::ElementsAre(-2147483648.0, -1.0, 0.0, 300.0, 2147483647.0));
  EXPECT_THAT(NpyArray::FromDoubles(DType::kU1, {5}, v).ToDoubles(),
              ::testing::ElementsAre(0.0, 0.0, 0.0, 255.0, 255.0));
  EXPECT_THAT(NpyArray::FromDoubles(DType::kB1, {5}, v).ToDoubles(),
              ::testing::ElementsAre(1.0, 1.0, 1.0, 1.0, 1.0));
  EXPECT_THROW(NpyArray::FromDoubles({2, 2}, v), Error);
}

TEST(NpyHalfTest, EveryHalfRoundTripsThroughDouble) {
  for (uint32_t bits = 0; bits < 65536; ++bits) {
    uint16_t h = static_cast<uint16_t>(bits);
    double d = HalfToDouble(h);
    ASSERT_EQ(DoubleToHalf(d), h) << std::hex << bits;
  }
  EXPECT_EQ(HalfToDouble(0x3C00), 1.0);
  EXPECT_EQ(HalfToDouble(0xC000), -2.0);
  EXPECT_EQ(HalfToDouble(0x7BFF), 65504.0);
  EXPECT_EQ(HalfToDouble(0x0001), std::ldexp(1.0, -24));
  EXPECT_EQ(HalfToDouble(0x0400), std::ldexp(1.0, -14));
  EXPECT_TRUE(std::isinf(HalfToDouble(0x7C00)));
  EXPECT_TRUE(std::isnan(HalfToDouble(0x7E00)));
  EXPECT_TRUE(std::signbit(HalfToDouble(0x8000)));
}

TEST(NpyHalfTest, RoundsToNearestEven) {
  // Exactly between two neighbouring finite halves: goes to the one with an even significand.
  // Just above or below the midpoint: goes to the nearer one.
  for (uint32_t bits = 0; bits < 0x7BFF; ++bits) {
    double lo = HalfToDouble(static_cast<uint16_t>(bits));
    double hi = HalfToDouble(static_cast<uint16_t>(bits + 1));
    double mid = (lo + hi) / 2;  // exact in double
    uint16_t even = (bits & 1) == 0 ? static_cast<uint16_t>(bits) : static_cast<uint16_t>(bits + 1);
    ASSERT_EQ(DoubleToHalf(mid), even) << std::hex << bits;
    ASSERT_EQ(DoubleToHalf(-mid), even | 0x8000) << std::hex << bits;
    ASSERT_EQ(DoubleToHalf(std::nextafter(mid, 0.0)), bits) << std::hex << bits;
    ASSERT_EQ(DoubleToHalf(std::nextafter(mid, 1e9)), bits + 1) << std::hex << bits;
  }
  EXPECT_EQ(DoubleToHalf(65519.99), 0x7BFF);
  EXPECT_EQ(DoubleToHalf(65520.0), 0x7C00);  // midpoint to "65536" rounds to inf
  EXPECT_EQ(DoubleToHalf(1e300), 0x7C00);
  EXPECT_EQ(DoubleToHalf(-1e300), 0xFC00);
  EXPECT_EQ(DoubleToHalf(std::ldexp(1.0, -25)), 0x0000);  // half of the smallest subnormal
  EXPECT_EQ(DoubleToHalf(std::nextafter(std::ldexp(1.0, -25), 1.0)), 0x0001);
  EXPECT_EQ(DoubleToHalf(1e-30), 0x0000);
  EXPECT_EQ(DoubleToHalf(-0.0), 0x8000);
  EXPECT_EQ(DoubleToHalf(std::numeric_limits<double>::quiet_NaN()) & 0x7E00, 0x7E00);
}

TEST(NpyHalfTest, MatchesNumpy) {
  TempDir dir;
  std::vector<double> values = {0.0,     -0.0,    1.0,     -1.0,       0.1,      1.0 / 3,
                                65504.0, 65519.0, 65520.0, 70000.0,    1e-5,     5.96e-8,
                                2.98e-8, 3e-8,    6.1e-5,  3.14159265, -2.71828, 1e300,
                                -1e300,  2049.0,  2051.0,  4097.0,     1025.5};
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> exponent(-27, 17);
  for (int i = 0; i < 2000; ++i) {
    double v = std::exp2(exponent(rng)) * ((rng() & 1) != 0 ? -1 : 1);
    values.push_back(v);
  }
  {
    std::ofstream out(dir.path() / "values.txt");
    char buf[64];
    for (double v : values) {
      std::snprintf(buf, sizeof buf, "%a\n", v);
      out << buf;
    }
  }
  std::string output;
  ASSERT_EQ(
      RunPython(dir.path(), R"(
import sys
import numpy as np
vals = [float.fromhex(l) for l in open(sys.argv[1]).read().split()]
with np.errstate(all='ignore'):
    bits = np.array(vals, dtype=np.float64).astype(np.float16).view(np.uint16)
print(' '.join(str(int(b)) for b in bits))
np.save(sys.argv[2], np.arange(65536, dtype=np.uint32).astype(np.uint16).view(np.float16)
        .astype(np.float64))
)",
                (dir.path() / "values.txt").string() + " " + (dir.path() / "halves.npy").string(),
                &output),
      0);
  std::istringstream in(output);
  for (double v : values) {
    unsigned expected = 0;
    ASSERT_TRUE(in >> expected);
    EXPECT_EQ(DoubleToHalf(v), expected) << std::hexfloat << v;
  }
  NpyArray halves = ReadNpyFile((dir.path() / "halves.npy").string());
  ASSERT_EQ(halves.num_elements(), 65536u);
  for (uint32_t bits = 0; bits < 65536; ++bits) {
    double ours = HalfToDouble(static_cast<uint16_t>(bits));
    double theirs = halves.AsDouble(bits);
    if (std::isnan(ours)) {
      EXPECT_TRUE(std::isnan(theirs)) << bits;
    } else {
      EXPECT_EQ(std::bit_cast<uint64_t>(ours), std::bit_cast<uint64_t>(theirs)) << bits;
    }
  }
}

TEST(NpyInteropTest, NumpyFilesLoad) {
  TempDir dir;
  ASSERT_EQ(RunPython(dir.path(), std::string(kPythonValues) + R"(
d = sys.argv[1]
for code, order, fortran, shape, name in cases():
    np.save(os.path.join(d, name), make(code, order, fortran, shape))
a = make('f8', '>', True, (2, 3, 4))
for v in (1, 2, 3):
    with open(os.path.join(d, 'v%d.npy' % v), 'wb') as f:
        np.lib.format.write_array(f, a, version=(v, 0))
)",
                      dir.path().string()),
            0);
  for (const auto& [code, dtype] : kCodes) {
    for (char order : {'<', '>'}) {
      for (bool fortran : {false, true}) {
        for (size_t si = 0; si < kShapes.size(); ++si) {
          std::string name = FileName(code, order, fortran, si);
          SCOPED_TRACE(name);
          const std::vector<size_t>& shape = kShapes[si];
          std::string bytes = ReadFile(dir.path() / name);
          NpyHeader h = ParseNpyHeader(Bytes(bytes), name);
          EXPECT_EQ(h.fortran_order, fortran && shape.size() > 1 && Product(shape) > 0);
          EXPECT_EQ(h.big_endian, order == '>' && DTypeSize(dtype) > 1);
          NpyArray a = ReadNpyFile((dir.path() / name).string());
          EXPECT_EQ(a.dtype, dtype);
          EXPECT_EQ(a.shape, shape);
          std::vector<double> values = a.ToDoubles();
          ASSERT_EQ(values.size(), Product(shape));
          for (size_t i = 0; i < values.size(); ++i) EXPECT_EQ(values[i], TestValue(code, i));
          // Our writer produces numpy's bytes exactly.
          EXPECT_EQ(SerializeNpy(a, {.big_endian = h.big_endian, .fortran_order = h.fortran_order}),
                    bytes);
        }
      }
    }
  }
  for (int v : {1, 2, 3}) {
    std::string path = (dir.path() / ("v" + std::to_string(v) + ".npy")).string();
    std::string bytes = ReadFile(path);
    EXPECT_EQ(bytes[6], v);
    NpyArray a = ReadNpyFile(path);
    EXPECT_EQ(a.shape, (std::vector<size_t>{2, 3, 4}));
    for (size_t i = 0; i < 24; ++i) EXPECT_EQ(a.AsDouble(i), TestValue("f8", i));
  }
}

TEST(NpyInteropTest, OurFilesLoadInNumpy) {
  TempDir dir;
  for (const auto& [code, dtype] : kCodes) {
    for (char order : {'<', '>'}) {
      for (bool fortran : {false, true}) {
        for (size_t si = 0; si < kShapes.size(); ++si) {
          WriteNpyFile((dir.path() / FileName(code, order, fortran, si)).string(),
                       MakeTestArray(code, dtype, kShapes[si]),
                       {.big_endian = order == '>', .fortran_order = fortran});
        }
      }
    }
  }
  std::string output;
  EXPECT_EQ(RunPython(dir.path(), std::string(kPythonValues) + R"(
d = sys.argv[1]
bad = []
count = 0
for code, order, fortran, shape, name in cases():
    a = np.load(os.path.join(d, name))
    want = make(code, order, fortran, shape)
    count += 1
    if a.dtype != want.dtype or a.shape != want.shape or not np.array_equal(a, want):
        bad.append('%s: got %s %s %r' % (name, a.dtype.str, a.shape, a))
    elif len(shape) > 1 and a.size > 0 and a.flags.f_contiguous != fortran:
        bad.append('%s: wrong memory order' % name)
if bad:
    print('\n'.join(bad))
    sys.exit(1)
print('checked', count)
)",
                      dir.path().string(), &output),
            0);
  EXPECT_THAT(output, HasSubstr("checked 168"));
}

}  // namespace
}  // namespace mlspaces
