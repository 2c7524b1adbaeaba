#include "mlspaces/core/npz.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
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
using ::mlspaces::testing::WriteText;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

std::vector<double> Iota(size_t n, double scale = 1.0, double offset = 0.0) {
  std::vector<double> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = static_cast<double>(i) * scale + offset;
  return v;
}

// The rows `rows` of a C-order array with `row_elems` elements per row.
std::vector<double> PickRows(const std::vector<double>& all, size_t row_elems,
                             const std::vector<size_t>& rows) {
  std::vector<double> out;
  for (size_t r : rows) {
    out.insert(out.end(), all.begin() + static_cast<ptrdiff_t>(r * row_elems),
               all.begin() + static_cast<ptrdiff_t>((r + 1) * row_elems));
  }
  return out;
}

std::vector<std::pair<std::string, NpyArray>> SampleArrays() {
  return {
      {"transforms", NpyArray::FromDoubles({5, 4, 4}, Iota(80, 0.5, -3))},
      {"half", NpyArray::FromDoubles(DType::kF2, {6, 2}, Iota(12, 0.25))},
      {"ids", NpyArray::FromDoubles(DType::kI8, {3}, Iota(3, 4e9, -1))},
      {"scalar", NpyArray::FromDoubles(DType::kI4, {}, std::vector<double>{-42})},
      {"flags", NpyArray::FromDoubles(DType::kB1, {2, 2}, std::vector<double>{1, 0, 0, 1})},
      {"nested/key", NpyArray::FromDoubles(DType::kU1, {2, 3}, Iota(6, 40))},
  };
}

void ExpectSameArrays(const NpyArray& a, const NpyArray& b) {
  EXPECT_EQ(a.dtype, b.dtype);
  EXPECT_EQ(a.shape, b.shape);
  EXPECT_EQ(a.data, b.data);
}

TEST(NpzTest, RoundTripStoredAndDeflated) {
  TempDir dir;
  auto arrays = SampleArrays();
  for (bool compress : {false, true}) {
    for (bool big : {false, true}) {
      for (bool fortran : {false, true}) {
        SCOPED_TRACE(std::to_string(compress) + std::to_string(big) + std::to_string(fortran));
        fs::path path = dir.path() / "a.npz";
        WriteNpz(path, arrays,
                 {.compress = compress, .npy = {.big_endian = big, .fortran_order = fortran}});
        NpzReader reader(path);
        EXPECT_EQ(reader.path(), path);
        EXPECT_THAT(reader.keys(),
                    ElementsAre("transforms", "half", "ids", "scalar", "flags", "nested/key"));
        EXPECT_TRUE(reader.Contains("transforms"));
        EXPECT_TRUE(reader.Contains("transforms.npy"));
        EXPECT_FALSE(reader.Contains("transform"));
        for (const auto& [key, array] : arrays) ExpectSameArrays(reader.Read(key), array);
        NpyHeader h = reader.ReadHeader("transforms");
        EXPECT_EQ(h.shape, (std::vector<size_t>{5, 4, 4}));
        EXPECT_EQ(h.dtype, DType::kF8);
        EXPECT_EQ(h.big_endian, big);
        EXPECT_EQ(h.fortran_order, fortran);

        std::vector<size_t> rows = {4, 0, 4, 2};
        NpyArray picked = reader.ReadRows("transforms", rows);
        EXPECT_EQ(picked.shape, (std::vector<size_t>{4, 4, 4}));
        EXPECT_EQ(picked.ToDoubles(), PickRows(Iota(80, 0.5, -3), 16, rows));
        NpyArray half_rows = reader.ReadRows("half.npy", {5, 1});
        EXPECT_EQ(half_rows.dtype, DType::kF2);
        EXPECT_THAT(half_rows.ToDoubles(), ElementsAre(2.5, 2.75, 0.5, 0.75));
        EXPECT_THAT(reader.ReadRows("ids", {2}).ToDoubles(), ElementsAre(8e9 - 1));
        EXPECT_THAT(reader.ReadRows("flags", {1, 1}).ToDoubles(), ElementsAre(0, 1, 0, 1));
        EXPECT_TRUE(reader.ReadRows("ids", {}).data.empty());

        ExpectError([&] { reader.ReadRows("transforms", {5}); },
                    {"a.npz: transforms.npy: ", "row 5 out of range"});
        ExpectError([&] { reader.ReadRows("scalar", {0}); }, {"scalar.npy", "0-d"});
        ExpectError([&] { reader.Read("nope"); }, {"a.npz", "no array 'nope'"});
        ExpectError([&] { reader.ReadHeader("nope"); }, {"no array 'nope'"});

        auto all = ReadNpz(path);
        ASSERT_EQ(all.size(), arrays.size());
        for (size_t i = 0; i < all.size(); ++i) {
          EXPECT_EQ(all[i].first, arrays[i].first);
          ExpectSameArrays(all[i].second, arrays[i].second);
        }
      }
    }
  }
}

TEST(NpzTest, ReaderIsMovable) {
  TempDir dir;
  fs::path path = dir.path() / "m.npz";
  WriteNpz(path, SampleArrays());
  NpzReader a(path);
  NpzReader b(std::move(a));
  EXPECT_EQ(b.ReadHeader("ids").shape, std::vector<size_t>{3});
  NpzReader c(path);
  c = std::move(b);
  EXPECT_EQ(c.Read("scalar").AsDouble(0), -42);
}

TEST(NpzTest, WriterRejectsDuplicateNames) {
  TempDir dir;
  auto arrays = SampleArrays();
  arrays.push_back(arrays[1]);
  ExpectError([&] { WriteNpz(dir.path() / "dup.npz", arrays); }, {"dup.npz: half: duplicate"});
  EXPECT_FALSE(fs::exists(dir.path() / "dup.npz"));
}

TEST(NpzTest, EmptyArchive) {
  TempDir dir;
  fs::path path = dir.path() / "empty.npz";
  WriteNpz(path, {});
  EXPECT_EQ(fs::file_size(path), 22u);
  NpzReader reader(path);
  EXPECT_TRUE(reader.keys().empty());
  EXPECT_TRUE(ReadNpz(path).empty());
}

// A minimal independent zip writer, to build archives our writer never makes.
struct ZipEntry {
  std::string name;
  std::string data;  // uncompressed
  bool deflate = false;
  bool zip64_local = false;      // sizes in a ZIP64 extra field of the local header
  bool zip64_central = false;    // sizes and offset in a ZIP64 extra field of the central entry
  bool data_descriptor = false;  // flag bit 3, zero sizes in the local header
  uint16_t method_override = 0xFFFF;
  uint16_t flags = 0;
};

void Put(std::string& s, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}

std::string Deflate(const std::string& data) {
  z_stream z{};
  deflateInit2(&z, 6, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY);
  std::string out(deflateBound(&z, data.size()), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = static_cast<uInt>(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

std::string BuildZip(const std::vector<ZipEntry>& entries, bool zip64_eocd) {
  std::string out, central;
  for (const ZipEntry& e : entries) {
    std::string payload = e.deflate ? Deflate(e.data) : e.data;
    uint32_t crc = static_cast<uint32_t>(
        crc32(0, reinterpret_cast<const Bytef*>(e.data.data()), static_cast<uInt>(e.data.size())));
    uint16_t method = e.method_override != 0xFFFF ? e.method_override : (e.deflate ? 8 : 0);
    uint16_t flags = static_cast<uint16_t>(e.flags | (e.data_descriptor ? 8 : 0));
    uint64_t offset = out.size();
    Put(out, 0x04034b50, 4);
    Put(out, 45, 2);
    Put(out, flags, 2);
    Put(out, method, 2);
    Put(out, 0, 4);
    Put(out, e.data_descriptor ? 0 : crc, 4);
    uint32_t local_size = e.zip64_local ? 0xFFFFFFFF : 0;
    Put(out, e.data_descriptor ? 0 : (e.zip64_local ? local_size : payload.size()), 4);
    Put(out, e.data_descriptor ? 0 : (e.zip64_local ? local_size : e.data.size()), 4);
    Put(out, e.name.size(), 2);
    Put(out, e.zip64_local ? 20 : 0, 2);
    out += e.name;
    if (e.zip64_local) {
      Put(out, 1, 2);
      Put(out, 16, 2);
      Put(out, e.data.size(), 8);
      Put(out, payload.size(), 8);
    }
    out += payload;
    if (e.data_descriptor) {
      Put(out, 0x08074b50, 4);
      Put(out, crc, 4);
      Put(out, payload.size(), 4);
      Put(out, e.data.size(), 4);
    }
    Put(central, 0x02014b50, 4);
    Put(central, 45, 2);
    Put(central, 45, 2);
    Put(central, flags, 2);
    Put(central, method, 2);
    Put(central, 0, 4);
    Put(central, crc, 4);
    Put(central, e.zip64_central ? 0xFFFFFFFF : payload.size(), 4);
    Put(central, e.zip64_central ? 0xFFFFFFFF : e.data.size(), 4);
    Put(central, e.name.size(), 2);
    Put(central, e.zip64_central ? 4 + 24 + 4 : 0, 2);
    Put(central, 0, 2);
    Put(central, e.zip64_central ? 0xFFFF : 0, 2);
    Put(central, 0, 2);
    Put(central, 0, 4);
    Put(central, e.zip64_central ? 0xFFFFFFFF : offset, 4);
    central += e.name;
    if (e.zip64_central) {
      Put(central, 1, 2);
      Put(central, 28, 2);
      Put(central, e.data.size(), 8);
      Put(central, payload.size(), 8);
      Put(central, offset, 8);
      Put(central, 0, 4);
    }
  }
  uint64_t cd_offset = out.size();
  out += central;
  if (zip64_eocd) {
    uint64_t z64 = out.size();
    Put(out, 0x06064b50, 4);
    Put(out, 44, 8);
    Put(out, 45, 2);
    Put(out, 45, 2);
    Put(out, 0, 8);
    Put(out, entries.size(), 8);
    Put(out, entries.size(), 8);
    Put(out, central.size(), 8);
    Put(out, cd_offset, 8);
    Put(out, 0x07064b50, 4);
    Put(out, 0, 4);
    Put(out, z64, 8);
    Put(out, 1, 4);
  }
  Put(out, 0x06054b50, 4);
  Put(out, 0, 4);
  Put(out, zip64_eocd ? 0xFFFF : entries.size(), 2);
  Put(out, zip64_eocd ? 0xFFFF : entries.size(), 2);
  Put(out, zip64_eocd ? 0xFFFFFFFF : central.size(), 4);
  Put(out, zip64_eocd ? 0xFFFFFFFF : cd_offset, 4);
  Put(out, 0, 2);
  return out;
}

TEST(NpzTest, ReadsZip64AndDataDescriptors) {
  TempDir dir;
  NpyArray a = NpyArray::FromDoubles({3, 2}, Iota(6, 1.5));
  NpyArray b = NpyArray::FromDoubles(DType::kF2, {4}, Iota(4, -0.5));
  std::string npy_a = SerializeNpy(a), npy_b = SerializeNpy(b, {.big_endian = true});
  for (bool eocd64 : {false, true}) {
    for (bool deflate : {false, true}) {
      SCOPED_TRACE(std::to_string(eocd64) + std::to_string(deflate));
      std::vector<ZipEntry> entries = {
          {.name = "a.npy",
           .data = npy_a,
           .deflate = deflate,
           .zip64_local = true,
           .zip64_central = true},
          {.name = "b.npy", .data = npy_b, .deflate = deflate, .data_descriptor = true},
          {.name = "c.npy", .data = npy_a, .deflate = deflate, .zip64_local = true}};
      fs::path path = dir.path() / "z.npz";
      WriteFileAtomic(path, BuildZip(entries, eocd64));
      NpzReader reader(path);
      EXPECT_THAT(reader.keys(), ElementsAre("a", "b", "c"));
      ExpectSameArrays(reader.Read("a"), a);
      ExpectSameArrays(reader.Read("b"), b);
      ExpectSameArrays(reader.Read("c"), a);
      EXPECT_THAT(reader.ReadRows("a", {2}).ToDoubles(), ElementsAre(6.0, 7.5));
      EXPECT_THAT(reader.ReadRows("b", {3, 0}).ToDoubles(), ElementsAre(-1.5, 0.0));
    }
  }
}

TEST(NpzTest, RejectsCorruptArchives) {
  TempDir dir;
  NpyArray a = NpyArray::FromDoubles({2, 2}, Iota(4));
  std::string npy = SerializeNpy(a);
  auto write = [&](const std::string& bytes) {
    fs::path path = dir.path() / "bad.npz";
    WriteFileAtomic(path, bytes);
    return path;
  };
  ExpectError([&] { NpzReader r(dir.path() / "missing.npz"); }, {"missing.npz", "not found"});
  ExpectError([&] { NpzReader r(dir.path()); }, {"directory"});
  ExpectError([&] { NpzReader r(write("")); }, {"bad.npz: ", "not a zip"});
  ExpectError([&] { NpzReader r(write(std::string(100, 'x'))); }, {"bad.npz: ", "not a zip"});
  ExpectError([&] { NpzReader r(write(npy)); }, {"not a zip"});

  // Unsupported method and encryption.
  {
    NpzReader r(write(BuildZip({{.name = "a.npy", .data = npy, .method_override = 12}}, false)));
    ExpectError([&] { r.Read("a"); }, {"bad.npz: a.npy: ", "compression method 12"});
  }
  {
    NpzReader r(write(BuildZip({{.name = "a.npy", .data = npy, .flags = 1}}, false)));
    ExpectError([&] { r.ReadHeader("a"); }, {"a.npy", "encrypted"});
  }
  // CRC mismatch: flip a data byte but keep the central directory's CRC.
  for (bool deflate : {false, true}) {
    std::string zip = BuildZip({{.name = "a.npy", .data = npy, .deflate = deflate}}, false);
    std::string other = npy;
    other.back() ^= 1;
    std::string zip2 = BuildZip({{.name = "a.npy", .data = other, .deflate = deflate}}, false);
    // Splice zip2's member data with zip's CRC (CRC lives at offset 14 local, cd+16 central).
    size_t cd = zip2.size() - 22 - (46 + 5);
    std::memcpy(zip2.data() + cd + 16, zip.data() + cd + 16, 4);
    NpzReader r(write(zip2));
    ExpectError([&] { r.Read("a"); }, {"a.npy", "CRC-32 mismatch"});
    EXPECT_EQ(r.ReadHeader("a").shape, (std::vector<size_t>{2, 2}));
  }
  // A bad DEFLATE stream.
  {
    std::string zip = BuildZip({{.name = "a.npy", .data = npy, .deflate = true}}, false);
    zip[30 + 5] = static_cast<char>(0xFF);  // first byte of the stream: invalid block type
    NpzReader r(write(zip));
    ExpectError([&] { r.Read("a"); }, {"a.npy", "DEFLATE"});
  }
  // Member sizes past the end of the file.
  {
    std::string zip = BuildZip({{.name = "a.npy", .data = npy}}, false);
    size_t cd = zip.size() - 22 - (46 + 5);
    uint32_t huge = 0x7FFFFFFF;
    std::memcpy(zip.data() + cd + 20, &huge, 4);
    std::memcpy(zip.data() + cd + 24, &huge, 4);
    NpzReader r(write(zip));
    ExpectError([&] { r.Read("a"); }, {"a.npy", "past the end"});
  }
  // A central directory offset past the end.
  {
    std::string zip = BuildZip({{.name = "a.npy", .data = npy}}, false);
    zip[zip.size() - 3] = 0x7F;
    ExpectError([&] { NpzReader r(write(zip)); }, {"bad.npz", "central directory"});
  }
  // A member that is not a .npy.
  {
    NpzReader r(write(BuildZip({{.name = "readme.txt", .data = "hello"}}, false)));
    EXPECT_THAT(r.keys(), ElementsAre("readme.txt"));
    ExpectError([&] { r.Read("readme.txt"); }, {"readme.txt", "not a .npy"});
  }
  // Header shape disagreeing with the member size.
  {
    std::string longer = npy + "12345678";
    NpzReader r(write(BuildZip({{.name = "a.npy", .data = longer}}, false)));
    ExpectError([&] { r.ReadHeader("a"); }, {"a.npy", "need 32"});
    ExpectError([&] { r.ReadRows("a", {0}); }, {"a.npy", "need 32"});
  }
}

// Opens `path` and reads everything through every API; throws Error on bad input.
void ReadEverything(const fs::path& path) {
  NpzReader reader(path);
  for (const std::string& key : reader.keys()) {
    NpyHeader h = reader.ReadHeader(key);
    NpyArray a = reader.Read(key);
    EXPECT_EQ(a.data.size(), a.num_elements() * DTypeSize(a.dtype));
    if (!h.shape.empty() && h.shape[0] > 0) {
      NpyArray rows = reader.ReadRows(key, {h.shape[0] - 1, 0});
      EXPECT_EQ(rows.data.size(), rows.num_elements() * DTypeSize(rows.dtype));
    }
  }
}

std::vector<std::pair<std::string, NpyArray>> SmallArrays() {
  return {{"t", NpyArray::FromDoubles({2, 2, 2}, Iota(8, 0.5))},
          {"h", NpyArray::FromDoubles(DType::kF2, {3}, Iota(3, 2))}};
}

TEST(NpzTest, EveryTruncationThrowsError) {
  TempDir dir;
  for (bool compress : {false, true}) {
    fs::path full = dir.path() / "full.npz";
    WriteNpz(full, SmallArrays(), {.compress = compress, .npy = {}});
    std::string bytes = ReadFile(full);
    ASSERT_NO_THROW(ReadEverything(full));
    fs::path path = dir.path() / "trunc.npz";
    for (size_t len = 0; len < bytes.size(); ++len) {
      WriteText(path, std::string_view(bytes).substr(0, len));
      EXPECT_THROW(ReadEverything(path), Error) << "compress " << compress << " length " << len;
    }
  }
}

TEST(NpzTest, EveryByteFlipLoadsOrThrowsError) {
  TempDir dir;
  for (bool compress : {false, true}) {
    fs::path full = dir.path() / "full.npz";
    WriteNpz(full, SmallArrays(), {.compress = compress, .npy = {.big_endian = true}});
    std::string bytes = ReadFile(full);
    fs::path path = dir.path() / "flip.npz";
    size_t loaded = 0, rejected = 0;
    for (size_t i = 0; i < bytes.size(); ++i) {
      for (uint8_t mask : {0xFF, 0x01, 0x80}) {
        std::string bad = bytes;
        bad[i] = static_cast<char>(bad[i] ^ mask);
        WriteText(path, bad);
        try {
          ReadEverything(path);
          ++loaded;
        } catch (const Error&) {
          ++rejected;
        }
      }
    }
    EXPECT_GT(loaded, 0u);
    EXPECT_GT(rejected, 0u);
  }
}

TEST(NpzInteropTest, NumpyArchivesLoad) {
  TempDir dir;
  ASSERT_EQ(RunPython(dir.path(), R"(
import sys, os
import numpy as np
d = sys.argv[1]
i = np.arange(48)
arrays = {
    'transforms': (i * 0.5 - 3).reshape(3, 4, 4),
    'half': (i * 0.25).astype('<f2').reshape(12, 4),
    'half_be': (i * 0.25).astype('>f2').reshape(4, 12),
    'f4_fortran': np.asfortranarray((i * 1.5).astype('>f4').reshape(2, 4, 6)),
    'i4': (i * 1000 - 7).astype('<i4').reshape(6, 8),
    'i8_be': (i * 3000000000 - 1).astype('>i8'),
    'u1': (i % 256).astype('u1').reshape(2, 2, 2, 6),
    'b1': (i % 3 == 0).reshape(8, 6),
    'scalar': np.array(2.5),
    'empty': np.zeros((0, 4)),
}
np.savez(os.path.join(d, 'stored.npz'), **arrays)
np.savez_compressed(os.path.join(d, 'deflated.npz'), **arrays)
np.savez(os.path.join(d, 'positional.npz'), np.arange(3.0), np.ones((2, 2), dtype='<f2'))
)",
                      dir.path().string()),
            0);
  std::vector<double> i48 = Iota(48);
  auto map = [&](auto fn) {
    std::vector<double> out;
    out.reserve(i48.size());
    for (double x : i48) out.push_back(fn(x));
    return out;
  };
  for (const char* name : {"stored.npz", "deflated.npz"}) {
    SCOPED_TRACE(name);
    NpzReader r(dir.path() / name);
    EXPECT_THAT(r.keys(), ElementsAre("transforms", "half", "half_be", "f4_fortran", "i4", "i8_be",
                                      "u1", "b1", "scalar", "empty"));
    NpyArray t = r.Read("transforms");
    EXPECT_EQ(t.dtype, DType::kF8);
    EXPECT_EQ(t.shape, (std::vector<size_t>{3, 4, 4}));
    EXPECT_EQ(t.ToDoubles(), map([](double x) { return x * 0.5 - 3; }));
    EXPECT_EQ(r.ReadRows("transforms", {2, 0}).ToDoubles(),
              PickRows(map([](double x) { return x * 0.5 - 3; }), 16, {2, 0}));
    NpyArray h = r.Read("half");
    EXPECT_EQ(h.dtype, DType::kF2);
    EXPECT_EQ(h.ToDoubles(), map([](double x) { return x * 0.25; }));
    EXPECT_EQ(r.ReadRows("half", {11, 3}).ToDoubles(),
              PickRows(map([](double x) { return x * 0.25; }), 4, {11, 3}));
    EXPECT_EQ(r.Read("half_be").ToDoubles(), map([](double x) { return x * 0.25; }));
    EXPECT_TRUE(r.ReadHeader("half_be").big_endian);
    NpyArray f4 = r.Read("f4_fortran");
    EXPECT_EQ(f4.dtype, DType::kF4);
    EXPECT_EQ(f4.shape, (std::vector<size_t>{2, 4, 6}));
    EXPECT_EQ(f4.ToDoubles(), map([](double x) { return x * 1.5; }));
    EXPECT_TRUE(r.ReadHeader("f4_fortran").fortran_order);
    EXPECT_EQ(r.ReadRows("f4_fortran", {1}).ToDoubles(),
              PickRows(map([](double x) { return x * 1.5; }), 24, {1}));
    EXPECT_EQ(r.Read("i4").ToDoubles(), map([](double x) { return x * 1000 - 7; }));
    EXPECT_EQ(r.Read("i8_be").ToDoubles(), map([](double x) { return x * 3000000000.0 - 1; }));
    EXPECT_EQ(r.Read("u1").ToDoubles(), i48);
    EXPECT_EQ(r.Read("b1").ToDoubles(),
              map([](double x) { return static_cast<int>(x) % 3 == 0 ? 1.0 : 0.0; }));
    NpyArray s = r.Read("scalar");
    EXPECT_TRUE(s.shape.empty());
    EXPECT_EQ(s.AsDouble(0), 2.5);
    EXPECT_EQ(r.Read("empty").shape, (std::vector<size_t>{0, 4}));
  }
  NpzReader p(dir.path() / "positional.npz");
  EXPECT_THAT(p.keys(), ElementsAre("arr_0", "arr_1"));
  EXPECT_THAT(p.Read("arr_1").ToDoubles(), ElementsAre(1, 1, 1, 1));
}

TEST(NpzInteropTest, OurArchivesLoadInNumpy) {
  TempDir dir;
  std::vector<double> b1(48);
  for (size_t i = 0; i < 48; ++i) b1[i] = i % 3 == 0;
  std::vector<std::pair<std::string, NpyArray>> arrays = {
      {"transforms", NpyArray::FromDoubles({3, 4, 4}, Iota(48, 0.5, -3))},
      {"half", NpyArray::FromDoubles(DType::kF2, {12, 4}, Iota(48, 0.25))},
      {"f4", NpyArray::FromDoubles(DType::kF4, {2, 4, 6}, Iota(48, 1.5))},
      {"i4", NpyArray::FromDoubles(DType::kI4, {6, 8}, Iota(48, 1000, -7))},
      {"i8", NpyArray::FromDoubles(DType::kI8, {48}, Iota(48, 3000000000.0, -1))},
      {"u1", NpyArray::FromDoubles(DType::kU1, {2, 2, 2, 6}, Iota(48))},
      {"b1", NpyArray::FromDoubles(DType::kB1, {8, 6}, b1)},
      {"scalar", NpyArray::FromDoubles({}, std::vector<double>{2.5})},
      {"empty", NpyArray::FromDoubles({0, 4}, std::vector<double>{})},
  };
  std::string files;
  for (bool compress : {false, true}) {
    for (bool big : {false, true}) {
      for (bool fortran : {false, true}) {
        std::string name = std::string("ours_") + (compress ? "z" : "s") + (big ? "B" : "L") +
                           (fortran ? "F" : "C") + ".npz";
        WriteNpz(dir.path() / name, arrays,
                 {.compress = compress, .npy = {.big_endian = big, .fortran_order = fortran}});
        files += " " + (dir.path() / name).string();
      }
    }
  }
  std::string output;
  EXPECT_EQ(RunPython(dir.path(), R"(
import sys, zipfile
import numpy as np
i = np.arange(48)
want = {
    'transforms': ('f8', (i * 0.5 - 3).reshape(3, 4, 4)),
    'half': ('f2', (i * 0.25).reshape(12, 4)),
    'f4': ('f4', (i * 1.5).reshape(2, 4, 6)),
    'i4': ('i4', (i * 1000 - 7).reshape(6, 8)),
    'i8': ('i8', i * 3000000000 - 1),
    'u1': ('u1', i.reshape(2, 2, 2, 6)),
    'b1': ('b1', (i % 3 == 0).reshape(8, 6)),
    'scalar': ('f8', np.array(2.5)),
    'empty': ('f8', np.zeros((0, 4))),
}
bad = []
for path in sys.argv[1:]:
    base = path.rsplit('/', 1)[1]
    big = 'B' in base
    with zipfile.ZipFile(path) as z:
        if z.testzip() is not None:
            bad.append(path + ': zip CRC error')
        methods = {info.compress_type for info in z.infolist()}
        if methods != {zipfile.ZIP_DEFLATED if base.startswith('ours_z') else zipfile.ZIP_STORED}:
            bad.append(path + ': wrong compression %r' % methods)
    with np.load(path) as f:
        if list(f.keys()) != list(want.keys()):
            bad.append(path + ': keys %r' % list(f.keys()))
        for k, (code, v) in want.items():
            a = f[k]
            dt = np.dtype(('>' if big else '<') + code)
            if a.dtype != dt or a.shape != v.shape or not np.array_equal(a, v.astype(dt)):
                bad.append('%s %s: got %s %s %r' % (path, k, a.dtype.str, a.shape, a))
if bad:
    print('\n'.join(bad))
    sys.exit(1)
print('ok', len(sys.argv) - 1)
)",
                      files, &output),
            0);
  EXPECT_THAT(output, HasSubstr("ok 8"));
}

}  // namespace
}  // namespace mlspaces
