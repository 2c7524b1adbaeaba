// _core.generate_grasps, behind mlspaces.grasp_generation.generate_grasps: `mlspaces
// generate-grasps` as a function returning one dict per object or joint (graspgen/generate.h).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "bindings.h"
#include "mlspaces/core/error.h"
#include "mlspaces/graspgen/generate.h"

namespace mlspaces::python {
namespace {

const char* StatusName(graspgen::ObjectReport::Status status) {
  switch (status) {
    case graspgen::ObjectReport::Status::kDone:
      return "done";
    case graspgen::ObjectReport::Status::kSkipped:
      return "skipped";
    case graspgen::ObjectReport::Status::kFailed:
      break;
  }
  return "failed";
}

nb::dict ReportToPython(const graspgen::ObjectReport& r) {
  nb::dict d;
  d["uid"] = r.uid;
  d["joint"] = r.joint.empty() ? nb::none() : nb::cast(r.joint);
  d["asset"] = r.asset.string();
  d["output"] = r.output.empty() ? nb::none() : nb::cast(r.output.string());
  d["status"] = StatusName(r.status);
  d["candidates"] = r.candidates;
  d["tested"] = r.tested;
  d["accepted"] = r.accepted;
  d["steps"] = r.steps;
  d["seconds"] = r.seconds;
  d["reason"] = r.reason.empty() ? nb::none() : nb::cast(r.reason);
  nb::dict failures;
  for (const auto& [reason, count] : r.failures) failures[nb::cast(reason)] = count;
  d["failures"] = failures;
  return d;
}

}  // namespace

void BindGraspgen(nb::module_& m) {
  m.def(
      "generate_grasps",
      [](const std::filesystem::path& library_dir, std::vector<std::string> uids,
         const std::string& robot, bool joints, int64_t max_grasps, uint64_t seed, int threads,
         bool overwrite, const std::string& dtype, const std::filesystem::path& output_dir,
         bool progress, double min_quality) {
        if (max_grasps < 1) throw UsageError("max_grasps must be at least 1");
        if (dtype != "f2" && dtype != "f8" && dtype != "float16" && dtype != "float64") {
          throw UsageError("dtype must be 'f2' (float16) or 'f8' (float64), got '" + dtype + "'");
        }
        graspgen::GenerateOptions o;
        o.library_dir = library_dir;
        o.output_dir = output_dir;
        o.uids = std::move(uids);
        o.robot = robot;
        o.joints = joints;
        o.max_grasps = static_cast<size_t>(max_grasps);
        o.seed = seed;
        o.threads = threads;
        o.overwrite = overwrite;
        o.float64 = dtype == "f8" || dtype == "float64";
        o.progress = progress;
        o.candidates.min_quality = min_quality;
        graspgen::GenerateReport report;
        {
          nb::gil_scoped_release no_gil;
          report = graspgen::GenerateGrasps(o);
        }
        nb::list objects;
        for (const auto& r : report.objects) objects.append(ReportToPython(r));
        nb::dict out;
        out["objects"] = objects;
        out["index"] = report.index.empty() ? nb::none() : nb::cast(report.index.string());
        return out;
      },
      nb::arg("library_dir"), nb::kw_only(), nb::arg("uids") = std::vector<std::string>{},
      nb::arg("robot") = "droid", nb::arg("joints") = false, nb::arg("max_grasps") = 1000,
      nb::arg("seed") = 0, nb::arg("threads") = 0, nb::arg("overwrite") = false,
      nb::arg("dtype") = "f2", nb::arg("output_dir") = std::filesystem::path(),
      nb::arg("progress") = true, nb::arg("min_quality") = graspgen::CandidateParams{}.min_quality,
      "The engine of mlspaces.grasp_generation.generate_grasps: GenerateGrasps' report as "
      "{'objects': [dict per object or joint], 'index': path or None}");
}

}  // namespace mlspaces::python
