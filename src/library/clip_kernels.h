// Internal to the CLIP store: float16 conversions and the scan kernels (clip_kernels.cc), with
// an AVX2+F16C+FMA version chosen at run time and a portable fallback.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

#include "mlspaces/core/npy.h"

namespace mlspaces::clip {

/// IEEE binary16 -> float (exact): core's (mlspaces/core/npy.h).
using ::mlspaces::HalfToFloat;
/// float -> IEEE binary16, round to nearest even (numpy's astype(float16)); Inf/NaN kept.
uint16_t FloatToHalf(float f);

/// Scores `rows` consecutive records starting at `rec`, each (views + 1) * dim halves (views
/// image vectors, then the text vector): out[r] = max_v dot(img_v, q) + 0.5 * dot(text, q).
/// `q` holds dim floats.
using ScoreRowsFn = void (*)(const uint16_t* rec, size_t rows, size_t views, size_t dim,
                             const float* q, float* out);
/// Approximate pass: out[r] = scale[r] * dot(codes + r * m, pq) for int8 codes of length m.
using ApproxRowsFn = void (*)(const int8_t* codes, const float* scale, size_t rows, size_t m,
                              const float* pq, float* out);

/// Upper-bound pass (docs/search.md "Exact queries without a full scan"): for each of `rows`
/// records, `vecs` = views + 1 int8 codes of length m (`codes`, record-major) and 2 floats per
/// vector (`params`: scale s, residual norm ||d||). With the query's int8 code `wq` and
/// k = {sw, ||q|| + ||delta||, 1.001 ||delta||}, each vector's bound is
///   s * sw * <code, wq> + ||d|| * k[1] + k[2],
/// and out[r] = max over the image vectors + 0.5 * the text vector's (no slack added).
using BoundRowsFn = void (*)(const int8_t* codes, const float* params, size_t rows, size_t vecs,
                             size_t m, const int8_t* wq, const float* k, float* out);

struct Kernels {
  ScoreRowsFn score;
  ApproxRowsFn approx;
  BoundRowsFn bound;
  std::string_view name;
};

/// The fastest kernels this CPU runs (decided once).
const Kernels& BestKernels();
/// The portable kernels (tests compare both).
const Kernels& PortableKernels();

}  // namespace mlspaces::clip
