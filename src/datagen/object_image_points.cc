#include "mlspaces/datagen/object_image_points.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numeric>
#include <utility>

#include "mlspaces/core/error.h"

namespace mlspaces::datagen {
namespace {

constexpr char kGroup[] = "object_image_points/";

// numpy.round(x, 4) on float32: x * 10000, rint (half to even), / 10000, each in float32.
float Round4(float x) {
  const float scaled = x * 10000.0f;
  return std::nearbyint(scaled) / 10000.0f;
}

void CheckMaskSize(const char* where, const std::vector<unsigned char>& mask, int width,
                   int height) {
  if (width < 0 || height < 0 ||
      mask.size() != static_cast<size_t>(width) * static_cast<size_t>(height)) {
    throw UsageError(std::string(where) + ": the mask holds " + std::to_string(mask.size()) +
                     " pixels, not " + std::to_string(width) + "x" + std::to_string(height));
  }
}

// The positions of the set (non-zero) bytes of `mask` whose ordinals in row-major order are
// `ordinals` (each below the number of set bytes), in the order given.
std::vector<uint32_t> NthSetPixels(const std::vector<unsigned char>& mask,
                                   const std::vector<size_t>& ordinals) {
  std::vector<size_t> order(ordinals.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return ordinals[a] < ordinals[b]; });
  std::vector<uint32_t> out(ordinals.size());
  constexpr size_t kBlock = 256;  // counted at once, walked only where an ordinal falls
  size_t seen = 0, next = 0;
  for (size_t start = 0; start < mask.size() && next < order.size(); start += kBlock) {
    const size_t end = std::min(mask.size(), start + kBlock);
    size_t in_block = 0;
    for (size_t i = start; i < end; ++i) in_block += mask[i] != 0 ? 1 : 0;
    if (ordinals[order[next]] >= seen + in_block) {
      seen += in_block;
      continue;
    }
    for (size_t i = start; i < end && next < order.size(); ++i) {
      if (mask[i] == 0) continue;
      while (next < order.size() && ordinals[order[next]] == seen) {
        out[order[next++]] = static_cast<uint32_t>(i);
      }
      ++seen;
    }
  }
  return out;
}

}  // namespace

Rng ImagePointsRng(uint64_t episode_seed) {
  return Rng(DeriveSeed(episode_seed, {0x706f696e7473ULL}));  // "points"
}

std::vector<TrackedObject> TaskObjects(const mjModel* m, const Task& task, const TaskConfig& config,
                                       const std::string& gripper_body) {
  std::vector<TrackedObject> out{{"gripper", gripper_body}};
  std::vector<std::string> added;
  for (const auto& [name, _] : config.added_objects) {
    if (mj_name2id(m, mjOBJ_BODY, name.c_str()) >= 0) added.push_back(name);
  }
  if (task.place) {
    for (const std::string& r : task.place->other_receptacles) added.push_back(r);
  }
  for (size_t k = 0; k < added.size(); ++k) {
    out.push_back({"added_" + std::to_string(k), added[k]});
  }
  // The original's deduplicate_task_objects_name: the role replaces any key of its body.
  auto assign = [&out](const std::string& key, const std::string& body) {
    std::erase_if(out, [&](const TrackedObject& o) { return o.body == body; });
    out.push_back({key, body});
  };
  assign("pickup_obj", task.pickup_obj_name);
  if (task.place) assign("place_receptacle", task.place->receptacle);
  return out;
}

bool TracksObjectsIn(std::string_view camera_name) {
  std::string lower(camera_name);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower.find("follower") == std::string::npos;
}

std::vector<unsigned char> ErodeMask(const std::vector<unsigned char>& mask, int width, int height,
                                     int iterations) {
  CheckMaskSize("ErodeMask", mask, width, height);
  std::vector<unsigned char> cur(mask.size()), next(mask.size(), 0);
  for (size_t i = 0; i < mask.size(); ++i) cur[i] = mask[i] != 0 ? 1 : 0;
  const auto w = static_cast<size_t>(width);
  for (int it = 0; it < iterations; ++it) {
    // The border rows and columns go (their outside neighbours are unset); inside, a pixel
    // stays when it and its four neighbours are set (byte ANDs, vectorised).
    if (height > 0) {
      std::fill_n(next.begin(), w, 0);
      std::fill_n(next.begin() + static_cast<std::ptrdiff_t>((height - 1) * w), w, 0);
    }
    for (int y = 0; y < height && w > 0; ++y) next[y * w] = next[y * w + w - 1] = 0;
    for (int y = 1; y + 1 < height; ++y) {
      const unsigned char* up = cur.data() + (y - 1) * w;
      const unsigned char* row = up + w;
      const unsigned char* down = row + w;
      unsigned char* out = next.data() + y * w;
      for (size_t x = 1; x + 1 < w; ++x) {
        out[x] = row[x] & row[x - 1] & row[x + 1] & up[x] & down[x];
      }
    }
    std::swap(cur, next);
  }
  return cur;
}

ImagePoints::ImagePoints() { points.fill(std::numeric_limits<float>::quiet_NaN()); }

ImagePoints SampleImagePoints(const std::vector<unsigned char>& mask, int width, int height,
                              bool erode, Rng& rng, const MaskWindow& window) {
  std::vector<unsigned char> eroded;
  const std::vector<unsigned char>* use = &mask;
  if (erode) {
    eroded = ErodeMask(mask, width, height, kImagePointErosions);
    if (std::any_of(eroded.begin(), eroded.end(), [](unsigned char v) { return v != 0; })) {
      use = &eroded;
    }
  } else {
    CheckMaskSize("SampleImagePoints", mask, width, height);
  }
  // The drawn pixels are the set pixels of the drawn ordinals, in row-major order.
  size_t count = 0;
  for (const unsigned char v : *use) count += v != 0 ? 1 : 0;
  ImagePoints out;
  const std::vector<size_t> drawn = SampleIndices(rng, count, kMaxImagePoints);
  const std::vector<uint32_t> pixels = NthSetPixels(*use, drawn);
  const int image_w = window.image_width > 0 ? window.image_width : width;
  const int image_h = window.image_height > 0 ? window.image_height : height;
  const auto w = static_cast<float>(image_w), h = static_cast<float>(image_h);
  for (size_t k = 0; k < drawn.size(); ++k) {
    const uint32_t pixel = pixels[k];
    const uint32_t row = pixel / static_cast<uint32_t>(width) + window.y;
    const uint32_t col = pixel % static_cast<uint32_t>(width) + window.x;
    out.points[2 * k] = Round4(static_cast<float>(col) / w);
    out.points[2 * k + 1] = Round4(static_cast<float>(row) / h);
  }
  out.count = static_cast<int32_t>(drawn.size());
  return out;
}

ObjectImagePoints::ObjectImagePoints(const mjModel* m, std::vector<TrackedObject> objects)
    : objects_(std::move(objects)) {
  for (const TrackedObject& o : objects_) {
    const int root = mj_name2id(m, mjOBJ_BODY, o.body.c_str());
    if (root < 0) {
      throw Error("object_image_points: no body '" + o.body + "' in the scene", "",
                  "object_image_points/" + o.key);
    }
    std::vector<unsigned char> owns(static_cast<size_t>(m->ngeom), 0);
    for (int g = 0; g < m->ngeom; ++g) {
      for (int b = m->geom_bodyid[g]; b > 0; b = m->body_parentid[b]) {
        if (b == root) {
          owns[g] = 1;
          break;
        }
      }
      if (root == 0) owns[g] = 1;  // the world's subtree is everything
    }
    owns_.push_back(std::move(owns));
  }
  owner_.resize(static_cast<size_t>(m->ngeom));
  tracked_.assign(static_cast<size_t>(m->ngeom), 0);
  solo_owner_.assign(static_cast<size_t>(m->ngeom), kNoOwner);
  for (size_t k = 0; k < owns_.size(); ++k) {
    for (int g = 0; g < m->ngeom; ++g) {
      if (owns_[k][g] == 0) continue;
      owner_[g].push_back(static_cast<int>(k));
      tracked_[g] = 1;
      solo_owner_[g] = owner_[g].size() == 1 ? static_cast<int>(k) : kSeveralOwners;
    }
  }
}

std::vector<ImagePoints> ObjectImagePoints::Sample(const int* geom_ids, int width, int height,
                                                   bool skip_erosion, Rng& rng) const {
  return Sample(geom_ids, width, height, {0, 0, width, height}, skip_erosion, rng);
}

std::vector<ImagePoints> ObjectImagePoints::Sample(const int* geom_ids, int width, int height,
                                                   const sim::PixelRect& part, bool skip_erosion,
                                                   Rng& rng) const {
  if (part.x < 0 || part.y < 0 || part.width < 0 || part.height < 0 ||
      part.x + part.width > width || part.y + part.height > height) {
    throw UsageError("ObjectImagePoints::Sample: part " + std::to_string(part.width) + "x" +
                     std::to_string(part.height) + " at (" + std::to_string(part.x) + ", " +
                     std::to_string(part.y) + ") is not inside the " + std::to_string(width) + "x" +
                     std::to_string(height) + " image");
  }
  // Each object's pixels lie in its bounding box: erode and draw there (outside it nothing is
  // set, so the erosion and the row-major order are the whole image's).
  struct Box {
    int x0 = std::numeric_limits<int>::max(), y0 = std::numeric_limits<int>::max();
    int x1 = -1, y1 = -1;
    void Add(int from, int to, int y) {
      x0 = std::min(x0, from);
      x1 = std::max(x1, to);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  };
  std::vector<Box> boxes(objects_.size());
  const size_t ngeom = solo_owner_.size();
  // The owner of pixel `x` of `row`, kNoOwner for none (-1 wraps past ngeom).
  auto owner = [&](const int* row, int x) {
    const auto g = static_cast<size_t>(row[x]);
    return g < ngeom ? solo_owner_[g] : kNoOwner;
  };
  const int x_end = part.x + part.width;
  for (int y = part.y; y < part.y + part.height; ++y) {
    const int* row = geom_ids + static_cast<size_t>(y) * width;
    for (int x = part.x; x < x_end; ++x) {
      const int k = owner(row, x);
      if (k == kNoOwner) continue;
      if (k == kSeveralOwners) {
        for (const int o : owner_[static_cast<size_t>(row[x])]) {
          boxes[static_cast<size_t>(o)].Add(x, x, y);
        }
        continue;
      }
      int last = x;  // a run of one object's pixels counts once
      while (last + 1 < x_end && owner(row, last + 1) == k) ++last;
      boxes[static_cast<size_t>(k)].Add(x, last, y);
      x = last;
    }
  }
  std::vector<unsigned char> mask;
  std::vector<ImagePoints> out(objects_.size());
  for (size_t k = 0; k < objects_.size(); ++k) {
    const Box& b = boxes[k];
    if (b.x1 >= 0) {
      const int bw = b.x1 - b.x0 + 1, bh = b.y1 - b.y0 + 1;
      const std::vector<unsigned char>& owns = owns_[k];
      mask.assign(static_cast<size_t>(bw) * bh, 0);
      for (int y = 0; y < bh; ++y) {
        const int* row = geom_ids + static_cast<size_t>(b.y0 + y) * width + b.x0;
        for (int x = 0; x < bw; ++x) {
          const int g = row[x];
          mask[static_cast<size_t>(y) * bw + x] =
              g >= 0 && static_cast<size_t>(g) < owns.size() && owns[g] != 0 ? 1 : 0;
        }
      }
      const bool erode = !skip_erosion && objects_[k].key.find("handle") == std::string::npos;
      out[k] = SampleImagePoints(mask, bw, bh, erode, rng, {b.x0, b.y0, width, height});
    }
  }
  return out;
}

std::vector<ImagePoints> ObjectImagePoints::SampleLastFrame(sim::Renderer& renderer,
                                                            const mjData* d,
                                                            const sim::CameraView& view,
                                                            bool skip_erosion, Rng& rng) {
  const int w = renderer.width(), h = renderer.height();
  segment_.resize(static_cast<size_t>(w) * static_cast<size_t>(h));
  const sim::PixelRect part = renderer.SegmentLastFrame(d, view, segment_.data(), tracked_);
  return Sample(segment_.data(), w, h, part, skip_erosion, rng);
}

void ObjectImagePoints::Append(const std::vector<ImagePoints>& points, const std::string& camera,
                               std::map<std::string, Series>& extra) const {
  for (size_t k = 0; k < objects_.size(); ++k) {
    const ImagePoints& p = points[k];
    const std::string base = kGroup + objects_[k].key + "/" + camera + "/";
    extra.try_emplace(base + "points", DType::kFloat32, std::vector<size_t>{kMaxImagePoints, 2})
        .first->second.Append(std::vector<double>(p.points.begin(), p.points.end()));
    extra.try_emplace(base + "num_points", DType::kInt32, std::vector<size_t>{1})
        .first->second.AppendInts({p.count});
  }
}

}  // namespace mlspaces::datagen
