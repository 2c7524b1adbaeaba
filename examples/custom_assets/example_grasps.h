// The example grasp library's only grasp: a top-down grasp at the red block's centre, as the
// MolmoSpaces custom-asset tutorial writes it with np.savez.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "mlspaces/core/npy.h"

namespace mlspaces::examples {

/// The arrays of red_block/droid/grasps.npz: "transforms", float64, shape (1, 4, 4).
/// Rotation columns x = (1,0,0), y = (0,-1,0), z = (0,0,-1) (approach straight down);
/// translation 0.
inline std::vector<std::pair<std::string, NpyArray>> RedBlockGrasps() {
  const double pose[16] = {
      1, 0,  0,  0,  //
      0, -1, 0,  0,  //
      0, 0,  -1, 0,  //
      0, 0,  0,  1,  //
  };
  std::vector<std::pair<std::string, NpyArray>> arrays;
  arrays.emplace_back("transforms", NpyArray::FromDoubles({1, 4, 4}, pose));
  return arrays;
}

}  // namespace mlspaces::examples
