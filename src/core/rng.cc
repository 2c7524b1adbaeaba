#include "mlspaces/core/rng.h"

#include <cmath>
#include <numbers>
#include <numeric>
#include <unordered_map>

namespace mlspaces {
namespace {
inline uint64_t Rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
}  // namespace

uint64_t SplitMix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

uint64_t DeriveSeed(uint64_t seed, std::initializer_list<uint64_t> parts) {
  uint64_t state = seed;
  uint64_t out = SplitMix64(state);
  for (uint64_t part : parts) {
    state = out ^ part;
    out = SplitMix64(state);
  }
  return out;
}

uint64_t HashString(std::string_view text) {
  uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : text) {
    h ^= c;
    h *= 0x100000001b3ULL;
  }
  return h;
}

Rng::Rng(uint64_t seed) {
  uint64_t state = seed;
  for (auto& s : s_) s = SplitMix64(state);
}

uint64_t Rng::NextU64() {
  const uint64_t result = Rotl(s_[1] * 5, 7) * 9;
  const uint64_t t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = Rotl(s_[3], 45);
  return result;
}

uint64_t Rng::UniformInt(uint64_t bound) {
  // Lemire's nearly-divisionless unbiased method.
  unsigned __int128 m = static_cast<unsigned __int128>(NextU64()) * bound;
  uint64_t low = static_cast<uint64_t>(m);
  if (low < bound) {
    uint64_t threshold = (0 - bound) % bound;
    while (low < threshold) {
      m = static_cast<unsigned __int128>(NextU64()) * bound;
      low = static_cast<uint64_t>(m);
    }
  }
  return static_cast<uint64_t>(m >> 64);
}

double Rng::Uniform01() { return static_cast<double>(NextU64() >> 11) * 0x1.0p-53; }

double Rng::Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform01(); }

double Rng::Normal() {
  // 1 - u is in (0, 1]: log never sees 0.
  const double u1 = 1.0 - Uniform01();
  const double u2 = Uniform01();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

double Rng::TruncatedNormal(double sigma, double limit) {
  if (!(sigma > 0) || !(limit > 0)) return 0.0;
  if (limit < 0.05 * sigma) return Uniform(-limit, limit);
  // Acceptance >= P(|Z| < 0.05) ~ 4%; typical bounds accept far more often.
  for (;;) {
    const double x = sigma * Normal();
    if (std::abs(x) <= limit) return x;
  }
}

std::vector<size_t> SampleIndices(Rng& rng, size_t n, size_t k) {
  std::vector<size_t> out;
  if (n <= k) {
    out.resize(n);
    std::iota(out.begin(), out.end(), size_t{0});
    return out;
  }
  // Partial Fisher-Yates: step i swaps slot i with slot i + UniformInt(n - i) and emits slot i.
  // Large n with small k keeps only the displaced slots (same draws, same result).
  out.reserve(k);
  if (n <= 4096 || n <= 8 * k) {
    std::vector<size_t> slots(n);
    std::iota(slots.begin(), slots.end(), size_t{0});
    for (size_t i = 0; i < k; ++i) {
      const size_t j = i + static_cast<size_t>(rng.UniformInt(n - i));
      std::swap(slots[i], slots[j]);
      out.push_back(slots[i]);
    }
    return out;
  }
  std::unordered_map<size_t, size_t> displaced;
  displaced.reserve(2 * k);
  auto slot = [&](size_t i) {
    auto it = displaced.find(i);
    return it == displaced.end() ? i : it->second;
  };
  for (size_t i = 0; i < k; ++i) {
    const size_t j = i + static_cast<size_t>(rng.UniformInt(n - i));
    const size_t vi = slot(i), vj = slot(j);
    displaced[j] = vi;
    out.push_back(vj);
  }
  return out;
}

}  // namespace mlspaces
