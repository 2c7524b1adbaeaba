// Pictures (sim/pictures.h, datagen/pictures.h) for mlspaces.render: every picture as a fresh
// uint8 (H,W,3) numpy array, PNG files read and written. Rendering releases the GIL.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nanobind/ndarray.h>
#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "bindings.h"
#include "convert.h"
#include "mlspaces/core/error.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/pictures.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/robots/robot_spec.h"
#include "mlspaces/sim/pictures.h"
#include "python_sampler.h"

namespace mlspaces::python {

namespace {

namespace dg = mlspaces::datagen;

using ImageArray = nb::ndarray<const uint8_t, nb::ndim<3>, nb::c_contig, nb::device::cpu>;
using GraspArray = nb::ndarray<const double, nb::shape<-1, 4, 4>, nb::c_contig, nb::device::cpu>;

nb::object ToNumpy(sim::Image image) {
  const size_t h = static_cast<size_t>(image.height), w = static_cast<size_t>(image.width);
  return OwnedNumpy<uint8_t>(std::move(image.rgb), {h, w, 3});
}

sim::Image FromNumpy(const ImageArray& a) {
  if (a.shape(2) != 3) throw UsageError("image: expected a uint8 (H,W,3) array");
  sim::Image image;
  image.height = static_cast<int>(a.shape(0));
  image.width = static_cast<int>(a.shape(1));
  image.rgb.assign(a.data(), a.data() + a.size());
  return image;
}

sim::PictureOptions Options(int width, int height, const std::string& gl) {
  if (std::min(width, height) < sim::kMinPictureSide ||
      std::max(width, height) > sim::kMaxPictureSide) {
    throw UsageError("size: expected width and height in [" + std::to_string(sim::kMinPictureSide) +
                     ", " + std::to_string(sim::kMaxPictureSide) + "], got " +
                     std::to_string(width) + "x" + std::to_string(height));
  }
  sim::PictureOptions o;
  o.width = width;
  o.height = height;
  o.backend = sim::ResolveGlBackend(gl, "gl");
  return o;
}

}  // namespace

void BindRender(nb::module_& m) {
  // The picture sides the engine accepts, for the Python checks' messages.
  m.attr("MIN_PICTURE_SIDE") = sim::kMinPictureSide;
  m.attr("MAX_PICTURE_SIDE") = sim::kMaxPictureSide;
  m.def(
      "render_user_uids", [](const Registry& r) { return r.user_uids(); }, nb::arg("registry"));
  m.def(
      "render_asset_sheet",
      [](const Registry& registry, const std::vector<std::string>& uids, int width, int height,
         int columns, const std::string& gl) {
        const sim::PictureOptions o = Options(width, height, gl);
        sim::Image image;
        {
          nb::gil_scoped_release release;
          image = sim::AssetSheet(registry, uids, o, columns);
        }
        return ToNumpy(std::move(image));
      },
      nb::arg("registry"), nb::arg("uids"), nb::arg("width"), nb::arg("height"), nb::arg("columns"),
      nb::arg("gl"));
  m.def(
      "render_asset",
      [](const Registry& registry, const std::string& uid, int width, int height,
         const std::string& gl) {
        const sim::PictureOptions o = Options(width, height, gl);
        sim::Image image;
        {
          nb::gil_scoped_release release;
          image = sim::RenderAsset(registry, uid, o);
        }
        return ToNumpy(std::move(image));
      },
      nb::arg("registry"), nb::arg("uid"), nb::arg("width"), nb::arg("height"), nb::arg("gl"));
  m.def(
      "render_grasps",
      [](const Registry& registry, const std::string& uid, const GraspArray& transforms,
         const std::string& joint, const std::string& gripper, int views, int width, int height,
         const std::string& gl) {
        const sim::PictureOptions o = Options(width, height, gl);
        std::vector<Mat4> grasps(transforms.shape(0));
        for (size_t i = 0; i < grasps.size(); ++i) {
          std::memcpy(grasps[i].m.data(), transforms.data() + 16 * i, 16 * sizeof(double));
        }
        std::filesystem::path gripper_file;
        try {
          gripper_file = robots::FindRobot(gripper, {}, "gripper");
        } catch (const Error& e) {
          throw UsageError(e);  // as the CLI's --gripper
        }
        sim::GripperOutline outline;
        outline.opening = robots::LoadRobotDescription(gripper_file).gripper.finger_range[1];
        sim::Image image;
        {
          nb::gil_scoped_release release;
          image = sim::GraspPicture(registry, uid, grasps, outline, o, views, joint);
        }
        return ToNumpy(std::move(image));
      },
      nb::arg("registry"), nb::arg("uid"), nb::arg("transforms"), nb::arg("joint"),
      nb::arg("gripper"), nb::arg("views"), nb::arg("width"), nb::arg("height"), nb::arg("gl"));
  m.def(
      "render_scene",
      [](const std::string& text, const std::string& origin, const std::filesystem::path& base_dir,
         int64_t house, int64_t episode, std::optional<uint64_t> seed, int overviews, int width,
         int height, const std::string& gl, const nb::object& sampler) {
        const sim::PictureOptions o = Options(width, height, gl);
        const dg::ConfigRegistry configs = dg::ConfigRegistry::WithBuiltins();
        dg::ExperimentConfig config = dg::ParseConfigText(text, origin, base_dir, configs);
        dg::Validate(config, origin);
        dg::SceneRequest request;
        request.house = house;
        request.episode = episode;
        request.seed = seed;
        request.overview_views = overviews;
        sim::Image image;
        if (sampler.is_none()) {
          nb::gil_scoped_release release;
          image = dg::ScenePicture(config, request, o);
        } else {
          // A Python sampler's hooks run in Python: the GIL stays held.
          const uint64_t run_seed = seed ? *seed : config.seed.value_or(0);
          image = dg::ScenePicture(config, request, o,
                                   std::make_unique<PythonTaskSampler>(config, run_seed, sampler));
        }
        return ToNumpy(std::move(image));
      },
      nb::arg("text"), nb::arg("origin"), nb::arg("base_dir"), nb::arg("house"), nb::arg("episode"),
      nb::arg("seed").none(), nb::arg("overviews"), nb::arg("width"), nb::arg("height"),
      nb::arg("gl"), nb::arg("sampler").none());
  // render_episode_phases(dataset, episode, camera, columns, width) -> (sheet, frames, info):
  // frames one (H,W,3) array per phase change; info {file, traj, camera, num_steps, steps,
  // phases, phase_names}.
  m.def(
      "render_episode_phases",
      [](const std::filesystem::path& dataset, int64_t episode, const std::string& camera,
         int columns, int width) {
        dg::EpisodeFrames frames;
        sim::Image sheet;
        {
          nb::gil_scoped_release release;
          frames = dg::EpisodePhaseFrames(dataset, episode, camera);
          sheet = dg::EpisodePhaseSheet(frames, columns, width);
        }
        nb::list images;
        nb::list steps, phases, names;
        for (dg::PhaseFrame& f : frames.frames) {
          steps.append(f.step);
          phases.append(f.phase);
          names.append(f.phase_name);
          images.append(ToNumpy(std::move(f.image)));
        }
        nb::dict info;
        info["file"] = frames.episode.file.string();
        info["traj"] = frames.episode.traj;
        info["camera"] = frames.camera;
        info["num_steps"] = frames.num_steps;
        info["steps"] = steps;
        info["phases"] = phases;
        info["phase_names"] = names;
        return nb::make_tuple(ToNumpy(std::move(sheet)), images, info);
      },
      nb::arg("dataset"), nb::arg("episode"), nb::arg("camera"), nb::arg("columns"),
      nb::arg("width"));
  m.def(
      "write_png",
      [](const std::filesystem::path& path, const ImageArray& image) {
        sim::WritePng(path, FromNumpy(image));
      },
      nb::arg("path"), nb::arg("image"));
  m.def(
      "read_png", [](const std::filesystem::path& path) { return ToNumpy(sim::ReadPng(path)); },
      nb::arg("path"));
}

}  // namespace mlspaces::python
