#include "mlspaces/library/grasp_index.h"

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
    throw Error("expected object, got " + JsonTypeWord(value), file,
                pointer.empty() ? "/" : pointer);
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

// Writes a path map ({uid: path} or {uid: {joint: path}}) as the original's json.dump(indent=4)
// does, its closing brace at `level`; an empty map is "{}".
void AppendPaths(std::string& out, const std::string& path, int /*level*/) {
  internal::AppendJsonString(out, path);
}
template <class Map>
void AppendPaths(std::string& out, const Map& map, int level) {
  if (map.empty()) {
    out += "{}";
    return;
  }
  out += "{\n";
  bool first = true;
  for (const auto& [key, value] : map) {
    if (!first) out += ",\n";
    first = false;
    AppendIndent(out, level + 1);
    internal::AppendJsonString(out, key);
    out += ": ";
    AppendPaths(out, value, level + 1);
  }
  out += "\n";
  AppendIndent(out, level);
  out += "}";
}

// Reads a {robot: {uid: path}} or {robot: {uid: {joint: path}}} section: objects down to string
// leaves. `depth` is 0 for the section itself; errors below the uid level name the uid.
void ReadPaths(const FlatJson& value, const std::string& file, const std::string& pointer,
               const std::string& uid, int /*depth*/, std::string* path) {
  if (!value.is_string()) {
    throw Error("expected string, got " + JsonTypeWord(value), file, pointer, uid);
  }
  *path = value.get<std::string>();
}
template <class Map>
void ReadPaths(const FlatJson& value, const std::string& file, const std::string& pointer,
               const std::string& uid, int depth, Map* map) {
  RequireObject(value, file, pointer);
  for (auto it = value.begin(); it != value.end(); ++it) {
    const std::string& key = it.key();
    ReadPaths(it.value(), file, Child(pointer, key), depth == 1 ? key : uid, depth + 1,
              &(*map)[key]);
  }
}

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
    ReadPaths(*it, file, "/grasp_paths", {}, 0, &index.grasp_paths);
  }
  if (auto it = root.find("articulated_grasp_paths"); it != root.end()) {
    ReadPaths(*it, file, "/articulated_grasp_paths", {}, 0, &index.articulated_grasp_paths);
  }
  return index;
}

std::string GraspIndex::Serialize() const {
  std::string out = "{\n    \"articulated_grasp_paths\": ";
  AppendPaths(out, articulated_grasp_paths, 1);
  out += ",\n    \"grasp_paths\": ";
  AppendPaths(out, grasp_paths, 1);
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
    if (e.kind == internal::WalkEntry::Kind::kSymlink && !d.HasFile(name)) {
      throw Error("broken symbolic link: its target does not exist", d.AbsChild(name));
    }
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
        throw Error("duplicate grasps for robot '" + robot + "' and uid '" + uid +
                        "': " + it->second + " and " + rel,
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
    auto [it, inserted] = index.articulated_grasp_paths[robot][uid].try_emplace(joint_name, rel);
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
  report.output =
      internal::IndexOutputPath(root, options.output, "grasps_index.json", options.overwrite);
  GraspIndex index = BuildGraspIndex(root, &report);
  WriteFileAtomic(report.output, index.Serialize());
  return report;
}

}  // namespace mlspaces
