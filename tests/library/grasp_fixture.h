// Grasp fixture files shared by the registry and grasp-set suites.
#pragma once

#include <cstddef>
#include <filesystem>
#include <vector>

#include "mlspaces/core/npy.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/core/transform.h"

namespace mlspaces::testing {

/// Grasp k of a fixture file: identity rotation, translation (k, file_tag, 0).
inline Mat4 FixturePose(size_t k, double file_tag = 0) {
  Mat4 m;
  m(0, 3) = static_cast<double>(k);
  m(1, 3) = file_tag;
  return m;
}

/// A grasp NPZ of `n` FixturePoses under "transforms", stored as `dtype`.
inline void WriteGrasps(const std::filesystem::path& file, size_t n, double file_tag = 0,
                        DType dtype = DType::kF8, bool compress = false) {
  std::vector<double> values;
  for (size_t k = 0; k < n; ++k) {
    Mat4 m = FixturePose(k, file_tag);
    values.insert(values.end(), m.m.begin(), m.m.end());
  }
  std::filesystem::create_directories(file.parent_path());
  NpzWriteOptions options;
  options.compress = compress;
  WriteNpz(file, {{"transforms", NpyArray::FromDoubles(dtype, {n, 4, 4}, values)}}, options);
}

}  // namespace mlspaces::testing
