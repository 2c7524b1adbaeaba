// Scan kernels of the CLIP store (clip_kernels.h). The AVX2 path converts 8 halves at a time
// with F16C (vcvtph2ps) and accumulates with FMA in float32; the portable path converts through
// a table. Both sum in float32 but in different orders, so scores may differ in the last bits.
#include "clip_kernels.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#include <immintrin.h>
#define MLSPACES_CLIP_X86 1
#endif

namespace mlspaces::clip {
namespace {

const float* HalfTable() {
  static const std::vector<float> table = [] {
    std::vector<float> t(65536);
    for (uint32_t h = 0; h < 65536; ++h) t[h] = HalfToFloat(static_cast<uint16_t>(h));
    return t;
  }();
  return table.data();
}

void ScoreRowsPortable(const uint16_t* rec, size_t rows, size_t views, size_t dim, const float* q,
                       float* out) {
  const float* table = HalfTable();
  const size_t stride = (views + 1) * dim;
  for (size_t r = 0; r < rows; ++r, rec += stride) {
    float best = 0;
    for (size_t v = 0; v <= views; ++v) {
      const uint16_t* x = rec + v * dim;
      float acc[4] = {0, 0, 0, 0};
      size_t j = 0;
      for (; j + 4 <= dim; j += 4) {
        for (size_t k = 0; k < 4; ++k) acc[k] += table[x[j + k]] * q[j + k];
      }
      for (; j < dim; ++j) acc[0] += table[x[j]] * q[j];
      const float dot = (acc[0] + acc[1]) + (acc[2] + acc[3]);
      if (v == views) {
        best += 0.5f * dot;
      } else if (v == 0 || dot > best) {
        best = dot;
      }
    }
    out[r] = best;
  }
}

void ApproxRowsPortable(const int8_t* codes, const float* scale, size_t rows, size_t m,
                        const float* pq, float* out) {
  for (size_t r = 0; r < rows; ++r, codes += m) {
    float acc = 0;
    for (size_t j = 0; j < m; ++j) acc += static_cast<float>(codes[j]) * pq[j];
    out[r] = scale[r] * acc;
  }
}

// Combines the per-vector dot products of one record into its bound (shared by both kernels).
inline float RecordBound(const int32_t* dots, const float* params, size_t vecs, const float* k) {
  float best = 0;
  for (size_t v = 0; v < vecs; ++v) {
    const float* p = params + 2 * v;
    const float b = p[0] * (k[0] * static_cast<float>(dots[v])) + p[1] * k[1] + k[2];
    if (v + 1 == vecs) {
      best += 0.5f * b;
    } else if (v == 0 || b > best) {
      best = b;
    }
  }
  return best;
}

constexpr size_t kMaxVecs = 65;  // views <= 64

void BoundRowsPortable(const int8_t* codes, const float* params, size_t rows, size_t vecs, size_t m,
                       const int8_t* wq, const float* k, float* out) {
  int32_t dots[kMaxVecs];
  for (size_t r = 0; r < rows; ++r, params += 2 * vecs) {
    for (size_t v = 0; v < vecs; ++v, codes += m) {
      int32_t acc = 0;
      for (size_t j = 0; j < m; ++j) acc += static_cast<int32_t>(codes[j]) * wq[j];
      dots[v] = acc;
    }
    out[r] = RecordBound(dots, params, vecs, k);
  }
}

#ifdef MLSPACES_CLIP_X86
__attribute__((target("avx2,f16c,fma"))) inline float HorizontalSum(__m256 v) {
  const __m128 lo = _mm256_castps256_ps128(v), hi = _mm256_extractf128_ps(v, 1);
  __m128 s = _mm_add_ps(lo, hi);
  s = _mm_add_ps(s, _mm_movehl_ps(s, s));
  s = _mm_add_ss(s, _mm_movehdup_ps(s));
  return _mm_cvtss_f32(s);
}

__attribute__((target("avx2,f16c,fma"))) float DotHalf(const uint16_t* x, const float* q,
                                                       size_t dim) {
  __m256 a0 = _mm256_setzero_ps(), a1 = a0, a2 = a0, a3 = a0;
  size_t j = 0;
  for (; j + 32 <= dim; j += 32) {
    const __m256i h01 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(x + j));
    const __m256i h23 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(x + j + 16));
    a0 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_castsi256_si128(h01)), _mm256_loadu_ps(q + j), a0);
    a1 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_extracti128_si256(h01, 1)),
                         _mm256_loadu_ps(q + j + 8), a1);
    a2 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_castsi256_si128(h23)), _mm256_loadu_ps(q + j + 16),
                         a2);
    a3 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_extracti128_si256(h23, 1)),
                         _mm256_loadu_ps(q + j + 24), a3);
  }
  for (; j + 8 <= dim; j += 8) {
    const __m128i h = _mm_loadu_si128(reinterpret_cast<const __m128i*>(x + j));
    a0 = _mm256_fmadd_ps(_mm256_cvtph_ps(h), _mm256_loadu_ps(q + j), a0);
  }
  float dot = HorizontalSum(_mm256_add_ps(_mm256_add_ps(a0, a1), _mm256_add_ps(a2, a3)));
  for (; j < dim; ++j) dot += HalfToFloat(x[j]) * q[j];
  return dot;
}

// Three views + text (the objathor shape): the four dot products in one pass, each query load
// shared by four vectors, eight independent accumulator chains.
__attribute__((target("avx2,f16c,fma"))) void ScoreRows3Avx2(const uint16_t* rec, size_t rows,
                                                             size_t dim, const float* q,
                                                             float* out) {
  const size_t stride = 4 * dim;
  for (size_t r = 0; r < rows; ++r, rec += stride) {
    _mm_prefetch(reinterpret_cast<const char*>(rec + 2 * stride), _MM_HINT_T0);
    // Written out (not a loop over v): the accumulators must stay in registers.
    __m256 a0 = _mm256_setzero_ps(), a1 = a0, b0 = a0, b1 = a0, c0 = a0, c1 = a0, t0 = a0, t1 = a0;
    const uint16_t *x0 = rec, *x1 = rec + dim, *x2 = rec + 2 * dim, *xt = rec + 3 * dim;
    for (size_t j = 0; j < dim; j += 16) {
      const __m256 q0 = _mm256_loadu_ps(q + j), q1 = _mm256_loadu_ps(q + j + 8);
      const __m256i h0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(x0 + j));
      const __m256i h1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(x1 + j));
      const __m256i h2 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(x2 + j));
      const __m256i ht = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(xt + j));
      a0 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_castsi256_si128(h0)), q0, a0);
      a1 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_extracti128_si256(h0, 1)), q1, a1);
      b0 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_castsi256_si128(h1)), q0, b0);
      b1 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_extracti128_si256(h1, 1)), q1, b1);
      c0 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_castsi256_si128(h2)), q0, c0);
      c1 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_extracti128_si256(h2, 1)), q1, c1);
      t0 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_castsi256_si128(ht)), q0, t0);
      t1 = _mm256_fmadd_ps(_mm256_cvtph_ps(_mm256_extracti128_si256(ht, 1)), q1, t1);
    }
    const float dot[4] = {
        HorizontalSum(_mm256_add_ps(a0, a1)), HorizontalSum(_mm256_add_ps(b0, b1)),
        HorizontalSum(_mm256_add_ps(c0, c1)), HorizontalSum(_mm256_add_ps(t0, t1))};
    out[r] = std::max(std::max(dot[0], dot[1]), dot[2]) + 0.5f * dot[3];
  }
}

__attribute__((target("avx2,f16c,fma"))) void ScoreRowsAvx2(const uint16_t* rec, size_t rows,
                                                            size_t views, size_t dim,
                                                            const float* q, float* out) {
  if (views == 3 && dim % 16 == 0) return ScoreRows3Avx2(rec, rows, dim, q, out);
  const size_t stride = (views + 1) * dim;
  for (size_t r = 0; r < rows; ++r, rec += stride) {
    // Ask for the record after next early: the hardware prefetcher follows the stream, this
    // only covers the first lines of each record.
    _mm_prefetch(reinterpret_cast<const char*>(rec + 2 * stride), _MM_HINT_T0);
    float best = DotHalf(rec, q, dim);
    for (size_t v = 1; v < views; ++v) best = std::max(best, DotHalf(rec + v * dim, q, dim));
    out[r] = best + 0.5f * DotHalf(rec + views * dim, q, dim);
  }
}

__attribute__((target("avx2,f16c,fma"))) void ApproxRowsAvx2(const int8_t* codes,
                                                             const float* scale, size_t rows,
                                                             size_t m, const float* pq,
                                                             float* out) {
  for (size_t r = 0; r < rows; ++r, codes += m) {
    __m256 a0 = _mm256_setzero_ps(), a1 = a0;
    size_t j = 0;
    for (; j + 16 <= m; j += 16) {
      const __m128i c = _mm_loadu_si128(reinterpret_cast<const __m128i*>(codes + j));
      const __m256 lo = _mm256_cvtepi32_ps(_mm256_cvtepi8_epi32(c));
      const __m256 hi = _mm256_cvtepi32_ps(_mm256_cvtepi8_epi32(_mm_srli_si128(c, 8)));
      a0 = _mm256_fmadd_ps(lo, _mm256_loadu_ps(pq + j), a0);
      a1 = _mm256_fmadd_ps(hi, _mm256_loadu_ps(pq + j + 8), a1);
    }
    float acc = HorizontalSum(_mm256_add_ps(a0, a1));
    for (; j < m; ++j) acc += static_cast<float>(codes[j]) * pq[j];
    out[r] = scale[r] * acc;
  }
}

// int8 x int8 by vpmaddubsw on (|c|, sign(c) * q) (pair sums <= 2 * 127 * 127: no int16
// saturation), widened to int32 by vpmaddwd: exact int32 sums, 32 values per step.
__attribute__((target("avx2,f16c,fma"))) void BoundRowsAvx2(const int8_t* codes,
                                                            const float* params, size_t rows,
                                                            size_t vecs, size_t m, const int8_t* wq,
                                                            const float* k, float* out) {
  int32_t dots[kMaxVecs];
  const __m256i ones = _mm256_set1_epi16(1);
  for (size_t r = 0; r < rows; ++r, params += 2 * vecs) {
    for (size_t v = 0; v < vecs; ++v, codes += m) {
      __m256i acc = _mm256_setzero_si256();
      size_t j = 0;
      for (; j + 32 <= m; j += 32) {
        const __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(codes + j));
        const __m256i w = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(wq + j));
        const __m256i pairs = _mm256_maddubs_epi16(_mm256_sign_epi8(c, c), _mm256_sign_epi8(w, c));
        acc = _mm256_add_epi32(acc, _mm256_madd_epi16(pairs, ones));
      }
      __m128i s = _mm_add_epi32(_mm256_castsi256_si128(acc), _mm256_extracti128_si256(acc, 1));
      s = _mm_add_epi32(s, _mm_shuffle_epi32(s, 0x4e));
      s = _mm_add_epi32(s, _mm_shuffle_epi32(s, 0xb1));
      int32_t dot = _mm_cvtsi128_si32(s);
      for (; j < m; ++j) dot += static_cast<int32_t>(codes[j]) * wq[j];
      dots[v] = dot;
    }
    out[r] = RecordBound(dots, params, vecs, k);
  }
}
#endif

}  // namespace

uint16_t FloatToHalf(float f) {
  const uint32_t x = std::bit_cast<uint32_t>(f);
  const uint16_t sign = static_cast<uint16_t>((x >> 16) & 0x8000u);
  const uint32_t abs = x & 0x7fffffffu;
  if (abs >= 0x7f800000u) {  // Inf, NaN (keep a quiet NaN)
    return static_cast<uint16_t>(sign | 0x7c00u | (abs > 0x7f800000u ? 0x200u : 0u));
  }
  if (abs >= 0x477ff000u) return static_cast<uint16_t>(sign | 0x7c00u);  // rounds to Inf
  if (abs < 0x38800000u) {               // below the smallest normal half: subnormal or zero
    if (abs < 0x33000000u) return sign;  // < half of the smallest subnormal: 0
    const uint32_t e = abs >> 23;
    const uint32_t mant = (abs & 0x7fffffu) | 0x800000u;
    const uint32_t shift = 126 - e;  // 14..24 bits dropped
    const uint32_t halfway = 1u << (shift - 1);
    uint32_t q = mant >> shift;
    const uint32_t rest = mant & ((1u << shift) - 1);
    if (rest > halfway || (rest == halfway && (q & 1u))) ++q;
    return static_cast<uint16_t>(sign | q);
  }
  uint32_t bits = abs - 0x38000000u;  // rebias 127 -> 15 (exponent field moves by 112 << 23)
  const uint32_t rest = bits & 0x1fffu;
  uint32_t q = bits >> 13;
  if (rest > 0x1000u || (rest == 0x1000u && (q & 1u))) ++q;  // may carry into the exponent
  return static_cast<uint16_t>(sign | q);
}

const Kernels& PortableKernels() {
  static const Kernels k{&ScoreRowsPortable, &ApproxRowsPortable, &BoundRowsPortable, "portable"};
  return k;
}

const Kernels& BestKernels() {
#ifdef MLSPACES_CLIP_X86
  static const bool avx2 = [] {
    // F16C is read from CPUID leaf 1 (ECX bit 29): clang 14's __builtin_cpu_supports does
    // not know "f16c", and the fuzz build uses clang.
    __builtin_cpu_init();
    unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
    const bool f16c = __get_cpuid(1, &eax, &ebx, &ecx, &edx) != 0 && (ecx & bit_F16C) != 0;
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && f16c;
  }();
  static const Kernels k{&ScoreRowsAvx2, &ApproxRowsAvx2, &BoundRowsAvx2, "avx2+f16c+fma"};
  if (avx2) return k;
#endif
  return PortableKernels();
}

}  // namespace mlspaces::clip
