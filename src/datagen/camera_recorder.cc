#include "mlspaces/datagen/camera_recorder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include <mujoco/mujoco.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/progress.h"
#include "mlspaces/core/transform.h"
#include "mlspaces/datagen/dataset_schema.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;

// Row-major rotation of a quaternion (w, x, y, z), normalised first (configs give 4 digits).
Rot3 QuatToMat(const Quat& q) { return QuatToRotation(QuatNormalized(q)); }

}  // namespace

CameraSystemConfig CamerasForRobot(const CameraSystemConfig& config, const RobotSpec& robot) {
  CameraSystemConfig out = config;
  if (config.name == "RobotCameraSystem") {
    out.cameras.clear();
    for (const robots::RobotCamera& rc : robot.cameras) {
      CameraConfig c;
      c.name = rc.name;
      c.fov = rc.fov;
      if (rc.type == "mjcf") {
        c.type = CameraType::kMjcf;
        c.mjcf_name = rc.mjcf_name.value_or("");
        c.robot_namespace = robot.prefix;
      } else {
        c.type = CameraType::kRobotMounted;
        c.reference_body_names = {robot.prefix + rc.reference_body.value_or("")};
        c.camera_offset = rc.offset;
        c.camera_quaternion = rc.quaternion;
      }
      out.cameras.push_back(std::move(c));
    }
  }
  for (CameraConfig& c : out.cameras) {
    if (c.type == CameraType::kMjcf && c.robot_namespace == robot.prefix) {
      c.mjcf_name = robot.Resolve(c.mjcf_name);
    }
    for (std::string& body : c.reference_body_names) {
      if (body.starts_with(robot.prefix)) {
        body = robot.prefix + robot.Resolve(body.substr(robot.prefix.size()));
      }
    }
  }
  return out;
}

CameraSystem::CameraSystem(const mjModel* m, const CameraSystemConfig& config)
    : width_(static_cast<int>(config.img_resolution[0])),
      height_(static_cast<int>(config.img_resolution[1])) {
  for (size_t i = 0; i < config.cameras.size(); ++i) {
    const CameraConfig& c = config.cameras[i];
    const std::string field = "camera_config.cameras[" + std::to_string(i) + "]";
    Camera cam;
    cam.name = c.name;
    cam.fovy_deg = c.fov;
    if (c.type == CameraType::kMjcf) {
      const std::string name = c.robot_namespace + c.mjcf_name;
      cam.camera_id = mj_name2id(m, mjOBJ_CAMERA, name.c_str());
      if (cam.camera_id < 0) {
        throw Error("camera '" + name + "' is not in the model", "", field + ".mjcf_name");
      }
    } else {
      const std::string& body = c.reference_body_names.at(0);
      cam.body_id = mj_name2id(m, mjOBJ_BODY, body.c_str());
      if (cam.body_id < 0) {
        throw Error("body '" + body + "' is not in the model", "", field + ".reference_body_names");
      }
      cam.offset = c.camera_offset;
      cam.rot = QuatToMat(c.camera_quaternion);
    }
    cameras_.push_back(std::move(cam));
  }
}

sim::CameraView CameraSystem::View(size_t i, const mjData* d) const {
  const Camera& c = cameras_.at(i);
  sim::CameraView v;
  v.fovy_deg = c.fovy_deg;
  if (c.camera_id >= 0) {
    std::copy_n(d->cam_xpos + 3 * c.camera_id, 3, v.pos.begin());
    std::copy_n(d->cam_xmat + 9 * c.camera_id, 9, v.xmat.begin());
    return v;
  }
  const mjtNum* p = d->xpos + 3 * c.body_id;
  const mjtNum* r = d->xmat + 9 * c.body_id;
  for (int a = 0; a < 3; ++a) {
    v.pos[a] = p[a];
    for (int k = 0; k < 3; ++k) v.pos[a] += r[3 * a + k] * c.offset[k];
    for (int b = 0; b < 3; ++b) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += r[3 * a + k] * c.rot[3 * k + b];
      v.xmat[3 * a + b] = s;
    }
  }
  return v;
}

void CameraSystem::AppendParams(const sim::CameraView& v, int width, int height,
                                std::map<std::string, Series>& params) {
  const auto& [c2w_param, ext_param, int_param] = schema::kSensorParams;
  if (params.empty()) {
    for (const schema::SensorParam& p : schema::kSensorParams) {
      params[p.name] =
          Series(DType::kFloat64, {static_cast<size_t>(p.rows), static_cast<size_t>(p.cols)});
    }
  }
  // Columns: right (x), -up (-y), forward (-z), position.
  double c2w[16] = {0};
  for (int a = 0; a < 3; ++a) {
    c2w[4 * a + 0] = v.xmat[3 * a + 0];
    c2w[4 * a + 1] = -v.xmat[3 * a + 1];
    c2w[4 * a + 2] = -v.xmat[3 * a + 2];
    c2w[4 * a + 3] = v.pos[a];
  }
  c2w[15] = 1;
  // World to camera: R^T, -R^T p.
  std::vector<double> ext(12);
  for (int a = 0; a < 3; ++a) {
    double t = 0;
    for (int b = 0; b < 3; ++b) {
      ext[4 * a + b] = c2w[4 * b + a];
      t -= c2w[4 * b + a] * v.pos[b];
    }
    ext[4 * a + 3] = t;
  }
  const double f = 0.5 * height / std::tan(v.fovy_deg * kPi / 360.0);
  params[c2w_param.name].Append(std::vector<double>(c2w, c2w + 16));
  params[ext_param.name].Append(ext);
  params[int_param.name].Append({f, 0, 0.5 * width, 0, f, 0.5 * height, 0, 0, 1});
}

std::unique_ptr<sim::Renderer> MakeCameraRenderer(const mjModel* m,
                                                  const CameraSystemConfig& config,
                                                  sim::GlBackend backend) {
  sim::RenderOptions options;
  options.width = static_cast<int>(config.img_resolution[0]);
  options.height = static_cast<int>(config.img_resolution[1]);
  options.backend = backend;
  options.shadow_size = static_cast<int>(config.shadow_size);
  options.multisamples = static_cast<int>(config.multisamples);
  options.fit_shadows = config.fit_shadows;
  options.one_pass_shadows = config.one_pass_shadows;
  options.coarse_sides = config.coarse_sides;
  options.nearest_mipmap = config.nearest_mipmap;
  auto renderer = std::make_unique<sim::Renderer>(m, options);
  renderer->scene().flags[mjRND_SHADOW] = config.shadows ? 1 : 0;
  renderer->scene().flags[mjRND_REFLECTION] = config.reflections ? 1 : 0;
  return renderer;
}

CameraRecorder::CameraRecorder(const mjModel* m, const CameraSystemConfig& config, double fps,
                               sim::GlBackend backend)
    : system_(m, config), config_(config) {
  video_.fps = fps;
  video_.crf = static_cast<int>(config.video_crf);
  video_.preset = config.video_preset;
  renderer_ = MakeCameraRenderer(m, config, backend);
  const size_t pixels = static_cast<size_t>(system_.width()) * system_.height();
  rgb_buf_.resize(3 * pixels);
  if (config.record_depth) {
    depth_buf_.resize(pixels);
    grey_buf_.resize(3 * pixels);
  }
}

CameraRecorder::~CameraRecorder() = default;

std::string CameraRecorder::TempVideoName(int64_t episode, const std::string& camera) {
  return ".episode_" + std::to_string(episode) + "_" + camera + ".mp4";
}

void CameraRecorder::Begin(const fs::path& dir, int64_t episode, std::vector<TrackedObject> objects,
                           uint64_t seed) {
  Abort();
  dir_ = dir;
  episode_ = episode;
  records_.clear();
  points_.reset();
  if (config_.object_image_points && !objects.empty()) {
    points_ = std::make_unique<ObjectImagePoints>(renderer_->model(), std::move(objects));
    points_rng_ = ImagePointsRng(seed);
  }
  // The frames carry the tracked geoms' ids (SampleLastFrame reads them, nothing redrawn).
  renderer_->TrackGeoms(points_ ? points_->tracked_geoms() : std::vector<unsigned char>{});
  for (size_t i = 0; i < system_.size(); ++i) {
    const std::string& name = system_.name(i);
    rgb_.push_back(std::make_unique<VideoWriter>(dir / TempVideoName(episode, name),
                                                 system_.width(), system_.height(), video_));
    if (config_.record_depth) {
      depth_.push_back(std::make_unique<VideoWriter>(dir / TempVideoName(episode, name + "_depth"),
                                                     system_.width(), system_.height(), video_));
    }
    CameraRecord rec;
    rec.name = name;
    records_.push_back(std::move(rec));
  }
}

void CameraRecorder::Capture(const mjData* d, std::map<std::string, Series>* extra) {
  views_.clear();
  for (size_t i = 0; i < system_.size(); ++i) views_.push_back(system_.View(i, d));
  renderer_->SetShadowViews(views_);  // the state's cameras share its shadow maps
  for (size_t i = 0; i < system_.size(); ++i) {
    const sim::CameraView& view = views_[i];
    CameraSystem::AppendParams(view, system_.width(), system_.height(), records_[i].params);
    auto t0 = Clock::now();
    renderer_->Render(d, view, rgb_buf_.data(), config_.record_depth ? depth_buf_.data() : nullptr);
    render_seconds_ += Since(t0);
    t0 = Clock::now();
    rgb_[i]->AddFrame(rgb_buf_.data());
    if (config_.record_depth) {
      const double scale = 255.0 / config_.depth_max_m;
      for (size_t p = 0; p < depth_buf_.size(); ++p) {
        const auto g =
            static_cast<unsigned char>(std::clamp(std::lround(depth_buf_[p] * scale), 0L, 255L));
        grey_buf_[3 * p] = grey_buf_[3 * p + 1] = grey_buf_[3 * p + 2] = g;
      }
      depth_[i]->AddFrame(grey_buf_.data());
    }
    encode_seconds_ += Since(t0);
    if (points_ != nullptr && extra != nullptr && TracksObjectsIn(system_.name(i))) {
      t0 = Clock::now();
      points_->Append(points_->SampleLastFrame(*renderer_, d, view, config_.cameras[i].skip_erosion,
                                               points_rng_),
                      system_.name(i), *extra);
      points_seconds_ += Since(t0);
    }
  }
}

std::vector<CameraRecord> CameraRecorder::End() {
  const auto t0 = Clock::now();
  for (size_t i = 0; i < records_.size(); ++i) {
    rgb_[i]->Finish();
    records_[i].video_file = TempVideoName(episode_, records_[i].name);
    if (config_.record_depth) {
      depth_[i]->Finish();
      records_[i].depth_video_file = TempVideoName(episode_, records_[i].name + "_depth");
    }
  }
  encode_seconds_ += Since(t0);
  rgb_.clear();
  depth_.clear();
  std::vector<CameraRecord> out = std::move(records_);
  records_.clear();
  return out;
}

void CameraRecorder::Abort() {
  // Writers destroyed without Finish() remove their temp files.
  rgb_.clear();
  depth_.clear();
  records_.clear();
}

}  // namespace mlspaces::datagen
