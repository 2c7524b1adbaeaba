// validate-dataset: cameras (obs/sensor_param) and the videos obs/sensor_data names.
#include <algorithm>
#include <cmath>

#include "mlspaces/datagen/video.h"

#include "dataset_validate_internal.h"

namespace mlspaces::datagen::dataset_check {

// -------------------------------------------------------------------------------------------
// Cameras and videos
void Validator::Cameras(const Traj& t) {
  // Camera parameters and image sizes.
  std::map<std::string, std::optional<std::pair<int, int>>> cams;  // name -> image W x H
  const std::string param_base = t.name + "/" + schema::kSensorParam;
  // The camera whose row 0 gives the image size.
  const char* const intrinsics = schema::kSensorParams[2].name;
  if (Exists(t.g, schema::kSensorParam)) {
    Handle g(H5Gopen2(t.g, schema::kSensorParam, H5P_DEFAULT), H5Gclose);
    const auto names = g.get() >= 0 ? ListLinks(g.get(), false) : std::nullopt;
    if (!names) Add(param_base, HdfMessage("expected a readable group"));
    for (const std::string& cam : names.value_or(std::vector<std::string>{})) {
      const std::string rel = std::string(schema::kSensorParam).append("/").append(cam);
      Handle obj(H5Oopen(t.g, rel.c_str(), H5P_DEFAULT), H5Oclose);
      if (obj.get() < 0 || H5Iget_type(obj.get()) != H5I_GROUP) {
        Add(param_base + "/" + cam,
            obj.get() < 0 ? HdfMessage("cannot open") : "expected a group per camera");
        continue;
      }
      cams[cam] = std::nullopt;
      VisitDatasets(t, rel, [&](const Ds& ds) {
        if (!Rows(ds, t)) return;
        const std::string key = ds.path.substr(ds.path.rfind('/') + 1);
        const auto shape =
            std::find_if(schema::kSensorParams.begin(), schema::kSensorParams.end(),
                         [&](const schema::SensorParam& p) { return key == p.name; });
        const std::vector<hsize_t> expected =
            shape == schema::kSensorParams.end()
                ? std::vector<hsize_t>{}
                : std::vector<hsize_t>{static_cast<hsize_t>(shape->rows),
                                       static_cast<hsize_t>(shape->cols)};
        if (shape != schema::kSensorParams.end() &&
            !std::equal(ds.dims.begin() + 1, ds.dims.end(), expected.begin(), expected.end())) {
          Add(ds.path, "has shape " + Shape(ds.dims) + ", expected (T, " +
                           std::to_string(expected[0]) + ", " + std::to_string(expected[1]) + ")");
          return;
        }
        if (key != intrinsics) {
          ReadNumeric(ds);
          return;
        }
        if (H5Tget_class(ds.type.get()) != H5T_FLOAT) {
          Add(ds.path, "expected float64, got " + TypeName(ds.type.get()));
          return;
        }
        std::vector<double> k(ds.elements());
        if (!Read(ds, H5T_NATIVE_DOUBLE, k.data()) || k.empty()) return;
        const double w = 2 * k[2], h = 2 * k[5];  // cx = K[0][2], cy = K[1][2]
        if (!(w >= 1 && h >= 1 && w <= 65536 && h <= 65536)) {
          Add(ds.path, "row 0 gives no image size (2 cx = " + std::to_string(w) +
                           ", 2 cy = " + std::to_string(h) + ")");
          return;
        }
        cams[cam] = std::pair{static_cast<int>(std::lround(w)), static_cast<int>(std::lround(h))};
      });
      if (!Exists(t.g, rel + "/" + intrinsics)) {
        Add(param_base + "/" + cam + "/" + intrinsics, "missing");
      }
    }
  }

  const std::string data_base = t.name + "/" + schema::kSensorData;
  if (!Exists(t.g, schema::kSensorData)) {
    Add(data_base, "missing");
    return;
  }
  Handle g(H5Gopen2(t.g, schema::kSensorData, H5P_DEFAULT), H5Gclose);
  const auto names = g.get() >= 0 ? ListLinks(g.get(), false) : std::nullopt;
  if (!names) {
    Add(data_base, HdfMessage("expected a readable group"));
    return;
  }
  for (const std::string& entry : *names) {
    auto ds = Open(g.get(), data_base, entry, true);
    if (!ds) continue;
    ++report_.videos;
    if (!IsUint8(ds->type.get()) || ds->dims.size() != 1) {
      Add(ds->path, "expected a uint8 (100,) zero-padded file name, got " +
                        TypeName(ds->type.get()) + " " + Shape(ds->dims));
      continue;
    }
    std::vector<unsigned char> buf(ds->dims[0]);
    if (!Read(*ds, H5T_NATIVE_UINT8, buf.data())) continue;
    const auto nul = std::find(buf.begin(), buf.end(), 0);
    const std::string file(buf.begin(), nul);
    if (std::any_of(nul, buf.end(), [](unsigned char c) { return c != 0; })) {
      Add(ds->path, "has non-zero bytes after its zero padding starts");
      continue;
    }
    if (file.empty() || file.find('/') != std::string::npos || file == "." || file == "..") {
      Add(ds->path, "expected a file name beside the HDF5 file, got " + Snippet(file));
      continue;
    }
    // The camera whose intrinsics give the size: <cam>, or <cam> for "<cam>_depth".
    std::string cam = entry;
    if (cams.count(cam) == 0 && EndsWith(cam, schema::kDepthSuffix)) {
      cam.resize(cam.size() - (sizeof(schema::kDepthSuffix) - 1));
    }
    auto cam_it = cams.find(cam);
    if (cam_it == cams.end()) {
      Add(ds->path, "no camera obs/sensor_param/" + entry + " for this video");
    }
    Video(t, *ds, file, cam_it != cams.end() ? cam_it->second : std::nullopt);
  }
  for (const auto& [cam, size] : cams) {
    if (std::find(names->begin(), names->end(), cam) == names->end()) {
      Add(data_base + "/" + cam, "missing: camera obs/sensor_param/" + cam + " has no video");
    }
  }
}

void Validator::Video(const Traj& t, const Ds& ds, const std::string& name,
                      const std::optional<std::pair<int, int>>& image) {
  const fs::path file = dir_ / name;
  const std::string key = Key(file);
  const std::string referer = file_ + ": " + ds.path;
  auto [ref, inserted] = video_refs_.emplace(key, referer);
  if (inserted) added_refs_.emplace_back(key, referer);
  if (!inserted) {
    Add(ds.path, "video " + name + " is also named by " + ref->second);
    return;
  }
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) {
    Add(ds.path, "video file does not exist: " + file.string());
    return;
  }
  VideoInfo info;
  try {
    info = ProbeVideo(file);
  } catch (const Error& e) {
    Add(ds.path, "video " + name + " cannot be decoded: " + e.message());
    return;
  }
  if (t.t >= 0 && info.frames != t.t) {
    Add(ds.path, "video " + name + " has " + std::to_string(info.frames) + " frames, expected " +
                     std::to_string(t.t) + " (T, one per observation)");
  }
  if (image) {
    const int w = (image->first + 15) / 16 * 16, h = (image->second + 15) / 16 * 16;
    if (info.width != w || info.height != h) {
      Add(ds.path, "video " + name + " is " + std::to_string(info.width) + "x" +
                       std::to_string(info.height) + ", expected " + std::to_string(w) + "x" +
                       std::to_string(h) + " (the camera's " + std::to_string(image->first) + "x" +
                       std::to_string(image->second) + " image rounded up to multiples of 16)");
    }
  }
}

}  // namespace mlspaces::datagen::dataset_check
