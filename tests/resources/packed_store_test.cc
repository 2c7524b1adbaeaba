// Packed stores: writer -> reader round trips, hashing, grasp shards, annotations, determinism,
// and damaged files (every truncation, byte flips) giving an Error, never a crash.
#include "mlspaces/library/packed_store.h"
#include "mlspaces/resources/packed_store_writer.h"

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <thread>

#include "mlspaces/core/npz.h"
#include "mlspaces/library/annotation.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::Slurp;
using testing::TempDir;
using testing::WriteText;

const std::vector<std::string> kArchives = {"objects_000.tar.zst", "objects_001.tar.zst"};

/// A pose whose 16 values all depend on (seed, i): bit-exact comparisons catch any mix-up.
Mat4 Pose(uint64_t seed, size_t i) {
  Mat4 m;
  for (size_t k = 0; k < 16; ++k) m.m[k] = static_cast<double>(seed) * 1000.0 + i + k / 17.0;
  return m;
}

std::vector<Mat4> Poses(uint64_t seed, size_t n) {
  std::vector<Mat4> out;
  for (size_t i = 0; i < n; ++i) out.push_back(Pose(seed, i));
  return out;
}

bool SameBits(const Mat4& a, const Mat4& b) {
  return std::memcmp(&a, &b, sizeof a) == 0;  // NOLINT(bugprone-suspicious-memory-comparison)
}

/// What a test asset should look like after reading back.
struct Expected {
  std::string uid, mjcf;
  uint32_t archive = 0;
  std::optional<Annotation> annotation;
  struct G {
    std::string robot, joint;
    uint32_t archive;
    std::vector<Mat4> poses;
    DType dtype = DType::kF8;
  };
  std::vector<G> grasps;  // any order; the store sorts by (robot, joint)
};

/// Writes the grasp shards and the store for `assets` (in the given order) into `dir`.
void WriteStore(const fs::path& dir, const std::vector<Expected>& assets) {
  std::vector<std::unique_ptr<GraspShardWriter>> shards;
  for (const std::string& a : kArchives) {
    const std::string stem = a.substr(0, a.size() - std::string(".tar.zst").size());
    shards.push_back(
        std::make_unique<GraspShardWriter>(dir / std::string(kGraspShardDir) / (stem + ".mlsg")));
  }
  PackedStoreWriter writer(dir, "test_lib", kArchives);
  for (const Expected& e : assets) {
    PackedAssetInput in;
    in.uid = e.uid;
    in.mjcf = e.mjcf;
    in.archive = e.archive;
    in.annotation = e.annotation ? &*e.annotation : nullptr;
    for (const Expected::G& g : e.grasps) {
      PackedAssetInput::Grasps pg;
      pg.robot = g.robot;
      pg.joint = g.joint;
      pg.archive = g.archive;
      pg.offset = shards[g.archive]->Append(g.poses);
      pg.count = static_cast<uint32_t>(g.poses.size());
      pg.stored_dtype = g.dtype;
      in.grasps.push_back(pg);
    }
    writer.Add(in);
  }
  for (auto& s : shards) s->Finish();
  writer.Finish();
}

Annotation RedBlockAnnotation() {
  const fs::path json = fs::path(MLSPACES_EXAMPLES_DIR) /
                        "custom_assets/asset_library/red_block/red_block_computed.json";
  return LoadAnnotation("red_block", "test_lib", json, nullptr);
}

NpyArray Array(DType dtype, std::vector<size_t> shape, std::vector<double> values) {
  return NpyArray::FromDoubles(dtype, std::move(shape), values);
}

/// An annotation with arrays of several dtypes at nested pointers, and non-ASCII JSON.
Annotation SyntheticAnnotation(const std::string& uid) {
  Annotation a;
  a.uid = uid;
  a.library = "test_lib";
  a.json = ParseJson(R"({"z_first": 1, "a_second": -2, "nested": {"b": [1.5, true, null,
      "str\u00e9"], "a": {"deep": 18446744073709551615}}, "float": 0.1, "neg": -9007199254740993,
      "empty_obj": {}, "empty_arr": [], "unicode": "\u6e2c\u8a66"})",
                     "synthetic");
  a.arrays.emplace_back("/description_short/clip",
                        Array(DType::kF4, {2, 3}, {0.5, -1.25, 3, 4, 5, 6.75}));
  a.arrays.emplace_back("/nested/a/ids", Array(DType::kI8, {4}, {-1, 0, 1, 9e15}));
  a.arrays.emplace_back("/half", Array(DType::kF2, {3}, {0.5, 1, -2}));
  a.arrays.emplace_back("/mask/x~1y", Array(DType::kB1, {2, 2}, {1, 0, 0, 1}));
  a.arrays.emplace_back("/bytes", Array(DType::kU1, {5}, {0, 1, 2, 254, 255}));
  a.arrays.emplace_back("/i4", Array(DType::kI4, {1, 2, 1}, {-7, 7}));
  a.arrays.emplace_back("/scalar", Array(DType::kF8, {}, {3.25}));
  a.arrays.emplace_back("/empty", Array(DType::kF8, {0, 3}, {}));
  return a;
}

void ExpectSameAnnotation(const Annotation& got, const Annotation& want) {
  EXPECT_EQ(got.uid, want.uid);
  EXPECT_EQ(got.library, want.library);
  EXPECT_EQ(got.json, want.json) << got.json.dump() << "\n" << want.json.dump();
  EXPECT_EQ(got.json.dump(), want.json.dump());  // key order kept
  ASSERT_EQ(got.arrays.size(), want.arrays.size());
  for (size_t i = 0; i < got.arrays.size(); ++i) {
    EXPECT_EQ(got.arrays[i].first, want.arrays[i].first);
    EXPECT_EQ(got.arrays[i].second.dtype, want.arrays[i].second.dtype);
    EXPECT_EQ(got.arrays[i].second.shape, want.arrays[i].second.shape);
    EXPECT_EQ(got.arrays[i].second.data, want.arrays[i].second.data);
  }
}

/// The mixed set most tests use: UIDs of many lengths (1 byte to 200), objaverse-like hex,
/// unicode; pickup and joint grasps for several robots; some without metadata or grasps.
std::vector<Expected> MixedAssets() {
  std::vector<Expected> out;
  auto add = [&](std::string uid, uint32_t archive, bool meta) -> Expected& {
    Expected e;
    e.uid = std::move(uid);
    e.mjcf = "objects/" + e.uid + "/" + e.uid + ".xml";
    e.archive = archive;
    if (meta) e.annotation = SyntheticAnnotation(e.uid);
    out.push_back(std::move(e));
    return out.back();
  };
  Expected& red = add("red_block", 0, false);
  red.annotation = RedBlockAnnotation();
  red.grasps.push_back({"franka_droid", "", 0, Poses(1, 33)});
  red.grasps.push_back({"rby1", "", 1, Poses(2, 7)});
  Expected& hex = add("0a1b2c3d4e5f60718293a4b5c6d7e8f9", 1, true);
  hex.grasps.push_back({"franka_droid", "", 1, Poses(3, 50)});
  hex.grasps.push_back({"franka_droid", "drawer_joint", 1, Poses(4, 12), DType::kF4});
  hex.grasps.push_back({"franka_droid", "door_joint", 0, Poses(5, 3)});
  hex.grasps.push_back({"arx", "door_joint", 0, Poses(6, 1)});
  add("x", 0, true);
  add("Fridge_1", 1, false).grasps.push_back({"arx", "", 0, Poses(7, 2)});
  add("\xe6\xb8\xac\xe8\xa9\xa6-\xc3\xa9l\xc3\xa8ve", 0, true)
      .grasps.push_back({"rby1", "hinge", 1, Poses(8, 4)});
  add(std::string(200, 'L'), 1, true);
  add("ffffffffffffffffffffffffffffffff", 0, false);
  return out;
}

void ExpectStoreMatches(const PackedLibrary& lib, const fs::path& dir,
                        const std::vector<Expected>& assets) {
  ASSERT_EQ(lib.size(), assets.size());
  EXPECT_EQ(lib.dir(), dir);
  EXPECT_EQ(lib.name(), "test_lib");
  EXPECT_EQ(std::vector<std::string>(lib.archives().begin(), lib.archives().end()), kArchives);
  std::set<std::string> robots;
  for (const Expected& e : assets) {
    for (const auto& g : e.grasps) robots.insert(g.robot);
  }
  EXPECT_EQ(lib.robots(), std::vector<std::string>(robots.begin(), robots.end()));
  for (const Expected& e : assets) {
    SCOPED_TRACE(e.uid);
    const std::optional<PackedAsset> a = lib.Find(e.uid);
    ASSERT_TRUE(a.has_value());
    EXPECT_EQ(a->uid, e.uid);
    EXPECT_EQ(a->mjcf, e.mjcf);
    EXPECT_EQ(a->archive, e.archive);
    EXPECT_EQ(a->num_grasps, e.grasps.size());
    const std::shared_ptr<const Annotation> ann = lib.LoadAnnotation(*a);
    if (e.annotation) {
      ASSERT_NE(ann, nullptr);
      ExpectSameAnnotation(*ann, *e.annotation);
    } else {
      EXPECT_EQ(ann, nullptr);
      EXPECT_EQ(a->metadata_size, 0u);
    }
    std::vector<Expected::G> want = e.grasps;
    std::sort(want.begin(), want.end(), [](const auto& x, const auto& y) {
      return std::tie(x.robot, x.joint) < std::tie(y.robot, y.joint);
    });
    const std::vector<PackedGraspRef> refs = lib.Grasps(*a);
    ASSERT_EQ(refs.size(), want.size());
    for (size_t i = 0; i < refs.size(); ++i) {
      EXPECT_EQ(refs[i].robot, want[i].robot);
      EXPECT_EQ(refs[i].joint, want[i].joint);
      EXPECT_EQ(refs[i].archive, want[i].archive);
      EXPECT_EQ(refs[i].count, want[i].poses.size());
      EXPECT_EQ(refs[i].stored_dtype, want[i].dtype);
      const std::optional<PackedGraspRef> found = lib.FindGrasps(*a, want[i].robot, want[i].joint);
      ASSERT_TRUE(found.has_value());
      EXPECT_EQ(found->offset, refs[i].offset);
      const std::vector<Mat4> poses = lib.ReadGrasps(refs[i]);
      ASSERT_EQ(poses.size(), want[i].poses.size());
      for (size_t k = 0; k < poses.size(); ++k) EXPECT_TRUE(SameBits(poses[k], want[i].poses[k]));
    }
    EXPECT_FALSE(lib.FindGrasps(*a, "no_such_robot", "").has_value());
    EXPECT_FALSE(lib.FindGrasps(*a, "franka_droid", "no_such_joint").has_value());
  }
}

TEST(PackedStoreTest, RoundTripFindAtGraspsAnnotations) {
  TempDir tmp;
  const std::vector<Expected> assets = MixedAssets();
  WriteStore(tmp.path(), assets);
  const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
  ExpectStoreMatches(*lib, tmp.path(), assets);
  lib->Check();

  // At(i) iterates in UID (byte) order and agrees with Find.
  std::vector<std::string> sorted;
  sorted.reserve(assets.size());
  for (const Expected& e : assets) sorted.push_back(e.uid);
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < lib->size(); ++i) {
    const PackedAsset a = lib->At(i);
    EXPECT_EQ(a.uid, sorted[i]);
    EXPECT_EQ(lib->Find(a.uid)->metadata_offset, a.metadata_offset);
  }
  EXPECT_THROW(lib->At(lib->size()), Error);

  // Misses: empty, prefixes, extensions, case changes.
  for (const std::string& miss :
       std::vector<std::string>{"", "red_bloc", "red_block ", "RED_BLOCK", "0a1b2c3d4e5f", "y",
                                std::string(201, 'L'), std::string(199, 'L')}) {
    EXPECT_FALSE(lib->Find(miss).has_value()) << miss;
  }
  // Shards live where GraspShardPath says, named after the archive stem.
  EXPECT_EQ(lib->GraspShardPath(1), tmp.path() / ".mlspaces/grasps/objects_001.mlsg");
  EXPECT_TRUE(fs::exists(lib->GraspShardPath(0)));
  EXPECT_THROW(lib->GraspShardPath(2), Error);
  // No temp files are left behind.
  for (const std::string& f : testing::ListFiles(tmp.path())) {
    EXPECT_EQ(f.find(".tmp."), std::string::npos) << f;
  }
}

TEST(PackedStoreTest, RealGraspNpzRoundTripsBitExact) {
  // The example library's droid grasps, as `mlspaces pack` would read them.
  const auto arrays = ReadNpz(fs::path(MLSPACES_EXAMPLES_DIR) /
                              "custom_assets/asset_library/red_block/droid/grasps.npz");
  ASSERT_FALSE(arrays.empty());
  const NpyArray& t = arrays[0].second;
  ASSERT_EQ(t.num_elements() % 16, 0u);
  const std::vector<double> values = t.ToDoubles();
  std::vector<Mat4> poses(values.size() / 16);
  for (size_t i = 0; i < poses.size(); ++i) {
    std::copy_n(values.begin() + static_cast<ptrdiff_t>(16 * i), 16, poses[i].m.begin());
  }
  TempDir tmp;
  Expected e;
  e.uid = "red_block";
  e.mjcf = "red_block/red_block.xml";
  e.annotation = RedBlockAnnotation();
  e.grasps.push_back({"droid", "", 0, poses, t.dtype});
  WriteStore(tmp.path(), {e});
  const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
  ExpectStoreMatches(*lib, tmp.path(), {e});
  lib->Check();
}

TEST(PackedStoreTest, ReadGraspsSelectedRowsBitExact) {
  TempDir tmp;
  const std::vector<Expected> assets = MixedAssets();
  WriteStore(tmp.path(), assets);
  const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
  const PackedAsset hex = *lib->Find("0a1b2c3d4e5f60718293a4b5c6d7e8f9");
  const PackedGraspRef ref = *lib->FindGrasps(hex, "franka_droid", "");
  const std::vector<Mat4> want = Poses(3, 50);
  const std::vector<size_t> rows = {49, 0, 7, 7, 23};
  const std::vector<Mat4> got = lib->ReadGrasps(ref, &rows);
  ASSERT_EQ(got.size(), rows.size());
  for (size_t i = 0; i < rows.size(); ++i) EXPECT_TRUE(SameBits(got[i], want[rows[i]])) << i;
  const std::vector<size_t> none;
  EXPECT_TRUE(lib->ReadGrasps(ref, &none).empty());
  const std::vector<size_t> bad = {3, 50};
  try {
    lib->ReadGrasps(ref, &bad);
    ADD_FAILURE() << "row 50 of 50 accepted";
  } catch (const Error& err) {
    EXPECT_THAT(err.message(), HasSubstr("row 50"));
    EXPECT_EQ(err.path(), lib->GraspShardPath(ref.archive).string());
  }
  // A ref pointing past the shard (a stale index) is an Error naming the shard.
  PackedGraspRef stale = ref;
  stale.count = 1u << 30;
  EXPECT_THROW(lib->ReadGrasps(stale), Error);
  stale = ref;
  stale.offset += 8;  // not on a pose boundary
  EXPECT_THROW(lib->ReadGrasps(stale), Error);
  stale.offset = 0;
  EXPECT_THROW(lib->ReadGrasps(stale), Error);
}

TEST(PackedStoreTest, TwentyThousandUidsFoundAndMissesRejected) {
  TempDir tmp;
  std::vector<Expected> assets;
  std::mt19937_64 rng(7);
  std::set<std::string> uids;
  while (uids.size() < 20000) {
    char hex[33];
    std::snprintf(hex, sizeof hex, "%016llx%016llx", static_cast<unsigned long long>(rng()),
                  static_cast<unsigned long long>(rng()));
    // Mix lengths: objaverse 32-hex, short, and long path-like UIDs.
    const size_t kind = uids.size() % 3;
    uids.insert(kind == 0   ? std::string(hex)
                : kind == 1 ? std::string(hex, 6 + uids.size() % 9)
                            : "Obj_" + std::string(hex) + std::string(hex));
  }
  for (const std::string& uid : uids) {
    Expected e;
    e.uid = uid;
    e.mjcf = uid + ".xml";
    e.archive = uid[0] % 2;
    assets.push_back(std::move(e));
  }
  WriteStore(tmp.path(), assets);
  const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
  ASSERT_EQ(lib->size(), 20000u);
  size_t i = 0;
  for (const std::string& uid : uids) {  // std::set order = byte order = At order
    const auto a = lib->Find(uid);
    ASSERT_TRUE(a.has_value()) << uid;
    ASSERT_EQ(a->uid, uid);
    ASSERT_EQ(a->mjcf, uid + ".xml");
    ASSERT_EQ(lib->At(i++).uid, uid);
  }
  // Misses: mutated existing UIDs (same length, same prefix) and fresh random ones.
  size_t misses = 0;
  for (const std::string& uid : uids) {
    std::string m = uid;
    m.back() = static_cast<char>(m.back() ^ 0x40);
    if (!uids.contains(m)) {
      EXPECT_FALSE(lib->Find(m).has_value()) << m;
      ++misses;
    }
    if (!uids.contains(uid + "0")) {
      EXPECT_FALSE(lib->Find(uid + "0").has_value());
    }
  }
  EXPECT_GT(misses, 19000u);
  lib->Check();
}

TEST(PackedStoreTest, MissWhoseTagAndBucketCollideIsNotFound) {
  // "missing-..." below was found by brute force: XXH3-64 high 32 bits (the bucket tag) and
  // lowest bit (the home bucket of a 2-bucket table) equal to those of "a". So Find must get
  // past the tag check and compare the strings to say "not found".
  const std::string stored = "a";
  const std::string colliding = "missing-40be35f2";
  const uint64_t hs = XXH3_64bits(stored.data(), stored.size());
  const uint64_t hc = XXH3_64bits(colliding.data(), colliding.size());
  ASSERT_EQ(hs >> 32, hc >> 32);
  ASSERT_EQ(hs & 1, hc & 1);
  TempDir tmp;
  Expected e;
  e.uid = stored;
  e.mjcf = "a.xml";
  WriteStore(tmp.path(), {e});
  const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
  EXPECT_TRUE(lib->Find(stored).has_value());
  EXPECT_FALSE(lib->Find(colliding).has_value());

  // And the other way round: the colliding UID stored, "a" missing.
  TempDir tmp2;
  e.uid = colliding;
  WriteStore(tmp2.path(), {e});
  const auto lib2 = PackedLibrary::Open(tmp2.path(), "test_lib");
  EXPECT_TRUE(lib2->Find(colliding).has_value());
  EXPECT_FALSE(lib2->Find(stored).has_value());

  // Both stored: the second probes past the first (same home bucket, same tag).
  TempDir tmp3;
  Expected e2 = e;
  e2.uid = stored;
  WriteStore(tmp3.path(), {e, e2});
  const auto lib3 = PackedLibrary::Open(tmp3.path(), "test_lib");
  EXPECT_EQ(lib3->Find(colliding)->uid, colliding);
  EXPECT_EQ(lib3->Find(stored)->uid, stored);
  lib3->Check();
}

TEST(PackedStoreTest, AnnotationRoundTripRedBlockAndNestedArrays) {
  TempDir tmp;
  Expected red;
  red.uid = "red_block";
  red.mjcf = "red_block/red_block.xml";
  red.annotation = RedBlockAnnotation();
  Expected syn;
  syn.uid = "synthetic";
  syn.mjcf = "synthetic.xml";
  syn.annotation = SyntheticAnnotation("synthetic");
  syn.annotation->library = "test_lib";
  WriteStore(tmp.path(), {red, syn});
  const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
  const auto got_red = lib->LoadAnnotation(*lib->Find("red_block"));
  ASSERT_NE(got_red, nullptr);
  ExpectSameAnnotation(*got_red, *red.annotation);
  EXPECT_EQ(got_red->json.dump(4), red.annotation->json.dump(4));
  const auto got_syn = lib->LoadAnnotation(*lib->Find("synthetic"));
  ASSERT_NE(got_syn, nullptr);
  ExpectSameAnnotation(*got_syn, *syn.annotation);
  // The merged view agrees too (arrays at their pointers, values exact).
  EXPECT_EQ(got_syn->ToJson(), syn.annotation->ToJson());
  EXPECT_EQ(got_syn->FindArray("/nested/a/ids")->ToDoubles()[3], 9e15);
  // Library name is the one given to Open.
  const auto renamed = PackedLibrary::Open(tmp.path(), "other_name");
  EXPECT_EQ(renamed->LoadAnnotation(*renamed->Find("red_block"))->library, "other_name");
}

TEST(PackedStoreTest, WriterIsDeterministicAndOrderIndependent) {
  const std::vector<Expected> assets = MixedAssets();
  std::vector<Expected> reversed(assets.rbegin(), assets.rend());
  TempDir a, b, c;
  WriteStore(a.path(), assets);
  WriteStore(b.path(), assets);
  for (const std::string_view f : {kUidIndexFile, kMetadataStoreFile}) {
    const std::string fa = Slurp(a.path() / std::string(f));
    ASSERT_FALSE(fa.empty());
    EXPECT_EQ(fa, Slurp(b.path() / std::string(f))) << f;
  }
  EXPECT_EQ(Slurp(a.path() / ".mlspaces/grasps/objects_000.mlsg"),
            Slurp(b.path() / ".mlspaces/grasps/objects_000.mlsg"));
  // Reversed Add order: the same index and metadata (shard offsets differ, so compare the
  // metadata file, which does not hold them, and the index's UID order via At).
  WriteStore(c.path(), reversed);
  EXPECT_EQ(Slurp(a.path() / std::string(kMetadataStoreFile)),
            Slurp(c.path() / std::string(kMetadataStoreFile)));
  const auto la = PackedLibrary::Open(a.path(), "test_lib");
  const auto lc = PackedLibrary::Open(c.path(), "test_lib");
  for (size_t i = 0; i < la->size(); ++i) EXPECT_EQ(la->At(i).uid, lc->At(i).uid);
  ExpectStoreMatches(*lc, c.path(), assets);
}

TEST(PackedStoreTest, WriterRejectsBadInput) {
  TempDir tmp;
  PackedStoreWriter writer(tmp.path(), "test_lib", kArchives);
  PackedAssetInput in;
  in.uid = "dup";
  in.mjcf = "dup.xml";
  writer.Add(in);
  try {
    writer.Add(in);
    ADD_FAILURE() << "duplicate accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.uid(), "dup");
    EXPECT_THAT(e.message(), HasSubstr("duplicate UID dup"));
  }
  in.uid = "bad_archive";
  in.archive = 2;
  try {
    writer.Add(in);
    ADD_FAILURE() << "archive 2 of 2 accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.uid(), "bad_archive");
    EXPECT_THAT(e.message(), HasSubstr("out of range"));
  }
  in.archive = 0;
  in.grasps.push_back({"franka", "", 5, 64, 1, DType::kF8});
  EXPECT_THROW(writer.Add(in), Error);
  in.grasps = {{"franka", "", 0, 64, 1, DType::kF8}, {"franka", "", 1, 64, 1, DType::kF8}};
  EXPECT_THROW(writer.Add(in), Error);  // duplicate (robot, joint)
  in.grasps = {{"", "", 0, 64, 1, DType::kF8}};
  EXPECT_THROW(writer.Add(in), Error);  // empty robot
  in.grasps.clear();
  in.uid = "";
  EXPECT_THROW(writer.Add(in), Error);
  Annotation other = RedBlockAnnotation();
  in.uid = "not_red_block";
  in.annotation = &other;
  EXPECT_THROW(writer.Add(in), Error);  // annotation of another UID
  NpyArray broken = Array(DType::kF8, {3}, {1, 2, 3});
  broken.data.pop_back();
  other.uid = "";
  other.arrays.emplace_back("/broken", broken);
  EXPECT_THROW(writer.Add(in), Error);
  writer.Finish();
  EXPECT_THROW(writer.Finish(), Error);
  // The failed Adds left nothing: only "dup" is in the store.
  const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
  ASSERT_EQ(lib->size(), 1u);
  EXPECT_EQ(lib->At(0).uid, "dup");
  lib->Check();

  GraspShardWriter shard(tmp.path() / "s.mlsg");
  Mat4 nan;
  nan.m[5] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(shard.Append(std::vector<Mat4>{nan}), Error);
}

TEST(PackedStoreTest, EmptyStoreOpens) {
  TempDir tmp;
  WriteStore(tmp.path(), {});
  const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
  EXPECT_EQ(lib->size(), 0u);
  EXPECT_TRUE(lib->robots().empty());
  EXPECT_FALSE(lib->Find("anything").has_value());
  EXPECT_FALSE(lib->Find("").has_value());
  lib->Check();
}

TEST(PackedStoreTest, MissingStoreFilesNameThePath) {
  TempDir tmp;
  try {
    PackedLibrary::Open(tmp.path(), "x");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), (tmp.path() / "uid_index.mlsx").string());
  }
  WriteStore(tmp.path(), MixedAssets());
  fs::remove(tmp.path() / "metadata.mlsm");
  try {
    PackedLibrary::Open(tmp.path(), "x");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), (tmp.path() / "metadata.mlsm").string());
  }
}

TEST(PackedStoreTest, MissingAndDamagedShards) {
  TempDir tmp;
  WriteStore(tmp.path(), MixedAssets());
  const fs::path shard = tmp.path() / ".mlspaces/grasps/objects_001.mlsg";
  const std::string good = Slurp(shard);
  fs::remove(shard);
  {
    const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
    const PackedAsset a = *lib->Find("0a1b2c3d4e5f60718293a4b5c6d7e8f9");
    const PackedGraspRef ref = *lib->FindGrasps(a, "franka_droid", "");
    try {
      lib->ReadGrasps(ref);
      ADD_FAILURE() << "missing shard read";
    } catch (const Error& e) {
      EXPECT_EQ(e.path(), shard.string());
      EXPECT_THAT(e.message(), HasSubstr("grasp shard " + shard.string() + " is not installed"));
    }
    // Archive 0's shard is there and still readable; once installed, archive 1 reads too
    // (a missing shard is not cached).
    EXPECT_EQ(lib->ReadGrasps(*lib->FindGrasps(a, "arx", "door_joint")).size(), 1u);
    WriteText(shard, good);
    EXPECT_EQ(lib->ReadGrasps(ref).size(), 50u);
  }
  // Every truncation of the shard is an Error naming it.
  for (size_t len = 0; len < good.size(); len += (len < 200 ? 1 : 97)) {
    WriteText(shard, good.substr(0, len));
    const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
    const PackedAsset a = *lib->Find("0a1b2c3d4e5f60718293a4b5c6d7e8f9");
    try {
      lib->ReadGrasps(*lib->FindGrasps(a, "franka_droid", ""));
      ADD_FAILURE() << "truncated shard of " << len << " bytes read";
    } catch (const Error& e) {
      EXPECT_EQ(e.path(), shard.string()) << len;
    }
  }
  // A NaN inside a pose is an Error naming the shard; bad magic too.
  std::string damaged = good;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::memcpy(damaged.data() + 64 + 3 * 8, &nan, sizeof nan);
  WriteText(shard, damaged);
  {
    const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
    bool threw = false;
    for (size_t i = 0; i < lib->size(); ++i) {
      for (const PackedGraspRef& ref : lib->Grasps(lib->At(i))) {
        if (ref.archive != 1 || ref.offset != 64) continue;
        try {
          lib->ReadGrasps(ref);
        } catch (const Error& e) {
          EXPECT_THAT(e.message(), HasSubstr("non-finite"));
          EXPECT_EQ(e.path(), shard.string());
          threw = true;
        }
      }
    }
    EXPECT_TRUE(threw);
  }
  damaged = good;
  damaged[0] = 'X';
  WriteText(shard, damaged);
  {
    const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
    const PackedAsset a = *lib->Find("0a1b2c3d4e5f60718293a4b5c6d7e8f9");
    EXPECT_THROW(lib->ReadGrasps(*lib->FindGrasps(a, "franka_droid", "")), Error);
  }
}

TEST(PackedStoreTest, ConcurrentFirstShardUse) {
  TempDir tmp;
  const std::vector<Expected> assets = MixedAssets();
  WriteStore(tmp.path(), assets);
  const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
  std::vector<std::thread> threads;
  threads.reserve(8);
  std::atomic<int> ok{0};
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&] {
      for (int round = 0; round < 50; ++round) {
        for (const Expected& e : assets) {
          const PackedAsset a = *lib->Find(e.uid);
          for (const PackedGraspRef& ref : lib->Grasps(a)) {
            if (lib->ReadGrasps(ref).size() == ref.count) ok.fetch_add(1);
          }
        }
      }
    });
  }
  for (auto& t : threads) t.join();
  size_t refs = 0;
  for (const Expected& e : assets) refs += e.grasps.size();
  EXPECT_EQ(ok.load(), static_cast<int>(8 * 50 * refs));
}

/// Overwrites bytes of a file in place. (Rewriting with O_TRUNC thousands of times is slow
/// on ext4, which flushes a file truncated to zero when it is closed.)
void Patch(const fs::path& path, size_t offset, std::string_view bytes) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekp(static_cast<std::streamoff>(offset));
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(f.good()) << path;
}

/// Everything a reader can do with a store; Errors are fine, anything else fails the test.
/// Returns whether it got through without an Error.
bool ExerciseStore(const fs::path& dir, const std::vector<Expected>& assets) {
  try {
    const auto lib = PackedLibrary::Open(dir, "test_lib");
    (void)lib->robots();
    for (const Expected& e : assets) {
      const auto a = lib->Find(e.uid);
      if (!a) continue;
      (void)lib->LoadAnnotation(*a);
      for (const PackedGraspRef& ref : lib->Grasps(*a)) {
        (void)lib->FindGrasps(*a, ref.robot, ref.joint);
      }
    }
    (void)lib->Find("definitely missing");
    for (size_t i = 0; i < lib->size(); ++i) {
      const PackedAsset a = lib->At(i);
      (void)lib->LoadAnnotation(a);
      (void)lib->Grasps(a);
    }
    lib->Check();
    return true;
  } catch (const Error&) {
    return false;
  }
}

TEST(PackedStoreTest, EveryTruncationIsAnError) {
  TempDir tmp;
  const std::vector<Expected> assets = MixedAssets();
  WriteStore(tmp.path(), assets);
  for (const std::string_view name : {kUidIndexFile, kMetadataStoreFile}) {
    const fs::path file = tmp.path() / std::string(name);
    const std::string good = Slurp(file);
    ASSERT_GT(good.size(), 64u);
    // Longest first: each step cuts the file shorter in place.
    for (size_t len = good.size(); len-- > 0;) {
      fs::resize_file(file, len);
      try {
        PackedLibrary::Open(tmp.path(), "test_lib");
        ADD_FAILURE() << name << " truncated to " << len << " bytes opened";
      } catch (const Error& e) {
        EXPECT_EQ(e.path(), file.string()) << len;
      }
      EXPECT_FALSE(ExerciseStore(tmp.path(), assets));
    }
    // Extended (junk appended) is an error too.
    WriteText(file, good + std::string(8, '\0'));
    EXPECT_THROW(PackedLibrary::Open(tmp.path(), "test_lib"), Error);
    WriteText(file, good);
    EXPECT_TRUE(ExerciseStore(tmp.path(), assets));
  }
}

TEST(PackedStoreTest, ByteFlipsGiveErrorsNeverCrashes) {
  // Every byte of both files flipped once (random nonzero xor, seeded), plus a few hundred
  // random multi-byte damages. Lookups on the damaged store must throw Error or return
  // something; ASan/UBSan (the CI build) catches any read outside the mappings. Check()
  // must notice every single-byte flip.
  TempDir tmp;
  const std::vector<Expected> assets = MixedAssets();
  WriteStore(tmp.path(), assets);
  std::mt19937 rng(12345);
  size_t errors = 0, runs = 0;
  for (const std::string_view name : {kUidIndexFile, kMetadataStoreFile}) {
    const fs::path file = tmp.path() / std::string(name);
    const std::string good = Slurp(file);
    for (size_t pos = 0; pos < good.size(); ++pos) {
      const char flipped = static_cast<char>(good[pos] ^ (1 + rng() % 255));
      Patch(file, pos, std::string_view(&flipped, 1));
      EXPECT_FALSE(ExerciseStore(tmp.path(), assets)) << name << " byte " << pos;
      Patch(file, pos, std::string_view(&good[pos], 1));
      ++runs;
    }
    for (int round = 0; round < 300; ++round) {
      std::vector<size_t> positions;
      const int flips = 1 + static_cast<int>(rng() % 8);
      for (int k = 0; k < flips; ++k) {
        positions.push_back(rng() % good.size());
        const char c = static_cast<char>(rng());
        Patch(file, positions.back(), std::string_view(&c, 1));
      }
      errors += ExerciseStore(tmp.path(), assets) ? 0 : 1;
      for (size_t p : positions) Patch(file, p, std::string_view(&good[p], 1));
      ++runs;
    }
    ASSERT_EQ(Slurp(file), good);
  }
  EXPECT_GT(errors, 500u);
  EXPECT_TRUE(ExerciseStore(tmp.path(), assets)) << runs;
}

TEST(PackedStoreTest, LookupsOnDamagedFileThrowErrorNamingIt) {
  // Damage a record's UID length so the lookup (not Open, not Check) hits it.
  TempDir tmp;
  const std::vector<Expected> assets = MixedAssets();
  WriteStore(tmp.path(), assets);
  const fs::path file = tmp.path() / std::string(kUidIndexFile);
  std::string bytes = Slurp(file);
  uint32_t buckets, records_off;
  std::memcpy(&buckets, bytes.data() + 24, 4);
  std::memcpy(&records_off, bytes.data() + 40, 4);
  ASSERT_EQ(records_off, 64 + 8 * buckets);
  for (size_t r = 0; r < assets.size(); ++r) {
    const uint32_t huge = 0x7fffffff;
    std::memcpy(bytes.data() + records_off + r * 48 + 4, &huge, 4);  // uid_len
  }
  WriteText(file, bytes);
  const auto lib = PackedLibrary::Open(tmp.path(), "test_lib");
  try {
    lib->Find("red_block");
    ADD_FAILURE() << "damaged UID length not noticed";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), file.string());
    EXPECT_THAT(e.message(), HasSubstr("damaged index"));
  }
  EXPECT_THROW(lib->At(0), Error);
  EXPECT_THROW(lib->Check(), Error);
}

}  // namespace
}  // namespace mlspaces
