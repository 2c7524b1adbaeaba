// Candidate test order (include/mlspaces/graspgen/ordering.h).
#include "mlspaces/graspgen/ordering.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "mlspaces/core/rng.h"

namespace mlspaces::graspgen {
namespace {

using Feature = std::array<double, 6>;

// [position, rotation vector] of each candidate, each column divided by (its std + 1e-6).
std::vector<Feature> Features(const std::vector<GraspCandidate>& c) {
  std::vector<Feature> f(c.size());
  for (size_t i = 0; i < c.size(); ++i) {
    const Quat q = QuatFromMat4(c[i].tcp);  // w >= 0
    const double s = std::sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    const double k = s > 1e-12 ? 2 * std::atan2(s, q[0]) / s : 2.0;
    f[i] = {c[i].tcp(0, 3), c[i].tcp(1, 3), c[i].tcp(2, 3), k * q[1], k * q[2], k * q[3]};
  }
  for (int j = 0; j < 6; ++j) {
    double mean = 0, var = 0;
    for (const Feature& x : f) mean += x[j];
    mean /= std::max<size_t>(1, f.size());
    for (const Feature& x : f) var += (x[j] - mean) * (x[j] - mean);
    const double scale = std::sqrt(var / std::max<size_t>(1, f.size())) + 1e-6;
    for (Feature& x : f) x[j] /= scale;
  }
  return f;
}

double Dist2(const Feature& a, const Feature& b) {
  double d = 0;
  for (int j = 0; j < 6; ++j) d += (a[j] - b[j]) * (a[j] - b[j]);
  return d;
}

}  // namespace

std::vector<int> ClusterCandidates(const std::vector<GraspCandidate>& candidates, int clusters,
                                   int iterations, uint64_t seed) {
  const size_t n = candidates.size();
  std::vector<int> label(n, 0);
  if (n == 0) return label;
  const size_t k = std::clamp<size_t>(static_cast<size_t>(std::max(1, clusters)), 1, n);
  const std::vector<Feature> f = Features(candidates);
  // k-means++ seeding.
  Rng rng(seed);
  std::vector<Feature> centers{f[rng.UniformInt(n)]};
  std::vector<double> d2(n);
  for (size_t i = 0; i < n; ++i) d2[i] = Dist2(f[i], centers[0]);
  while (centers.size() < k) {
    double total = 0;
    for (double d : d2) total += d;
    size_t pick = rng.UniformInt(n);
    if (total > 0) {
      double x = rng.Uniform01() * total;
      for (pick = 0; pick + 1 < n && x >= d2[pick]; ++pick) x -= d2[pick];
    }
    centers.push_back(f[pick]);
    for (size_t i = 0; i < n; ++i) d2[i] = std::min(d2[i], Dist2(f[i], centers.back()));
  }
  // Lloyd iterations; an empty cluster keeps its centre.
  for (int it = 0; it <= iterations; ++it) {
    bool changed = it == 0;
    for (size_t i = 0; i < n; ++i) {
      int best = 0;
      double bd = std::numeric_limits<double>::infinity();
      for (size_t c = 0; c < k; ++c) {
        const double d = Dist2(f[i], centers[c]);
        if (d < bd) bd = d, best = static_cast<int>(c);
      }
      changed |= label[i] != best;
      label[i] = best;
    }
    if (!changed || it == iterations) break;
    std::vector<Feature> sum(k, Feature{});
    std::vector<size_t> count(k, 0);
    for (size_t i = 0; i < n; ++i) {
      for (int j = 0; j < 6; ++j) sum[label[i]][j] += f[i][j];
      ++count[label[i]];
    }
    for (size_t c = 0; c < k; ++c) {
      if (count[c] == 0) continue;
      for (int j = 0; j < 6; ++j) centers[c][j] = sum[c][j] / count[c];
    }
  }
  // Renumber by first appearance.
  std::vector<int> renumber(k, -1);
  int next = 0;
  for (int& l : label) {
    if (renumber[l] < 0) renumber[l] = next++;
    l = renumber[l];
  }
  return label;
}

std::vector<size_t> OrderCandidates(const std::vector<GraspCandidate>& candidates,
                                    const OrderParams& params, uint64_t seed) {
  std::vector<GraspCandidate> kept;
  std::vector<size_t> index;
  for (size_t i = 0; i < candidates.size(); ++i) {
    const double d = candidates[i].depth;
    if (d < params.min_depth || d > params.max_depth) continue;
    kept.push_back(candidates[i]);
    index.push_back(i);
  }
  if (kept.empty()) return {};
  const std::vector<int> label =
      ClusterCandidates(kept, params.clusters, params.kmeans_iterations, DeriveSeed(seed, {1}));
  const int k = *std::max_element(label.begin(), label.end()) + 1;
  // Weighted random order without replacement (Efraimidis-Spirakis keys log(u) / w, largest
  // first): the same distribution as drawing one by one with probability proportional to w.
  Rng rng(DeriveSeed(seed, {2}));
  std::vector<std::vector<std::pair<double, size_t>>> members(k);
  for (size_t i = 0; i < kept.size(); ++i) {
    const double w =
        std::pow(1 / (std::abs(kept[i].depth - params.center_depth) + 0.001), params.depth_bias);
    const double u = 1 - rng.Uniform01();  // (0, 1]
    members[label[i]].push_back({std::log(u) / w, i});
  }
  for (auto& m : members) {
    std::sort(m.begin(), m.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
  }
  std::vector<size_t> order;
  order.reserve(kept.size());
  for (size_t round = 0; order.size() < kept.size(); ++round) {
    for (const auto& m : members) {
      if (round < m.size()) order.push_back(index[m[round].second]);
    }
  }
  return order;
}

}  // namespace mlspaces::graspgen
