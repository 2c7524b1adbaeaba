// Grasp generation, test order: candidates ordered to cover the object (spec section 2.5.4):
// k-means clusters of [position, rotation vector] (each column scaled by its spread), inside each
// cluster a random order weighted toward the preferred contact depth, then round-robin over the
// clusters. Seeded: the same candidates and seed give the same order.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <vector>

#include "mlspaces/graspgen/antipodal.h"

namespace mlspaces::graspgen {

/// The ordering settings (defaults: the original runners').
struct MLSPACES_API OrderParams {
  int clusters = 40;       ///< k = min(clusters, candidates)
  double min_depth = 0.0;  ///< candidates outside [min_depth, max_depth] are left out
  double max_depth = 1.0;
  double center_depth = 0.75;  ///< weight = (1 / (|depth - center| + 0.001)) ^ bias
  double depth_bias = 2.8;
  int kmeans_iterations = 100;  ///< Lloyd iterations at most (stops when labels settle)
};

/// Cluster label (0 .. k-1) of each candidate: seeded k-means++ then Lloyd iterations on the
/// 6-D features; clusters numbered by their first candidate's index.
MLSPACES_API std::vector<int> ClusterCandidates(const std::vector<GraspCandidate>& candidates,
                                                int clusters, int iterations, uint64_t seed);

/// Indices of the candidates in test order (those inside the depth range, each once).
MLSPACES_API std::vector<size_t> OrderCandidates(const std::vector<GraspCandidate>& candidates,
                                                 const OrderParams& params, uint64_t seed);

}  // namespace mlspaces::graspgen
