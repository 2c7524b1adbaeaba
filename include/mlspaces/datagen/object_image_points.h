// object_image_points (docs/dataset.md): per observation, per tracked object and per camera,
// up to 10 pixels where the object is seen, as MolmoSpaces' ObjectImagePointsSensor records
// them: the pixels of the object's geoms (its body's subtree) in a segmentation render,
// eroded twice with the 3x3 cross (scipy.ndimage.binary_erosion; the whole mask when that
// leaves nothing, or when erosion is skipped), up to 10 of them drawn without replacement,
// as (x / W, y / H) of their row and column, rounded to 4 decimals, NaN-padded:
//   obs/extra/object_image_points/<key>/<camera>/points      (T, 10, 2) float32
//   obs/extra/object_image_points/<key>/<camera>/num_points  (T, 1)     int32
// The original draws with NumPy's global RNG; here every draw comes from the episode's seed.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/rng.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/episode_record.h"
#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/sim/renderer.h"

// NOLINTBEGIN(modernize-use-using): MuJoCo's own form of this declaration
struct mjModel_;
typedef struct mjModel_ mjModel;
// NOLINTEND(modernize-use-using)

namespace mlspaces::datagen {

/// Points per object and camera (the original's max_points) and erosion iterations.
inline constexpr int kMaxImagePoints = 10;
inline constexpr int kImagePointErosions = 2;

/// The generator an episode's image points are drawn from (the datagen recorder's and the
/// evaluation env's), from the episode's seed.
MLSPACES_API Rng ImagePointsRng(uint64_t episode_seed);

/// One object whose image points an episode records: its key in the dataset and its body.
struct MLSPACES_API TrackedObject {
  std::string key;   ///< "gripper", "pickup_obj", "place_receptacle", "added_<k>"
  std::string body;  ///< a body of the model (its subtree's geoms are the object)
};

/// The objects the original tracks in an episode of `task` (its get_task_objects): the
/// robot's gripper body as "gripper"; the bodies of config.added_objects present in `m`, then
/// (pick_and_place_color) the other receptacles, as added_0, added_1, ...; then pickup_obj and,
/// with a place target, place_receptacle, each replacing an added_<k> of the same body.
MLSPACES_API std::vector<TrackedObject> TaskObjects(const mjModel* m, const Task& task,
                                                    const TaskConfig& config,
                                                    const std::string& gripper_body);

/// Whether camera `name` records image points: not a "follower" camera (any case), as the
/// original leaves those out.
MLSPACES_API bool TracksObjectsIn(std::string_view camera_name);

/// `mask` (width*height, rows top to bottom, non-zero = set) eroded `iterations` times by
/// the 3x3 cross, pixels outside the image counting as unset: scipy.ndimage.binary_erosion(
/// mask, iterations=iterations). @throws UsageError when mask.size() != width*height.
MLSPACES_API std::vector<unsigned char> ErodeMask(const std::vector<unsigned char>& mask, int width,
                                                  int height, int iterations);

/// One object's points in one camera, as the dataset stores them.
struct MLSPACES_API ImagePoints {
  /// (x, y) pairs, the unused ones NaN.
  std::array<float, 2 * kMaxImagePoints> points;
  int32_t count = 0;
  ImagePoints();
};

/// Where a mask lies in its image: a window at column x, row y of an image_width x
/// image_height image (0: the mask's own size), the pixels outside it unset.
struct MLSPACES_API MaskWindow {
  int x = 0, y = 0;
  int image_width = 0, image_height = 0;
};

/// The points of `mask` (as ErodeMask's), a `window` of its image: eroded kImagePointErosions times
/// when `erode` (the whole mask when that leaves nothing), then min(pixels, kMaxImagePoints) of its
/// pixels in row-major order, drawn without replacement by `rng` (kept in the order drawn; all of
/// them, in order, when there are at most kMaxImagePoints), each as float32 (column / width, row /
/// height) of the image, rounded to 4 decimals (numpy.round in float32). An empty mask gives count
/// 0 and draws nothing. The same points as the whole image's mask when the window holds every set
/// pixel. @throws UsageError as ErodeMask.
MLSPACES_API ImagePoints SampleImagePoints(const std::vector<unsigned char>& mask, int width,
                                           int height, bool erode, Rng& rng,
                                           const MaskWindow& window = {});

/// The tracked objects of one episode on one model: which geoms each object owns.
class MLSPACES_API ObjectImagePoints {
 public:
  /// `m` is read during the call only. @throws Error naming the object's key and body when the
  /// body is not in `m`.
  ObjectImagePoints(const mjModel* m, std::vector<TrackedObject> objects);

  const std::vector<TrackedObject>& objects() const { return objects_; }
  /// Per model geom, 1 for the geoms of some object (sim::Renderer::RenderSegmentation's
  /// `interest`).
  const std::vector<unsigned char>& tracked_geoms() const { return tracked_; }
  /// Every object's points (objects() order) in the segmentation `geom_ids` (width*height, as
  /// sim::Renderer::RenderSegmentation writes it), drawn by `rng` object after object. The
  /// objects whose key holds "handle" are not eroded, nor any with `skip_erosion`.
  std::vector<ImagePoints> Sample(const int* geom_ids, int width, int height, bool skip_erosion,
                                  Rng& rng) const;
  /// As Sample, looking only inside `part` of the segmentation (every pixel outside it -1, as
  /// RenderSegmentation returns it): the same points for less work.
  /// @throws UsageError when `part` is not inside the image.
  std::vector<ImagePoints> Sample(const int* geom_ids, int width, int height,
                                  const sim::PixelRect& part, bool skip_erosion, Rng& rng) const;
  /// Sample's points in the frame `renderer` drew last, of `d` from `view`
  /// (Renderer::SegmentLastFrame of tracked_geoms(), into a buffer the object keeps).
  std::vector<ImagePoints> SampleLastFrame(sim::Renderer& renderer, const mjData* d,
                                           const sim::CameraView& view, bool skip_erosion,
                                           Rng& rng);
  /// One row of `points` (Sample's, of camera `camera`) appended to `extra`, creating the
  /// series object_image_points/<key>/<camera>/{points,num_points} on first use.
  void Append(const std::vector<ImagePoints>& points, const std::string& camera,
              std::map<std::string, Series>& extra) const;

 private:
  std::vector<TrackedObject> objects_;
  std::vector<std::vector<unsigned char>> owns_;  // [object][geom]: the geom is the object's
  std::vector<std::vector<int>> owner_;           // [geom]: the objects owning it
  std::vector<unsigned char> tracked_;            // [geom]: some object owns it
  static constexpr int kNoOwner = -1, kSeveralOwners = -2;
  std::vector<int> solo_owner_;  // [geom]: its one owner, or kNoOwner / kSeveralOwners
  std::vector<int> segment_;     // SampleLastFrame's segmentation
};

}  // namespace mlspaces::datagen
