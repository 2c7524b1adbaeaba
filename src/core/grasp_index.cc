#include "mlspaces/core/grasp_index.h"

#include <set>
#include <string_view>
#include <system_error>

#include "library_walk.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"

namespace mlspaces {
namespace fs = std::filesystem;
namespace {

constexpr std::string_view kPickupName = "grasps.npz";
constexpr std::string_view kJointPrefix = "joint_grasps_";
constexpr std::string_view kNpz = ".npz";

void RequireObject(const FlatJson& value, const std::string& file, const std::string& pointer) {
  if (!value.is_object()) {
    throw Error("expected object, got " + JsonTypeWord(value), file, pointer.empty() ? "/" : pointer);
  }
}

std::string Child(const std::string& pointer, const std::string& key) {
  return pointer + "/" + JsonPointerToken(key);
}

// Splits a '/'-separated relative folder into its last two components (uid, robot).
// Returns false when it has fewer than two.
bool UidAndRobot(const std::string& rel_dir, std::string* uid, std::string* robot) {
  size_t last = rel_dir.rfind('/');
  if (rel_dir.empty() || last == std::string::npos) return false;
  *robot = rel_dir.substr(last + 1);
  size_t prev = last == 0 ? std::string::npos : rel_dir.rfind('/', last - 1);
  *uid = rel_dir.substr(prev == std::string::npos ? 0 : prev + 1,
                        last - (prev == std::string::npos ? 0 : prev + 1));
  return !uid->empty() && !robot->empty();
}

void AppendIndent(std::string& out, int level) { out.append(static_cast<size_t>(level) * 4, ' '); }

}  // namespace

std::vector<std::string> GraspIndex::robots() const {
  std::set<std::string> names;
  for (const auto& [robot, uids] : grasp_paths) names.insert(robot);
  for (const auto& [robot, uids] : articulated_grasp_paths) names.insert(robot);
  return {names.begin(), names.end()};
}

GraspIndex GraspIndex::Load(const fs::path& index_file) {
  const std::string file = index_file.string();
  FlatJson root = ParseFlatJsonFile(index_file);
  RequireObject(root, file, "");
  GraspIndex index;
  if (auto it = root.find("grasp_paths"); it != root.end()) {
    const std::string p0 = "/grasp_paths";
    RequireObject(*it, file, p0);
    for (auto r = it->begin(); r != it->end(); ++r) {
      const std::string p1 = Child(p0, r.key());
      RequireObject(r.value(), file, p1);
      auto& uids = index.grasp_paths[r.key()];
      for (auto u = r.value().begin(); u != r.value().end(); ++u) {
        if (!u.value().is_string()) {
          throw Error("expected string, got " + JsonTypeWord(u.value()), file, Child(p1, u.key()),
                      u.key());
        }
        uids[u.key()] = u.value().get<std::string>();
      }
    }
  }
  if (auto it = root.find("articulated_grasp_paths"); it != root.end()) {
    const std::string p0 = "/articulated_grasp_paths";
    RequireObject(*it, file, p0);
    for (auto r = it->begin(); r != it->end(); ++r) {
      const std::string p1 = Child(p0, r.key());
      RequireObject(r.value(), file, p1);
      auto& uids = index.articulated_grasp_paths[r.key()];
      for (auto u = r.value().begin(); u != r.value().end(); ++u) {
        const std::string p2 = Child(p1, u.key());
        RequireObject(u.value(), file, p2);
        auto& joints = uids[u.key()];
        for (auto j = u.value().begin(); j != u.value().end(); ++j) {
          if (!j.value().is_string()) {
            throw Error("expected string, got " + JsonTypeWord(j.value()), file, Child(p2, j.key()),
                        u.key());
          }
          joints[j.key()] = j.value().get<std::string>();
        }
      }
    }
  }
  return index;
}

std::string GraspIndex::Serialize() const {
  std::string out = "{\n    \"articulated_grasp_paths\": ";
  if (articulated_grasp_paths.empty()) {
    out += "{}";
  } else {
    out += "{\n";
    bool first_robot = true;
    for (const auto& [robot, uids] : articulated_grasp_paths) {
      if (!first_robot) out += ",\n";
      first_robot = false;
      AppendIndent(out, 2);
      internal::AppendJsonString(out, robot);
      out += ": ";
      if (uids.empty()) {
        out += "{}";
        continue;
      }
      out += "{\n";
      bool first_uid = true;
      for (const auto& [uid, joints] : uids) {
        if (!first_uid) out += ",\n";
        first_uid = false;
        AppendIndent(out, 3);
        internal::AppendJsonString(out, uid);
        out += ": ";
        if (joints.empty()) {
          out += "{}";
          continue;
        }
        out += "{\n";
        bool first_joint = true;
        for (const auto& [joint, path] : joints) {
          if (!first_joint) out += ",\n";
          first_joint = false;
          AppendIndent(out, 4);
          internal::AppendJsonString(out, joint);
          out += ": ";
          internal::AppendJsonString(out, path);
        }
        out += "\n";
        AppendIndent(out, 3);
        out += "}";
      }
      out += "\n";
      AppendIndent(out, 2);
      out += "}";
    }
    out += "\n    }";
  }
  out += ",\n    \"grasp_paths\": ";
  if (grasp_paths.empty()) {
    out += "{}";
  } else {
    out += "{\n";
    bool first_robot = true;
    for (const auto& [robot, uids] : grasp_paths) {
      if (!first_robot) out += ",\n";
      first_robot = false;
      AppendIndent(out, 2);
      internal::AppendJsonString(out, robot);
      out += ": ";
      if (uids.empty()) {
        out += "{}";
        continue;
      }
      out += "{\n";
      bool first_uid = true;
      for (const auto& [uid, path] : uids) {
        if (!first_uid) out += ",\n";
        first_uid = false;
        AppendIndent(out, 3);
        internal::AppendJsonString(out, uid);
        out += ": ";
        internal::AppendJsonString(out, path);
      }
      out += "\n";
      AppendIndent(out, 2);
      out += "}";
    }
    out += "\n    }";
  }
  out += "\n}";
  return out;
}

GraspIndex BuildGraspIndex(const fs::path& dir, IndexReport* report) {
  const fs::path root = internal::ResolvePath(dir);
  GraspIndex index;
  internal::WalkSorted(root, [&](const internal::WalkDir& d, const internal::WalkEntry& e) {
    const std::string& name = e.name;
    const bool pickup = name == kPickupName;
    const bool joint = !pickup && name.size() >= kJointPrefix.size() + kNpz.size() &&
                       name.starts_with(kJointPrefix) && name.ends_with(kNpz);
    if (!pickup && !joint) return;
    std::string uid, robot;
    if (!UidAndRobot(d.rel, &uid, &robot)) {
      throw Error("grasp files must be at <uid>/<robot>/" + name +
                      " (at least two folders below the library root)",
                  d.AbsChild(name));
    }
    const std::string rel = d.RelChild(name);
    if (pickup) {
      auto [it, inserted] = index.grasp_paths[robot].try_emplace(uid, rel);
      if (!inserted) {
        throw Error("duplicate grasps for robot '" + robot + "' and uid '" + uid + "': " +
                        it->second + " and " + rel,
                    {}, {}, uid);
      }
      return;
    }
    const std::string joint_name =
        name.substr(kJointPrefix.size(), name.size() - kJointPrefix.size() - kNpz.size());
    if (joint_name.empty()) {
      throw Error("empty joint name (expected joint_grasps_<joint>.npz)", d.AbsChild(name), {},
                  uid);
    }
    auto [it, inserted] =
        index.articulated_grasp_paths[robot][uid].try_emplace(joint_name, rel);
    if (!inserted) {
      throw Error("duplicate joint grasps for robot '" + robot + "', uid '" + uid +
                      "' and joint '" + joint_name + "': " + it->second + " and " + rel,
                  {}, {}, uid);
    }
  });
  if (report != nullptr) {
    report->robots = index.grasp_paths.size();
    report->count = 0;
    for (const auto& [robot, uids] : index.grasp_paths) report->count += uids.size();
  }
  return index;
}

IndexReport WriteGraspIndex(const fs::path& dir, const GraspIndexOptions& options) {
  const fs::path root = internal::ResolvePath(dir);
  IndexReport report;
  report.output = options.output.empty() ? root / "grasps_index.json" : internal::ResolvePath(options.output);
  std::error_code ec;
  if (fs::exists(report.output, ec) && !options.overwrite) {
    throw Error(report.output.string() + " already exists. Use --overwrite to overwrite.");
  }
  GraspIndex index = BuildGraspIndex(root, &report);
  WriteFileAtomic(report.output, index.Serialize());
  return report;
}

}  // namespace mlspaces
