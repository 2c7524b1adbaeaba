// Grasp sets: reading grasp poses from a grasp NPZ or a packed store's grasp shard, the
// seeded subsampling every lookup uses, and grasps in the world frame. Registry::LoadGrasps
// finds the file and calls these; they are public for `pack`, tests and benchmarks.
#pragma once

#include "mlspaces/core/export.h"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "mlspaces/core/npy.h"
#include "mlspaces/core/transform.h"

namespace mlspaces {

class PackedLibrary;
struct PackedGraspRef;

/// N grasp poses, in the object body frame (pickup) or the joint's body frame (joint).
struct MLSPACES_API GraspSet {
  std::vector<Mat4> poses;
  std::filesystem::path source;  ///< the NPZ they came from, or the packed grasp shard
  std::vector<size_t> indices;   ///< row of each pose in the file
  DType stored_dtype = DType::kF8;
};

/// Loads every row of transforms.npy from a grasp NPZ (or `rows` of them, in that order),
/// checking the shape is (N,4,4) and values are finite. @throws Error naming the file.
MLSPACES_API GraspSet ReadGraspFile(const std::filesystem::path& npz,
                                    const std::vector<size_t>* rows = nullptr);

/// Number of grasps (rows of transforms.npy) in a grasp NPZ; reads the header only.
/// @throws Error for a missing or corrupt file.
MLSPACES_API size_t CountGraspFileRows(const std::filesystem::path& npz);

/// Loads grasps from a grasp NPZ. If it has N <= num_grasps rows, all of them in file order;
/// else SubsampleIndices(N, num_grasps, seed) of them, in draw order (docs/formats.md).
/// @throws Error as ReadGraspFile.
MLSPACES_API GraspSet LoadGraspFile(const std::filesystem::path& npz, size_t num_grasps,
                                    uint64_t seed);

/// Chooses the rows a load reads, given the file's row count N: nullopt = all N in file order,
/// else the rows in the order wanted (each < N, else the load throws Error). The Python
/// binding draws them with Python's `random.sample`, as MolmoSpaces does.
using GraspRowChooser = std::function<std::optional<std::vector<size_t>>(size_t n)>;

/// The rows `choose` picks from a whole grasp set (ReadGraspFile's), copied in pick order;
/// all of them when it picks nullopt. @throws Error naming the source for a row out of range.
MLSPACES_API GraspSet SelectGraspRows(const GraspSet& all, const GraspRowChooser& choose);

/// The chooser of LoadGraspFile(npz, num_grasps, seed): all rows when N <= num_grasps, else
/// SubsampleIndices(N, num_grasps, seed).
MLSPACES_API GraspRowChooser SeededRowChooser(size_t num_grasps, uint64_t seed);

/// As LoadGraspFile, with the rows `choose` picks. @throws Error as ReadGraspFile.
MLSPACES_API GraspSet LoadGraspFile(const std::filesystem::path& npz,
                                    const GraspRowChooser& choose);

/// As LoadGraspFile, for a packed grasp ref of `library`: the same draws as from the NPZ the
/// poses were packed from. `source` becomes GraspSet::source. @throws Error when the shard
/// is not installed or is damaged.
MLSPACES_API GraspSet LoadPackedGrasps(const PackedLibrary& library, const PackedGraspRef& ref,
                                       const std::filesystem::path& source, size_t num_grasps,
                                       uint64_t seed);
/// As LoadPackedGrasps, with the rows `choose` picks.
MLSPACES_API GraspSet LoadPackedGrasps(const PackedLibrary& library, const PackedGraspRef& ref,
                                       const std::filesystem::path& source,
                                       const GraspRowChooser& choose);

/// Indices drawn for subsampling: SampleIndices(Rng(seed), n, k) (core/rng.h): all of [0, n)
/// when n <= k, else k distinct indices from a partial Fisher-Yates shuffle, in draw order.
MLSPACES_API std::vector<size_t> SubsampleIndices(size_t n, size_t k, uint64_t seed);

/// World-frame grasps W_i = body_pose * G_i; with `include_flipped`, followed by the
/// jaw-symmetric twins W_i * Rz(180 deg) (2N poses).
MLSPACES_API std::vector<Mat4> GraspsInWorld(const Mat4& body_pose, std::span<const Mat4> grasps,
                                             bool include_flipped = true);

}  // namespace mlspaces
