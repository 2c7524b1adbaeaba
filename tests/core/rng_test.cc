#include "mlspaces/core/rng.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace mlspaces {
namespace {

// Values computed independently (a Python model of SplitMix64 seeding + xoshiro256**);
// they pin the stream so it can never change silently.
TEST(RngTest, PinnedFirstValues) {
  Rng zero(0);
  EXPECT_EQ(zero.NextU64(), 0x99ec5f36cb75f2b4ULL);
  EXPECT_EQ(zero.NextU64(), 0xbf6e1f784956452aULL);
  EXPECT_EQ(zero.NextU64(), 0x1a5f849d4933e6e0ULL);
  EXPECT_EQ(zero.NextU64(), 0x6aa594f1262d2d2cULL);
  Rng other(12345);
  EXPECT_EQ(other.NextU64(), 0xbe6a36374160d49bULL);
  EXPECT_EQ(other.NextU64(), 0x214aaa0637a688c6ULL);
}

TEST(RngTest, PinnedUniformIntAndUniform01) {
  Rng ints(0);
  std::vector<uint64_t> got;
  got.reserve(8);
  for (int i = 0; i < 8; ++i) got.push_back(ints.UniformInt(10));
  EXPECT_THAT(got, ::testing::ElementsAre(6, 7, 1, 4, 7, 9, 4, 5));
  Rng unit(0);
  EXPECT_EQ(unit.Uniform01(), 0.6012629994179048);
  EXPECT_EQ(unit.Uniform01(), 0.7477740925472398);
}

TEST(RngTest, SplitMix64Reference) {
  // The published SplitMix64 outputs for state 0.
  uint64_t state = 0;
  EXPECT_EQ(SplitMix64(state), 0xe220a8397b1dcdafULL);
  EXPECT_EQ(SplitMix64(state), 0x6e789e6aa1b965f4ULL);
  EXPECT_EQ(state, 2 * 0x9E3779B97F4A7C15ULL);
}

TEST(RngTest, DeterministicAndSeedSensitive) {
  Rng a(77), b(77), c(78);
  bool differs = false;
  for (int i = 0; i < 100; ++i) {
    const uint64_t va = a.NextU64();
    EXPECT_EQ(va, b.NextU64());
    differs |= va != c.NextU64();
  }
  EXPECT_TRUE(differs);
}

TEST(RngTest, UniformIntStaysInRangeAndIsRoughlyUniform) {
  Rng rng(2024);
  constexpr int kBuckets = 7;
  constexpr int kDraws = 70000;
  int counts[kBuckets] = {};
  for (int i = 0; i < kDraws; ++i) {
    const uint64_t v = rng.UniformInt(kBuckets);
    ASSERT_LT(v, static_cast<uint64_t>(kBuckets));
    ++counts[v];
  }
  // Chi-square with 6 degrees of freedom: 22.46 is the 0.999 quantile.
  double chi2 = 0;
  const double expected = static_cast<double>(kDraws) / kBuckets;
  for (int c : counts) chi2 += (c - expected) * (c - expected) / expected;
  EXPECT_LT(chi2, 22.46);
  EXPECT_EQ(rng.UniformInt(1), 0u);
  // A bound just above 2^63 exercises the rejection path; values stay below it.
  const uint64_t big = (1ULL << 63) + 12345;
  for (int i = 0; i < 1000; ++i) EXPECT_LT(rng.UniformInt(big), big);
}

TEST(RngTest, UniformDoubles) {
  Rng rng(5);
  double sum = 0;
  for (int i = 0; i < 10000; ++i) {
    const double u = rng.Uniform01();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum += u;
    const double x = rng.Uniform(-2.0, 3.0);
    ASSERT_GE(x, -2.0);
    ASSERT_LT(x, 3.0);
  }
  EXPECT_NEAR(sum / 10000, 0.5, 0.02);
}

TEST(RngTest, DeriveSeedAndHashString) {
  EXPECT_EQ(HashString(""), 0xcbf29ce484222325ULL);   // FNV-1a offset basis
  EXPECT_EQ(HashString("a"), 0xaf63dc4c8601ec8cULL);  // published FNV-1a 64 test vector
  EXPECT_EQ(DeriveSeed(1, {2, 3}), DeriveSeed(1, {2, 3}));
  EXPECT_NE(DeriveSeed(1, {2, 3}), DeriveSeed(1, {3, 2}));
  EXPECT_NE(DeriveSeed(1, {2}), DeriveSeed(2, {2}));
  EXPECT_NE(DeriveSeed(1, {}), DeriveSeed(1, {0}));
  uint64_t state = 9;
  EXPECT_EQ(DeriveSeed(9, {}), SplitMix64(state));
}

TEST(RngTest, NormalHasUnitMomentsAndIsReproducible) {
  Rng rng(11);
  constexpr int kN = 200000;
  double sum = 0, sum2 = 0, sum4 = 0;
  for (int i = 0; i < kN; ++i) {
    const double x = rng.Normal();
    ASSERT_TRUE(std::isfinite(x));
    sum += x;
    sum2 += x * x;
    sum4 += x * x * x * x;
  }
  EXPECT_NEAR(sum / kN, 0.0, 0.01);
  EXPECT_NEAR(sum2 / kN, 1.0, 0.02);
  EXPECT_NEAR(sum4 / kN, 3.0, 0.1);  // kurtosis of a normal
  Rng a(5), b(5);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(a.Normal(), b.Normal());
}

TEST(RngTest, TruncatedNormalStaysInsideItsBound) {
  Rng rng(12);
  double max_abs = 0, sum2 = 0;
  constexpr int kN = 100000;
  for (int i = 0; i < kN; ++i) {
    const double x = rng.TruncatedNormal(1.0, 0.5);
    max_abs = std::max(max_abs, std::abs(x));
    sum2 += x * x;
  }
  EXPECT_LE(max_abs, 0.5);
  EXPECT_GT(max_abs, 0.49);
  // Variance of N(0,1) truncated to [-0.5, 0.5]: 1 - 2 a phi(a) / (2 Phi(a) - 1) = 0.0797.
  EXPECT_NEAR(sum2 / kN, 0.0797, 0.002);
  // A wide bound leaves the normal as it is.
  double wide2 = 0;
  for (int i = 0; i < kN; ++i) {
    const double x = rng.TruncatedNormal(0.01, 1.0);
    wide2 += x * x;
  }
  EXPECT_NEAR(wide2 / kN, 1e-4, 3e-6);
  // Degenerate inputs and far-tail bounds.
  EXPECT_EQ(rng.TruncatedNormal(0.0, 1.0), 0.0);
  EXPECT_EQ(rng.TruncatedNormal(1.0, 0.0), 0.0);
  for (int i = 0; i < 100; ++i) EXPECT_LE(std::abs(rng.TruncatedNormal(10.0, 0.1)), 0.1);
}

}  // namespace
}  // namespace mlspaces
