// Grasp sets (include/mlspaces/library/grasp_set.h): grasp NPZ and packed-shard reading,
// seeded subsampling, world-frame grasps.
#include "mlspaces/library/grasp_set.h"

#include <cmath>
#include <cstring>
#include <numeric>
#include <string>
#include <string_view>
#include <utility>

#include "mlspaces/core/error.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/library/packed_store.h"

namespace mlspaces {
namespace fs = std::filesystem;

namespace {

constexpr std::string_view kTransformsKey = "transforms";
constexpr std::string_view kTransformsMember = "transforms.npy";

/// Checks a transforms.npy header; returns N.
size_t CheckGraspHeader(const NpyHeader& header, const fs::path& npz) {
  if (header.shape.size() != 3 || header.shape[1] != 4 || header.shape[2] != 4) {
    throw Error("grasp transforms must have shape (N, 4, 4), got " + ShapeRepr(header.shape),
                npz.string(), std::string(kTransformsMember));
  }
  if (header.dtype == DType::kB1) {
    throw Error("grasp transforms must be numeric, got dtype " + DTypeDescr(header.dtype),
                npz.string(), std::string(kTransformsMember));
  }
  return header.shape[0];
}

NpyHeader ReadGraspHeader(const NpzReader& reader) {
  if (!reader.Contains(kTransformsKey)) {
    throw Error("grasp file has no transforms.npy array", reader.path().string());
  }
  NpyHeader header = reader.ReadHeader(kTransformsKey);
  CheckGraspHeader(header, reader.path());
  return header;
}

/// Reads all rows (rows == nullptr) or `rows` of an already checked transforms array.
GraspSet ReadGrasps(const NpzReader& reader, const NpyHeader& header,
                    const std::vector<size_t>* rows) {
  const size_t n = header.shape[0];
  GraspSet out;
  out.source = reader.path();
  out.stored_dtype = header.dtype;
  NpyArray array;
  if (rows != nullptr) {
    for (size_t r : *rows) {
      if (r >= n) {
        throw Error(
            "grasp row " + std::to_string(r) + " out of range (file has " + std::to_string(n) + ")",
            reader.path().string(), std::string(kTransformsMember));
      }
    }
    out.indices = *rows;
    array = reader.ReadRows(kTransformsKey, *rows);
  } else {
    out.indices.resize(n);
    std::iota(out.indices.begin(), out.indices.end(), size_t{0});
    array = reader.Read(kTransformsKey);
  }
  const size_t count = out.indices.size();
  if (array.num_elements() != count * 16) {
    throw Error("grasp transforms: read " + std::to_string(array.num_elements()) +
                    " values, expected " + std::to_string(count * 16),
                reader.path().string(), std::string(kTransformsMember));
  }
  out.poses.resize(count);
  const bool f8 = array.dtype == DType::kF8;
  for (size_t i = 0; i < count; ++i) {
    Mat4& pose = out.poses[i];
    if (f8) {
      std::memcpy(pose.m.data(), array.data.data() + i * 16 * sizeof(double), 16 * sizeof(double));
    } else {
      for (size_t k = 0; k < 16; ++k) pose.m[k] = array.AsDouble(i * 16 + k);
    }
    for (double v : pose.m) {
      if (!std::isfinite(v)) {
        throw Error("grasp " + std::to_string(out.indices[i]) + " has a non-finite value",
                    reader.path().string(), std::string(kTransformsMember));
      }
    }
  }
  return out;
}

}  // namespace

GraspSet ReadGraspFile(const fs::path& npz, const std::vector<size_t>* rows) {
  NpzReader reader(npz);
  const NpyHeader header = ReadGraspHeader(reader);
  return ReadGrasps(reader, header, rows);
}

size_t CountGraspFileRows(const fs::path& npz) {
  NpzReader reader(npz);
  return ReadGraspHeader(reader).shape[0];
}

GraspSet SelectGraspRows(const GraspSet& all, const GraspRowChooser& choose) {
  const size_t n = all.poses.size();
  std::optional<std::vector<size_t>> rows = choose(n);
  if (!rows) return all;
  GraspSet out;
  out.source = all.source;
  out.stored_dtype = all.stored_dtype;
  out.poses.reserve(rows->size());
  for (size_t r : *rows) {
    if (r >= n) {
      throw Error(
          "grasp row " + std::to_string(r) + " out of range (file has " + std::to_string(n) + ")",
          all.source.string(), std::string(kTransformsMember));
    }
    out.poses.push_back(all.poses[r]);
  }
  out.indices = std::move(*rows);
  return out;
}

GraspRowChooser SeededRowChooser(size_t num_grasps, uint64_t seed) {
  return [num_grasps, seed](size_t n) -> std::optional<std::vector<size_t>> {
    if (n <= num_grasps) return std::nullopt;
    return SubsampleIndices(n, num_grasps, seed);
  };
}

GraspSet LoadGraspFile(const fs::path& npz, const GraspRowChooser& choose) {
  NpzReader reader(npz);
  const NpyHeader header = ReadGraspHeader(reader);
  const std::optional<std::vector<size_t>> rows = choose(header.shape[0]);
  return ReadGrasps(reader, header, rows ? &*rows : nullptr);
}

GraspSet LoadGraspFile(const fs::path& npz, size_t num_grasps, uint64_t seed) {
  return LoadGraspFile(npz, SeededRowChooser(num_grasps, seed));
}

GraspSet LoadPackedGrasps(const PackedLibrary& library, const PackedGraspRef& ref,
                          const fs::path& source, const GraspRowChooser& choose) {
  const size_t n = ref.count;
  GraspSet out;
  out.source = source;
  out.stored_dtype = ref.stored_dtype;
  std::optional<std::vector<size_t>> rows = choose(n);
  if (!rows) {
    out.poses = library.ReadGrasps(ref);
    out.indices.resize(n);
    std::iota(out.indices.begin(), out.indices.end(), size_t{0});
    return out;
  }
  for (size_t r : *rows) {
    if (r >= n) {
      throw Error("grasp row " + std::to_string(r) + " out of range (library holds " +
                      std::to_string(n) + ")",
                  source.string());
    }
  }
  out.indices = std::move(*rows);
  out.poses = library.ReadGrasps(ref, &out.indices);
  return out;
}

GraspSet LoadPackedGrasps(const PackedLibrary& library, const PackedGraspRef& ref,
                          const fs::path& source, size_t num_grasps, uint64_t seed) {
  return LoadPackedGrasps(library, ref, source, SeededRowChooser(num_grasps, seed));
}

std::vector<size_t> SubsampleIndices(size_t n, size_t k, uint64_t seed) {
  Rng rng(seed);
  return SampleIndices(rng, n, k);
}

std::vector<Mat4> GraspsInWorld(const Mat4& body_pose, std::span<const Mat4> grasps,
                                bool include_flipped) {
  std::vector<Mat4> out;
  out.reserve(grasps.size() * (include_flipped ? 2 : 1));
  for (const Mat4& g : grasps) out.push_back(body_pose * g);
  if (include_flipped) {
    // W * Rz(180 deg) with the exact rotation diag(-1, -1, 1): negate the x and y columns.
    for (size_t i = 0; i < grasps.size(); ++i) {
      Mat4 flipped = out[i];
      for (int r = 0; r < 3; ++r) {
        flipped(r, 0) = -flipped(r, 0);
        flipped(r, 1) = -flipped(r, 1);
      }
      out.push_back(flipped);
    }
  }
  return out;
}

}  // namespace mlspaces
