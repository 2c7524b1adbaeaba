// Grasp sets: grasp NPZ reading (shape, values, dtypes, rows), LoadGraspFile's subsampling,
// the subsampling draws pinned against the documented algorithm, world-frame grasps.
#include "mlspaces/library/grasp_set.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <set>
#include <vector>

#include "library/grasp_fixture.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/core/rng.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ErrorOf;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteGrasps;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

// ---- grasp files, subsampling, world grasps ------------------------------------------------

TEST(ReadGraspFileTest, ValidatesShapeAndValues) {
  TempDir tmp;
  const fs::path f = tmp.path() / "g.npz";
  WriteNpz(f, {{"transforms", NpyArray::FromDoubles({2, 3, 3}, std::vector<double>(18, 0.0))}});
  EXPECT_THAT(ErrorOf([&] { ReadGraspFile(f); }),
              HasSubstr("must have shape (N, 4, 4), got (2, 3, 3)"));
  WriteNpz(f, {{"transforms", NpyArray::FromDoubles({16}, std::vector<double>(16, 0.0))}});
  EXPECT_THAT(ErrorOf([&] { ReadGraspFile(f); }), HasSubstr("got (16,)"));
  std::vector<double> values(32, 0.0);
  values[16 + 5] = std::numeric_limits<double>::quiet_NaN();
  WriteNpz(f, {{"transforms", NpyArray::FromDoubles({2, 4, 4}, values)}});
  EXPECT_THAT(ErrorOf([&] { ReadGraspFile(f); }), HasSubstr("grasp 1 has a non-finite value"));
  const std::vector<size_t> first = {0};
  EXPECT_EQ(ReadGraspFile(f, &first).poses.size(), 1u);  // row 1 not read
  const std::vector<size_t> out_of_range = {2};
  EXPECT_THROW(ReadGraspFile(f, &out_of_range), Error);
  WriteNpz(f, {{"grasps", NpyArray::FromDoubles({1, 4, 4}, std::vector<double>(16, 0.0))}});
  EXPECT_THAT(ErrorOf([&] { ReadGraspFile(f); }), HasSubstr("no transforms.npy"));
  EXPECT_THROW(ReadGraspFile(tmp.path() / "missing.npz"), Error);
}

TEST(ReadGraspFileTest, ConvertsStoredDtypesToDouble) {
  TempDir tmp;
  for (DType dtype : {DType::kF2, DType::kF4, DType::kF8}) {
    for (bool compress : {false, true}) {
      const fs::path f = tmp.path() / "g.npz";
      WriteGrasps(f, 6, 0.5, dtype, compress);
      const GraspSet all = ReadGraspFile(f);
      EXPECT_EQ(all.stored_dtype, dtype);
      ASSERT_EQ(all.poses.size(), 6u);
      EXPECT_EQ(all.poses[4](0, 3), 4.0);
      EXPECT_EQ(all.poses[4](1, 3), 0.5);
      EXPECT_EQ(all.poses[4](3, 3), 1.0);
      const std::vector<size_t> rows = {5, 1, 5};
      const GraspSet some = ReadGraspFile(f, &rows);
      EXPECT_THAT(some.indices, ElementsAre(5, 1, 5));
      EXPECT_EQ(some.poses[0](0, 3), 5.0);
      EXPECT_EQ(some.poses[1](0, 3), 1.0);
    }
  }
}

/// The documented algorithm, dense, as a reference.
std::vector<size_t> ReferenceSubsample(size_t n, size_t k, uint64_t seed) {
  std::vector<size_t> a(n);
  for (size_t i = 0; i < n; ++i) a[i] = i;
  Rng rng(seed);
  std::vector<size_t> out;
  for (size_t i = 0; i < k; ++i) {
    size_t j = i + rng.UniformInt(n - i);
    std::swap(a[i], a[j]);
    out.push_back(a[i]);
  }
  return out;
}

TEST(SubsampleTest, AllWhenFewEnough) {
  EXPECT_THAT(SubsampleIndices(4, 4, 9), ElementsAre(0, 1, 2, 3));
  EXPECT_THAT(SubsampleIndices(3, 50, 9), ElementsAre(0, 1, 2));
  EXPECT_THAT(SubsampleIndices(0, 5, 9), IsEmpty());
  EXPECT_THAT(SubsampleIndices(10, 0, 9), IsEmpty());
}

TEST(SubsampleTest, DeterministicDistinctInRange) {
  for (uint64_t seed : {0ull, 1ull, 12345ull}) {
    const std::vector<size_t> a = SubsampleIndices(1000, 50, seed);
    EXPECT_EQ(a, SubsampleIndices(1000, 50, seed));
    ASSERT_EQ(a.size(), 50u);
    EXPECT_EQ(std::set<size_t>(a.begin(), a.end()).size(), 50u);
    for (size_t i : a) EXPECT_LT(i, 1000u);
    EXPECT_EQ(a, ReferenceSubsample(1000, 50, seed));
  }
  EXPECT_NE(SubsampleIndices(1000, 50, 1), SubsampleIndices(1000, 50, 2));
  // k = n - 1 is a full permutation but one.
  const std::vector<size_t> p = SubsampleIndices(10, 9, 3);
  EXPECT_EQ(std::set<size_t>(p.begin(), p.end()).size(), 9u);
}

TEST(SubsampleTest, SparsePathMatchesTheDenseAlgorithm) {
  // Large n with small k takes the sparse path; the draws must be the same.
  for (uint64_t seed : {0ull, 7ull}) {
    EXPECT_EQ(SubsampleIndices(1000000, 40, seed), ReferenceSubsample(1000000, 40, seed));
    EXPECT_EQ(SubsampleIndices(5000, 600, seed), ReferenceSubsample(5000, 600, seed));
  }
  // Small n so that collisions among displaced slots happen, through the public function.
  const std::vector<size_t> s = SubsampleIndices(4097, 512, 5);
  EXPECT_EQ(s, ReferenceSubsample(4097, 512, 5));
  EXPECT_EQ(std::set<size_t>(s.begin(), s.end()).size(), 512u);
}

TEST(SubsampleTest, PinnedDraws) {
  // The documented stream (docs/formats.md) must never change silently.
  const std::vector<size_t> got = SubsampleIndices(100, 5, 0);
  EXPECT_EQ(got, ReferenceSubsample(100, 5, 0));
  EXPECT_THAT(got, ElementsAre(60, 75, 12, 43, 74));
}

Mat4 Make(std::initializer_list<double> rows) {
  Mat4 m;
  std::copy(rows.begin(), rows.end(), m.m.begin());
  return m;
}

TEST(GraspsInWorldTest, ComposesAndFlipsExactly) {
  // Body: rotation of +90 deg about z, at (1, 2, 3).
  const Mat4 body = Make({0, -1, 0, 1,  //
                          1, 0, 0, 2,   //
                          0, 0, 1, 3,   //
                          0, 0, 0, 1});
  // Grasp: the tutorial's top-down grasp, 0.1 m along the body x axis.
  const Mat4 grasp = Make({1, 0, 0, 0.1,  //
                           0, -1, 0, 0,   //
                           0, 0, -1, 0,   //
                           0, 0, 0, 1});
  const std::vector<Mat4> grasps = {grasp, Mat4{}};
  const std::vector<Mat4> w = GraspsInWorld(body, grasps);
  ASSERT_EQ(w.size(), 4u);
  // Hand-computed: R_body * R_grasp = [[0,1,0],[1,0,0],[0,0,-1]]; p = (1, 2.1, 3).
  const Mat4 w0 = Make({0, 1, 0, 1,    //
                        1, 0, 0, 2.1,  //
                        0, 0, -1, 3,   //
                        0, 0, 0, 1});
  EXPECT_EQ(w[0].m, w0.m);
  EXPECT_EQ(w[1].m, body.m);
  // Flipped twins follow all originals: x and y columns negated, z and position kept.
  const Mat4 w0_flipped = Make({0, -1, 0, 1,    //
                                -1, 0, 0, 2.1,  //
                                0, 0, -1, 3,    //
                                0, 0, 0, 1});
  EXPECT_EQ(w[2].m, w0_flipped.m);
  const Mat4 body_flipped = Make({0, 1, 0, 1,   //
                                  -1, 0, 0, 2,  //
                                  0, 0, 1, 3,   //
                                  0, 0, 0, 1});
  EXPECT_EQ(w[3].m, body_flipped.m);
  // Exactly W * diag(-1, -1, 1, 1), and its jaw axis (y) reversed.
  const Mat4 flip = Make({-1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});
  EXPECT_EQ((w[0] * flip).m, w[2].m);
  const std::vector<Mat4> unflipped = GraspsInWorld(body, grasps, false);
  ASSERT_EQ(unflipped.size(), 2u);
  EXPECT_EQ(unflipped[0].m, w0.m);
  EXPECT_TRUE(GraspsInWorld(body, {}).empty());
}

TEST(LoadGraspFileTest, AllInFileOrderOrSeededDraws) {
  TempDir tmp;
  const fs::path f = tmp.path() / "g.npz";
  WriteGrasps(f, 7, 2.0);
  EXPECT_EQ(CountGraspFileRows(f), 7u);
  const GraspSet all = LoadGraspFile(f, 7, 3);
  EXPECT_THAT(all.indices, ElementsAre(0, 1, 2, 3, 4, 5, 6));
  EXPECT_EQ(all.source, f);
  const GraspSet some = LoadGraspFile(f, 4, 11);
  EXPECT_EQ(some.indices, SubsampleIndices(7, 4, 11));
  ASSERT_EQ(some.poses.size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(some.poses[i](0, 3), static_cast<double>(some.indices[i]));
    EXPECT_EQ(some.poses[i](1, 3), 2.0);
  }
  EXPECT_THROW(CountGraspFileRows(tmp.path() / "missing.npz"), Error);
}

}  // namespace
}  // namespace mlspaces
