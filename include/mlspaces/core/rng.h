// Seeded random numbers. There is no global RNG in mlspaces: every draw comes from an Rng
// seeded from the run seed and the work item, so the same inputs give the same bytes on
// every platform (we never use std::*_distribution, whose output is implementation-defined).
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <initializer_list>
#include <string_view>
#include <vector>

namespace mlspaces {

/// SplitMix64 step: the documented seed mixer used by DeriveSeed and Rng's seeding.
MLSPACES_API uint64_t SplitMix64(uint64_t& state);

/// Mixes a seed with work-item parts, e.g. DeriveSeed(run_seed, {scene_id, episode}).
MLSPACES_API uint64_t DeriveSeed(uint64_t seed, std::initializer_list<uint64_t> parts);

/// 64-bit FNV-1a of a string, for turning names (UIDs, scene paths) into seed parts.
MLSPACES_API uint64_t HashString(std::string_view text);

/// xoshiro256** generator seeded through SplitMix64.
class MLSPACES_API Rng {
 public:
  explicit Rng(uint64_t seed);
  /// Next raw 64-bit value.
  uint64_t NextU64();
  /// Uniform integer in [0, bound), bound > 0 (Lemire's unbiased method).
  uint64_t UniformInt(uint64_t bound);
  /// Uniform double in [0, 1) with 53 random bits.
  double Uniform01();
  /// Uniform double in [lo, hi).
  double Uniform(double lo, double hi);
  /// Standard normal draw (Box-Muller on two Uniform01 draws; one draw per call, the second
  /// value is discarded so the stream position depends only on the number of calls).
  double Normal();
  /// Normal(0, sigma) truncated to [-limit, limit] by rejection (scipy's truncnorm(-a, a)
  /// scaled by sigma, a = limit / sigma). sigma <= 0 or limit <= 0 gives 0. When the bound
  /// is far in the tail (limit < 0.05 sigma) a uniform draw in [-limit, limit] stands in:
  /// the truncated density is flat there to within 0.1%.
  double TruncatedNormal(double sigma, double limit);

 private:
  uint64_t s_[4];
};

/// k distinct indices of [0, n) drawn by `rng` in a partial Fisher-Yates shuffle (step i swaps
/// slot i with slot i + UniformInt(n - i) and takes slot i), in draw order; all of [0, n) in
/// order, drawing nothing, when n <= k. O(k) memory for large n with small k.
MLSPACES_API std::vector<size_t> SampleIndices(Rng& rng, size_t n, size_t k);

}  // namespace mlspaces
