// Writes the fuzz targets' seed corpora with the project's own writers:
//   make_corpus OUT_DIR [EXAMPLES_DIR]
// OUT_DIR/npy/*.npy        every dtype, C and Fortran order, big-endian, 0-d, empty, v2.0
// OUT_DIR/npz/*.npz        STORED and DEFLATEd archives of those arrays, a grasp file
// OUT_DIR/msgpack/*.bin    nlohmann::to_msgpack of sample JSON (and of the example metadata)
// OUT_DIR/uid_index/*.bin  packed stores from PackedStoreWriter, framed as uid_index_fuzz reads
//                          them (4-byte index length, index, metadata store)
// OUT_DIR/tries/*.json.gz  gzip JSON tries of MolmoSpaces-format sources (compacted keys,
//                          nesting, several gzip members), as tries_fuzz reads them
// scripts/fuzz.sh adds the test fixtures' own .npy/.npz files beside these.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <zlib.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "mlspaces/core/npy.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/library/annotation.h"
#include "mlspaces/library/package_layout.h"
#include "mlspaces/resources/packed_store_writer.h"

namespace fs = std::filesystem;
using namespace mlspaces;

namespace {

void Write(const fs::path& path, const std::string& bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << bytes;
  if (!out) throw Error("cannot write", path.string());
}

std::string Slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<std::pair<std::string, NpyArray>> SampleArrays() {
  std::vector<std::pair<std::string, NpyArray>> out;
  const std::vector<double> v = {0.5, -1.25, 3, 4, 5, 6.75};
  const DType dtypes[] = {DType::kF2, DType::kF4, DType::kF8, DType::kI4,
                          DType::kI8, DType::kU1, DType::kB1};
  for (DType d : dtypes) {
    std::vector<double> vals = v;
    if (d == DType::kU1 || d == DType::kB1) vals = {0, 1, 1, 0, 1, 1};
    out.emplace_back("a" + std::to_string(static_cast<int>(d)),
                     NpyArray::FromDoubles(d, {2, 3}, vals));
  }
  out.emplace_back("scalar", NpyArray::FromDoubles({}, std::vector<double>{3.25}));
  out.emplace_back("empty", NpyArray::FromDoubles({0, 3}, std::vector<double>{}));
  std::vector<double> grasps(3 * 16, 0.0);
  for (size_t k = 0; k < 3; ++k) {
    for (int i = 0; i < 4; ++i) grasps[k * 16 + i * 5] = 1.0;
    grasps[k * 16 + 3] = static_cast<double>(k);
  }
  out.emplace_back("transforms", NpyArray::FromDoubles({3, 4, 4}, grasps));
  return out;
}

void WriteNpySeeds(const fs::path& dir) {
  for (const auto& [name, array] : SampleArrays()) {
    Write(dir / (name + ".npy"), SerializeNpy(array));
    NpyWriteOptions be;
    be.big_endian = true;
    Write(dir / (name + "_be.npy"), SerializeNpy(array, be));
    NpyWriteOptions f;
    f.fortran_order = true;
    Write(dir / (name + "_f.npy"), SerializeNpy(array, f));
  }
  // A shape long enough that the header needs format 2.0.
  std::vector<size_t> shape(40, 1);
  Write(dir / "v2.npy", SerializeNpy(NpyArray::FromDoubles(shape, std::vector<double>{1.0})));
}

void WriteNpzSeeds(const fs::path& dir) {
  fs::create_directories(dir);
  const auto arrays = SampleArrays();
  for (bool compress : {false, true}) {
    NpzWriteOptions options;
    options.compress = compress;
    WriteNpz(dir / (compress ? "all_deflate.npz" : "all_stored.npz"), arrays, options);
    WriteNpz(dir / (compress ? "grasps_deflate.npz" : "grasps_stored.npz"), {arrays.back()},
             options);
  }
}

Json SampleJson() {
  return ParseJson(R"({"z_first": 1, "a_second": -2, "nested": {"b": [1.5, true, null,
      "str\u00e9"], "a": {"deep": 18446744073709551615}}, "float": 0.1, "neg": -9007199254740993,
      "i16": -30000, "u32": 4000000000, "empty_obj": {}, "empty_arr": [],
      "long": "0123456789012345678901234567890123456789"})",
                   "sample");
}

std::string Msgpack(const Json& j) {
  const std::vector<uint8_t> bytes = Json::to_msgpack(j);
  return {bytes.begin(), bytes.end()};
}

void WriteMsgpackSeeds(const fs::path& dir, const fs::path& examples) {
  Write(dir / "sample.bin", Msgpack(SampleJson()));
  Write(dir / "array.bin", Msgpack(Json::array({1, -1, 2.5, "x", nullptr, true})));
  const fs::path red = examples / "custom_assets/asset_library/red_block/red_block_computed.json";
  if (fs::exists(red)) Write(dir / "red_block.bin", Msgpack(ParseJsonFile(red)));
}

/// A small package store in `work`, framed for uid_index_fuzz.
std::string FramedStore(const fs::path& work, int num_assets, bool with_grasps) {
  fs::remove_all(work);
  const std::vector<std::string> archives = {"objects_000.tar.zst", "nested/objects_001.tar.zst"};
  std::vector<std::unique_ptr<GraspShardWriter>> shards;
  for (const std::string& a : archives) {
    shards.push_back(std::make_unique<GraspShardWriter>(work / GraspShardMember(a)));
  }
  PackedStoreWriter writer(work, "seed", archives);
  std::vector<Annotation> annotations(num_assets);
  for (int i = 0; i < num_assets; ++i) {
    PackedAssetInput in;
    in.uid = "uid_" + std::to_string(i);
    in.mjcf = "assets/" + in.uid + "/" + in.uid + ".xml";
    in.archive = static_cast<uint32_t>(i % 2);
    if (i % 3 != 2) {
      Annotation& a = annotations[i];
      a.uid = in.uid;
      a.library = "seed";
      a.json = SampleJson();
      a.json["index"] = i;
      a.arrays.emplace_back("/clip",
                            NpyArray::FromDoubles(DType::kF4, {2}, std::vector<double>{0.5, -1.0}));
      in.annotation = &a;
    }
    if (with_grasps) {
      for (const char* joint : {"", "hinge"}) {
        PackedAssetInput::Grasps g;
        g.robot = i % 2 == 0 ? "droid" : "franka";
        g.joint = joint;
        g.archive = in.archive;
        std::vector<Mat4> poses(2);
        g.offset = shards[g.archive]->Append(poses);
        g.count = 2;
        in.grasps.push_back(g);
      }
    }
    writer.Add(in);
  }
  for (auto& s : shards) s->Finish(false);
  writer.Finish();
  const std::string index = Slurp(work / std::string(kUidIndexFile));
  const std::string meta = Slurp(work / std::string(kMetadataStoreFile));
  const auto n = static_cast<uint32_t>(index.size());
  std::string out(reinterpret_cast<const char*>(&n), 4);
  return out + index + meta;
}

void WriteStoreSeeds(const fs::path& dir, const fs::path& work) {
  Write(dir / "empty.bin", FramedStore(work / "s0", 0, false));
  Write(dir / "one.bin", FramedStore(work / "s1", 1, true));
  Write(dir / "five.bin", FramedStore(work / "s5", 5, true));
  Write(dir / "nograsps.bin", FramedStore(work / "s3", 3, false));
  fs::remove_all(work);
}

/// gzip (one member) of `text`.
std::string Gzip(const std::string& text) {
  z_stream zs{};
  if (deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    throw Error("zlib: deflateInit2 failed");
  }
  std::string out(deflateBound(&zs, text.size()) + 64, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
  zs.avail_in = static_cast<uInt>(text.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&zs, Z_FINISH);
  deflateEnd(&zs);
  if (rc != Z_STREAM_END) throw Error("zlib: deflate failed");
  out.resize(zs.total_out);
  return out;
}

void WriteTriesSeeds(const fs::path& dir) {
  Write(dir / "empty.json.gz", Gzip("{}"));
  Write(dir / "objects.json.gz",
        Gzip(R"({"objaverse_0a1b.tar.zst": {"0a1b": {"0a1b.xml": {}, "assets": )"
             R"({"0a1b_mesh_0.obj": {}, "0a1b_mesh_1.obj": {}}}}, )"
             R"("objaverse_ffee.tar.zst": {"ffee/ffee.xml": {}, "ffee/assets/m.obj": {}}})"));
  Write(dir / "scenes.json.gz",
        Gzip(R"({"ithor_FloorPlan1.tar.zst": {"FloorPlan1_physics.xml": {}, )"
             R"("FloorPlan1_physics_metadata.json": {}}, "ithor_base.tar.zst": )"
             R"({"common": {"textures": {"wood.png": {}}}}, "ithor_FloorPlan2_3.tar.zst": {}})"));
  Write(dir / "two_members.json.gz", Gzip(R"({"a.tar.zst": )") + Gzip(R"({"x/y": {}}})"));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: make_corpus OUT_DIR [EXAMPLES_DIR]\n");
    return 2;
  }
  const fs::path out = argv[1];
  const fs::path examples = argc > 2 ? fs::path(argv[2]) : fs::path(MLSPACES_EXAMPLES_DIR);
  try {
    WriteNpySeeds(out / "npy");
    WriteNpzSeeds(out / "npz");
    WriteMsgpackSeeds(out / "msgpack", examples);
    WriteStoreSeeds(out / "uid_index", out / "work");
    WriteTriesSeeds(out / "tries");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_corpus: %s\n", e.what());
    return 1;
  }
  return 0;
}
