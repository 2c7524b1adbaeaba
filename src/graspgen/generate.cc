// The grasp-generation job over an asset library (generate.h, docs/graspgen.md).
#include "mlspaces/graspgen/generate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <set>

#include "mlspaces/core/error.h"
#include "mlspaces/core/npz.h"
#include "mlspaces/core/progress.h"
#include "mlspaces/core/rng.h"
#include "mlspaces/graspgen/joints.h"
#include "mlspaces/graspgen/ordering.h"
#include "mlspaces/library/asset_index.h"
#include "mlspaces/library/grasp_index.h"
#include "mlspaces/robots/robot_spec.h"

namespace mlspaces::graspgen {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

// Smallest and largest side of the mesh's bounding box in its own frame (m).
std::pair<double, double> BoxSides(const TriMesh& mesh) {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Vec3& v : mesh.vertices) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], v[k]);
      hi[k] = std::max(hi[k], v[k]);
    }
  }
  double smallest = 1e300, largest = 0;
  for (int k = 0; k < 3; ++k) {
    smallest = std::min(smallest, hi[k] - lo[k]);
    largest = std::max(largest, hi[k] - lo[k]);
  }
  return {smallest, largest};
}

// Below this largest side an object is too small to be held between the pads.
constexpr double kSmallest = 0.01;

std::string Mm(double metres) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.0f mm", metres * 1000);
  return buf;
}

// Why a mesh gave no candidate: its size against the gripper, else the filters.
// ": the object is probably too big for the gripper (...)" when its bounding box is wider
// than the opening every way, else "".
std::string SizeHint(const TriMesh& mesh, double opening) {
  auto [smallest, largest] = BoxSides(mesh);
  if (smallest > opening) {
    return "; the object is probably too big for the gripper: its narrowest bounding-box side "
           "is " +
           Mm(smallest) + ", the fingers open " + Mm(opening);
  }
  if (largest < kSmallest) {
    return "; the object is probably too small for the gripper: its largest side is " + Mm(largest);
  }
  return {};
}

// Why a mesh gave no candidate: the filter that removed them all, and its size.
std::string NoCandidateReason(const TriMesh& mesh, const CandidateStats& stats, double opening) {
  std::string why =
      stats.collision_free == 0
          ? "no candidate clears the open hand (" + std::to_string(stats.visible) + " visible of " +
                std::to_string(stats.raw) + ")"
          : "no antipodal candidate (" + std::to_string(stats.collision_free) +
                " collision-free candidates, none with opposing contacts within the fingers' "
                "reach)";
  return why + SizeHint(mesh, opening);
}

// "lost during shake 61%, slipped 30%" from the failure counts, largest first.
std::string FailureSummary(const std::map<std::string, size_t>& failures, size_t tested) {
  std::vector<std::pair<size_t, std::string>> sorted;
  sorted.reserve(failures.size());
  for (const auto& [reason, count] : failures) sorted.emplace_back(count, reason);
  std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) {
    return a.first > b.first || (a.first == b.first && a.second < b.second);
  });
  std::string out;
  for (size_t i = 0; i < sorted.size() && i < 3; ++i) {
    if (!out.empty()) out += ", ";
    out += sorted[i].second + " " +
           std::to_string(tested ? (100 * sorted[i].first + tested / 2) / tested : 0) + "%";
  }
  return out;
}

void WriteTransforms(const fs::path& file, const std::vector<Mat4>& poses, bool float64) {
  std::vector<double> values;
  values.reserve(poses.size() * 16);
  for (const Mat4& pose : poses) values.insert(values.end(), pose.m.begin(), pose.m.end());
  NpyArray array =
      NpyArray::FromDoubles(float64 ? DType::kF8 : DType::kF2, {poses.size(), 4, 4}, values);
  NpzWriteOptions write;
  write.compress = true;  // np.savez_compressed, as the original
  fs::create_directories(file.parent_path());
  WriteNpz(file, {{"transforms", std::move(array)}}, write);
}

// Joint names become part of a file name, and index-grasps reads them back from it.
bool JointNameFitsFile(const std::string& joint) {
  return !joint.empty() && joint.find('/') == std::string::npos &&
         joint.find('\\') == std::string::npos && joint.find('\0') == std::string::npos;
}

struct ObjectEntry {
  std::string uid;
  fs::path asset;
};

std::vector<ObjectEntry> ListObjects(const GenerateOptions& options) {
  const fs::path& dir = options.library_dir;
  if (!fs::is_directory(dir)) throw Error("asset library folder not found", dir.string());
  AssetIndex index;
  fs::path index_file = dir / "assets_index.json";
  if (fs::exists(index_file)) {
    index = AssetIndex::Load(index_file);
  } else {
    AssetIndexOptions scan;
    scan.suppress_missing_metadata = true;
    IndexReport ignored;
    index = BuildAssetIndex(dir, scan, &ignored);
  }
  std::vector<ObjectEntry> objects;
  if (options.uids.empty()) {
    for (const auto& [uid, entry] : index.entries)
      objects.push_back({uid, dir / entry.object_path});
    return objects;
  }
  std::set<std::string> seen;
  for (const std::string& uid : options.uids) {
    auto it = index.entries.find(uid);
    if (it == index.entries.end()) {
      throw Error("unknown UID '" + uid + "' (not in the asset library)",
                  fs::exists(index_file) ? index_file.string() : dir.string(), {}, uid);
    }
    if (seen.insert(uid).second) objects.push_back({uid, dir / it->second.object_path});
  }
  return objects;
}

class Runner {
 public:
  Runner(const GenerateOptions& options, const std::function<void(const ObjectReport&)>& on_object)
      : options_(options), on_object_(on_object) {
    out_ = options.output_dir.empty() ? options.library_dir : options.output_dir;
    robot_ = robots::LoadRobotSpec(RobotForGraspLibrary(options.robot));
    gripper_ = GripperProxyOf(robot_);
    params_ = options.candidates;
    params_.threads = options.threads;
    sim_ = options.sim;
    sim_.threads = options.threads;
  }

  GenerateReport Run() {
    GenerateReport report;
    for (const ObjectEntry& object : ListObjects(options_)) {
      if (options_.joints) {
        RunJoints(object, &report);
      } else {
        Finish(RunRigid(object), &report);
      }
    }
    bool any_file = std::any_of(report.objects.begin(), report.objects.end(), [](const auto& o) {
      return !o.output.empty() && fs::exists(o.output);
    });
    if (any_file || removed_any_) {
      GraspIndexOptions index;
      index.overwrite = true;
      report.index = WriteGraspIndex(out_, index).output;
    }
    return report;
  }

 private:
  void Finish(ObjectReport object, GenerateReport* report) {
    // --overwrite asked for new grasps: an object that now gives none keeps no old file, which
    // the index would otherwise still list.
    std::error_code ec;
    if (options_.overwrite && object.status == ObjectReport::Status::kFailed &&
        !object.output.empty() && fs::exists(object.output, ec) && fs::remove(object.output, ec)) {
      object.reason += " (removed the old " + object.output.filename().string() + ")";
      removed_any_ = true;
    }
    if (on_object_) on_object_(object);
    report->objects.push_back(std::move(object));
  }

  // Each candidate moved along its closing axis so both fingers reach the surface together
  // (CenteredTcp); the open-hand and approach checks of the simulation still apply. Rigid
  // objects only: a free object pushed by the first finger is what this avoids (acceptance on
  // a 10-part mug 10% -> 15%, a box 21% -> 34%); on a fixed handle it lowered acceptance.
  void Center(const MeshBvh& bvh, CandidateSet* set) const {
    for (GraspCandidate& c : set->candidates) c.tcp = CenteredTcp(bvh, gripper_, c.tcp);
  }

  // Keeps at least min_support_fraction of the kept grasps usable from the object's support
  // (SupportClear): when the covering order kept fewer, the untested candidates whose open
  // hand clears the support are tested in order, and their successes replace the last kept
  // grasps that do not clear it. `run` covers a prefix of `order`.
  template <typename Progress>
  void EnsureSupportGrasps(const GraspScene& scene, const CandidateSet& set,
                           const std::vector<size_t>& order, SimRun* run,
                           const Progress& progress) const {
    const size_t kept = run->accepted.size();
    const size_t want = std::min(
        kept, std::max<size_t>(1, static_cast<size_t>(std::ceil(options_.min_support_fraction *
                                                                static_cast<double>(kept)))));
    std::vector<char> clear(kept);
    size_t have = 0;
    for (size_t i = 0; i < kept; ++i) have += clear[i] = scene.SupportClear(run->poses[i]);
    if (have >= want || run->tested >= order.size()) return;
    std::vector<size_t> rest;
    for (size_t k = run->tested; k < order.size(); ++k) {
      if (scene.AboveSupport(set.candidates[order[k]].tcp)) rest.push_back(order[k]);
    }
    if (rest.empty()) return;
    SimRun more = TestCandidates(scene, set.candidates, rest, want - have, nullptr, sim_,
                                 progress(run->tested, kept));
    run->tested += more.tested;
    run->steps += more.steps;
    for (const auto& [reason, count] : more.failures) run->failures[reason] += count;
    // Drop the last kept grasps that do not clear the support, one per new grasp.
    size_t drop = more.accepted.size();
    for (size_t i = kept; i-- > 0 && drop > 0;) {
      if (clear[i]) continue;
      run->accepted.erase(run->accepted.begin() + static_cast<ptrdiff_t>(i));
      run->poses.erase(run->poses.begin() + static_cast<ptrdiff_t>(i));
      --drop;
    }
    run->accepted.insert(run->accepted.end(), more.accepted.begin(), more.accepted.end());
    run->poses.insert(run->poses.end(), more.poses.begin(), more.poses.end());
  }

  // Orders, simulates and writes one candidate set; fills the counts of `report`.
  void TestAndWrite(const GraspScene& scene, const CandidateSet& set, const JointTarget* target,
                    const TriMesh& mesh, uint64_t seed, ObjectReport* report) {
    report->candidates = set.candidates.size();
    std::vector<size_t> order = OrderCandidates(set.candidates, OrderParams{}, seed);
    std::string label = report->uid + (report->joint.empty() ? "" : ":" + report->joint);
    ProgressBar bar(label, options_.max_grasps, options_.progress);
    bar.Start(0, "simulating");
    // Test the first give_up_after in order; go on only if one of them passed.
    auto progress = [&](size_t base_tested, size_t base_accepted) {
      return [&bar, base_tested, base_accepted](size_t tested, size_t accepted) {
        bar.Update(base_accepted + accepted, std::to_string(base_tested + tested) + " tested");
      };
    };
    size_t first = std::min(order.size(), std::max<size_t>(options_.give_up_after, 1));
    std::vector<size_t> head(order.begin(), order.begin() + static_cast<ptrdiff_t>(first));
    SimRun run = TestCandidates(scene, set.candidates, head, options_.max_grasps, target, sim_,
                                progress(0, 0));
    if (!run.accepted.empty() && run.accepted.size() < options_.max_grasps &&
        first < order.size()) {
      std::vector<size_t> tail(order.begin() + static_cast<ptrdiff_t>(first), order.end());
      SimRun rest =
          TestCandidates(scene, set.candidates, tail, options_.max_grasps - run.accepted.size(),
                         target, sim_, progress(run.tested, run.accepted.size()));
      run.accepted.insert(run.accepted.end(), rest.accepted.begin(), rest.accepted.end());
      run.poses.insert(run.poses.end(), rest.poses.begin(), rest.poses.end());
      run.tested += rest.tested;
      run.steps += rest.steps;
      for (const auto& [reason, count] : rest.failures) run.failures[reason] += count;
    }
    if (target == nullptr && sim_.support_test && !run.accepted.empty()) {
      EnsureSupportGrasps(scene, set, order, &run, progress);
    }
    bar.Finish();
    report->tested = run.tested;
    report->accepted = run.accepted.size();
    report->steps = run.steps;
    report->failures = run.failures;
    if (run.accepted.empty()) {
      report->reason =
          "no candidate passed the simulation (" + std::to_string(run.tested) +
          (run.tested < order.size() ? " tested, the first in test order" : " tested") + ": " +
          FailureSummary(run.failures, run.tested) + ")" + SizeHint(mesh, robot_.finger_range[1]);
      return;
    }
    WriteTransforms(report->output, run.poses, options_.float64);
    report->status = ObjectReport::Status::kDone;
  }

  ObjectReport RunRigid(const ObjectEntry& object) {
    ObjectReport report;
    report.uid = object.uid;
    report.asset = object.asset;
    report.output = out_ / object.uid / options_.robot / "grasps.npz";
    if (!options_.overwrite && fs::exists(report.output)) {
      report.status = ObjectReport::Status::kSkipped;
      report.reason = "exists";
      return report;
    }
    Clock::time_point t0 = Clock::now();
    try {
      // One compiled model per object: the scene's, whose collision mesh the candidates use.
      GraspScene scene(object.asset, robot_, GraspScene::Mode::kRigid, sim_);
      const MeshBvh& bvh = scene.object_mesh();
      uint64_t seed = DeriveSeed(options_.seed, {HashString(object.uid)});
      CandidateSet set = GenerateCandidates(bvh, gripper_, params_, seed);
      Center(bvh, &set);
      if (set.candidates.empty()) {
        report.reason = NoCandidateReason(bvh.mesh(), set.stats, robot_.finger_range[1]);
      } else {
        TestAndWrite(scene, set, nullptr, bvh.mesh(), DeriveSeed(seed, {1}), &report);
      }
    } catch (const std::exception& e) {
      report.status = ObjectReport::Status::kFailed;
      report.reason = e.what();
    }
    report.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    return report;
  }

  void RunJoints(const ObjectEntry& object, GenerateReport* report) {
    ObjectReport base;
    base.uid = object.uid;
    base.asset = object.asset;
    Clock::time_point t0 = Clock::now();
    std::vector<JointTarget> targets;
    try {
      targets = FindJointTargets(object.asset);
    } catch (const Error& e) {
      // A rigid object in a --joints run: nothing to do, not a failure.
      bool no_joint = e.message().starts_with("no hinge or slide joint");
      base.status = no_joint ? ObjectReport::Status::kSkipped : ObjectReport::Status::kFailed;
      base.reason = no_joint ? "no hinge or slide joint" : e.what();
      base.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
      Finish(std::move(base), report);
      return;
    } catch (const std::exception& e) {
      base.reason = e.what();
      base.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
      Finish(std::move(base), report);
      return;
    }
    std::unique_ptr<GraspScene> scene;
    for (const JointTarget& target : targets) {
      ObjectReport joint = base;
      joint.joint = target.joint;
      joint.output = out_ / object.uid / options_.robot / ("joint_grasps_" + target.joint + ".npz");
      Clock::time_point tj = Clock::now();
      if (!JointNameFitsFile(target.joint)) {
        joint.reason = "joint name '" + target.joint +
                       "' cannot be part of a file name joint_grasps_<joint>.npz";
        joint.output.clear();
      } else if (!options_.overwrite && fs::exists(joint.output)) {
        joint.status = ObjectReport::Status::kSkipped;
        joint.reason = "exists";
      } else if (target.handle.faces.empty()) {
        joint.reason = "joint " + target.joint +
                       " has no handle geometry (no collision geom in "
                       "the subtree of body " +
                       target.body + ")";
      } else {
        try {
          uint64_t seed =
              DeriveSeed(options_.seed, {HashString(object.uid), HashString(target.joint)});
          CandidateSet set = GenerateJointCandidates(target, gripper_, params_, seed);
          if (set.candidates.empty()) {
            joint.reason = NoCandidateReason(target.handle, set.stats, robot_.finger_range[1]);
          } else {
            if (!scene) {
              scene = std::make_unique<GraspScene>(object.asset, robot_,
                                                   GraspScene::Mode::kArticulated, sim_);
            }
            TestAndWrite(*scene, set, &target, target.handle, DeriveSeed(seed, {1}), &joint);
          }
        } catch (const std::exception& e) {
          joint.status = ObjectReport::Status::kFailed;
          joint.reason = e.what();
        }
      }
      joint.seconds = std::chrono::duration<double>(Clock::now() - tj).count();
      Finish(std::move(joint), report);
    }
  }

  const GenerateOptions& options_;
  const std::function<void(const ObjectReport&)>& on_object_;
  fs::path out_;
  robots::RobotSpec robot_;
  GripperProxy gripper_;
  CandidateParams params_;
  SimParams sim_;
  bool removed_any_ = false;  // a stale file removed: the index is rewritten
};

std::string Thousands(uint64_t n) {
  std::string digits = std::to_string(n), out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out.push_back(',');
    out.push_back(digits[i]);
  }
  return out;
}

}  // namespace

size_t GenerateReport::done() const {
  return std::count_if(objects.begin(), objects.end(),
                       [](const auto& o) { return o.status == ObjectReport::Status::kDone; });
}
size_t GenerateReport::skipped() const {
  return std::count_if(objects.begin(), objects.end(),
                       [](const auto& o) { return o.status == ObjectReport::Status::kSkipped; });
}
size_t GenerateReport::failed() const {
  return std::count_if(objects.begin(), objects.end(),
                       [](const auto& o) { return o.status == ObjectReport::Status::kFailed; });
}

std::string RobotForGraspLibrary(const std::string& robot) {
  if (robot == "droid" || robot == "franka_droid") return "franka_droid";
  const std::vector<std::string> known = robots::BundledRobots();
  if (std::find(known.begin(), known.end(), robot) != known.end()) return robot;
  std::string names = "droid (franka_droid)";
  for (const std::string& name : known) {
    if (name != "franka_droid") names += ", " + name;
  }
  throw UsageError("no robot '" + robot + "' for grasp generation (known: " + names +
                   "; $MLSPACES_ROBOT_PATH adds your own)");
}

GenerateReport GenerateGrasps(const GenerateOptions& options,
                              const std::function<void(const ObjectReport&)>& on_object) {
  if (options.max_grasps == 0) throw UsageError("max_grasps must be at least 1");
  const double q = options.candidates.min_quality;
  if (!(q >= 0 && q <= 1)) {
    throw UsageError("min_quality must be in [0, 1] (a cosine), got " + std::to_string(q));
  }
  if (options.robot.empty() || options.robot.find('/') != std::string::npos) {
    throw UsageError("robot must be a folder name, got '" + options.robot + "'");
  }
  Runner runner(options, on_object);
  return runner.Run();
}

std::string ObjectReportLine(const ObjectReport& report) {
  std::string name = report.uid + (report.joint.empty() ? "" : ":" + report.joint);
  char secs[32];
  std::snprintf(secs, sizeof secs, "%.1f s", report.seconds);
  switch (report.status) {
    case ObjectReport::Status::kSkipped:
      return name + ": skipped (" + report.reason + ")";
    case ObjectReport::Status::kFailed:
      return name + ": failed: " + report.reason;
    case ObjectReport::Status::kDone:
      break;
  }
  std::string line = name + ": " + Thousands(report.accepted) + " grasps (" +
                     Thousands(report.tested) + " tested of " + Thousands(report.candidates) +
                     " candidates";
  if (report.accepted > 0) {
    line +=
        ", " + Thousands(static_cast<uint64_t>(report.steps) / report.accepted) + " steps/grasp";
  }
  return line + ") in " + secs;
}

}  // namespace mlspaces::graspgen
