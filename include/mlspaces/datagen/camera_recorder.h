// The camera system of an episode (spec 7, 7.1): where each configured camera is at a state,
// its per-step parameters (obs/sensor_param/<camera>), and its RGB (and optional depth) video,
// rendered headless (sim::Renderer) and encoded as H.264 MP4 (VideoWriter).
//
// Cameras:
//   - mjcf: the model camera <robot_namespace><mjcf_name> (e.g. robot_0/gripper/wrist_camera),
//     at its compiled pose on its body; vertical field of view = the config's fov;
//   - robot_mounted: fixed to the first of reference_body_names: world position
//     R_body * camera_offset + p_body, rotation R_body * R(camera_quaternion) in MuJoCo's camera
//     convention (looks along -z, +y up).
// Per step and camera (float64): cam2world_gl (4x4, columns right, -up, forward, position:
// OpenCV-style axes, as in the dataset format: docs/dataset.md), extrinsic_cv =
// inverse(cam2world_gl)[:3] (3x4, world to camera), intrinsic_cv = [[f, 0, W/2], [0, f, H/2],
// [0, 0, 1]] with f = (H/2) / tan(fovy/2).
// The cameras are fixed, so visibility_constraints are not used (docs/datagen.md). With
// camera_config.object_image_points, each camera's frame also gives obs/extra/
// object_image_points (object_image_points.h): the tracked objects' ids, which the frame
// carries in its alpha (sim::Renderer::TrackGeoms, SegmentLastFrame).
//
// Lifetimes: the models and data passed in are read during the call only. References a
// CameraSystem or CameraRecorder returns (name(), cameras()) are valid while it lives.
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/episode_record.h"
#include "mlspaces/datagen/object_image_points.h"
#include "mlspaces/datagen/video.h"
#include "mlspaces/sim/renderer.h"

namespace mlspaces::datagen {

/// The cameras `config` means for `robot`: the robot's own cameras (robot.yaml `cameras`) when
/// config.name is "RobotCameraSystem", else config's; then every robot name (an mjcf camera
/// under the robot's namespace, a reference body under its prefix) through the robot's
/// franka_droid aliases (RobotSpec::Resolve), so a config written for franka_droid runs with
/// another robot.
MLSPACES_API CameraSystemConfig CamerasForRobot(const CameraSystemConfig& config,
                                                const RobotSpec& robot);

/// Resolves the cameras of a config in a model and computes their views.
class MLSPACES_API CameraSystem {
 public:
  /// @throws Error naming camera_config.cameras[i] for a camera or body missing in `m`.
  CameraSystem(const mjModel* m, const CameraSystemConfig& config);

  size_t size() const { return cameras_.size(); }
  const std::string& name(size_t i) const { return cameras_[i].name; }
  /// Camera i's view at the state in `d` (kinematics must be current).
  sim::CameraView View(size_t i, const mjData* d) const;
  int width() const { return width_; }
  int height() const { return height_; }

  /// Appends one step of cam2world_gl, extrinsic_cv and intrinsic_cv of `view` to
  /// `params` (creating the series on first use).
  static void AppendParams(const sim::CameraView& view, int width, int height,
                           std::map<std::string, Series>& params);

 private:
  struct Camera {
    std::string name;
    int camera_id = -1;  // mjcf cameras
    int body_id = -1;    // robot-mounted cameras
    std::array<double, 3> offset{};
    std::array<double, 9> rot{};  // R(camera_quaternion), row-major
    double fovy_deg = 45;
  };
  std::vector<Camera> cameras_;
  int width_ = 0, height_ = 0;
};

/// A Renderer for `config`'s cameras on `m`: its image size, shadow_size, multisamples,
/// fit_shadows, shadows and reflections. @throws Error as sim::Renderer's constructor.
MLSPACES_API std::unique_ptr<sim::Renderer> MakeCameraRenderer(const mjModel* m,
                                                               const CameraSystemConfig& config,
                                                               sim::GlBackend backend);

/// Renders and encodes the cameras of one env, episode after episode. One per worker
/// (it owns a GL context).
class MLSPACES_API CameraRecorder {
 public:
  // ===========================================================================================
  // Construction

  /// @throws Error when a camera cannot be resolved or no GL context can be made.
  CameraRecorder(const mjModel* m, const CameraSystemConfig& config, double fps,
                 sim::GlBackend backend);
  ~CameraRecorder();

  // ===========================================================================================
  // Episodes

  /// Starts episode `episode`: its videos are written in `dir` under TempVideoName(). With
  /// camera_config.object_image_points, Capture records the image points of `objects`
  /// (TaskObjects), drawn from a generator seeded by `seed` (the episode's).
  /// @throws Error as ObjectImagePoints for an object whose body is not in the model.
  void Begin(const std::filesystem::path& dir, int64_t episode,
             std::vector<TrackedObject> objects = {}, uint64_t seed = 0);
  /// Renders every camera at the state in `d` and appends a frame and the parameters; with
  /// tracked objects and `extra` not null, appends a row of their image points per camera
  /// (not "follower" cameras: TracksObjectsIn) to `extra` (obs/extra series).
  void Capture(const mjData* d, std::map<std::string, Series>* extra = nullptr);
  /// Finishes the videos: one CameraRecord per camera whose video_file (and
  /// depth_video_file) name the finished files in the episode's dir (temp names: the
  /// trajectory writer renames them to their final names).
  std::vector<CameraRecord> End();
  /// Drops the episode's videos (no files left).
  void Abort();

  /// The name an episode's video has until it is kept: .episode_<episode>_<camera>.mp4.
  static std::string TempVideoName(int64_t episode, const std::string& camera);

  // ===========================================================================================
  // Access

  const CameraSystem& cameras() const { return system_; }
  /// The renderer (its frame counts, sim::Renderer::one_pass_missed()); valid while this lives.
  const sim::Renderer& renderer() const { return *renderer_; }
  /// Seconds spent rendering / encoding / on image points (the ids read from the frames, or
  /// segmentation renders, and the points drawn from them) so far, over every episode.
  double render_seconds() const { return render_seconds_; }
  double encode_seconds() const { return encode_seconds_; }
  double points_seconds() const { return points_seconds_; }

 private:
  CameraSystem system_;
  CameraSystemConfig config_;
  VideoOptions video_;
  std::unique_ptr<sim::Renderer> renderer_;
  std::filesystem::path dir_;
  int64_t episode_ = -1;
  std::vector<std::unique_ptr<VideoWriter>> rgb_, depth_;
  std::vector<CameraRecord> records_;
  std::vector<unsigned char> rgb_buf_, grey_buf_;
  std::vector<sim::CameraView> views_;  // this state's, Capture's
  std::vector<float> depth_buf_;
  std::unique_ptr<ObjectImagePoints> points_;  // this episode's tracked objects; null: none
  Rng points_rng_{0};
  double render_seconds_ = 0, encode_seconds_ = 0, points_seconds_ = 0;
};

}  // namespace mlspaces::datagen
