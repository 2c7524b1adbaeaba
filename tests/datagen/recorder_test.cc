#include "mlspaces/datagen/recorder.h"

#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <thread>

#include "mlspaces/core/error.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ExpectError;
using ::mlspaces::testing::ListFiles;
using ::mlspaces::testing::RunPython;
using ::mlspaces::testing::ShellQuote;
using ::mlspaces::testing::Slurp;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

// A pick-like episode of `t` observations that ends with the done action (terminated) unless
// `timeout`, in which case the horizon truncates it.
EpisodeRecord MakeEpisode(size_t t, bool timeout = false, double offset = 0.0) {
  EpisodeRecord r;
  r.meta.config_hash = "sha256:0123abcd";
  r.meta.seed = 18446744073709551557ull;  // > 2^63: must survive JSON as an exact integer
  r.meta.scene = "house_0";
  r.meta.source_episode = 7;
  r.meta.task_description = "Pick up the block";
  r.meta.assets = {{"red_block", "custom_assets", "CC-BY-4.0", "pickup_obj"},
                   {"franka_droid", "mlspaces", "Apache-2.0", "robot"}};
  r.meta.mujoco_version = "2.2.2";
  r.meta.mlspaces_version = "0.1.0";
  r.meta.extra = Json{{"policy", "pick_planner"}};
  Series base(DType::kFloat32, {7});
  Series phase(DType::kInt64, {});
  Series points(DType::kFloat32, {10, 2});
  Series num_points(DType::kInt32, {1});
  Series panda(DType::kFloat32, {31});
  Series c2w(DType::kFloat64, {4, 4}), extr(DType::kFloat64, {3, 4}), intr(DType::kFloat64, {3, 3});
  JsonSeries task_info{{}, 4000};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (size_t i = 0; i < t; ++i) {
    const double s = static_cast<double>(i) + offset;
    r.qpos.push_back({{"arm", {0.1 * s, 0.2, 0.3, -1.5, 0, 1.6, 0.7}},
                      {"base", {}},
                      {"gripper", {0.01 * s, 0.02}}});
    r.qvel.push_back({{"arm", {0, 0, 0, 0, 0, 0, s}}, {"base", {}}, {"gripper", {0, 0}}});
    const bool first = i == 0, last = i + 1 == t;
    r.actions["commanded_action"].push_back(
        first ? MoveGroupValues{}
              : MoveGroupValues{{"arm", {s, 0, 0, 0, 0, 0, 0}}, {"base", {}}, {"gripper", {255}}});
    r.actions["joint_pos"].push_back(
        last ? MoveGroupValues{}
             : MoveGroupValues{{"arm", {s, 1, 2, 3, 4, 5, 6}}, {"gripper", {0}}});
    base.Append({1, 2, 3, 1, 0, 0, 0});
    phase.AppendInts({static_cast<int64_t>(i)});
    std::vector<double> pts(20, nan);
    pts[0] = 0.25;
    pts[1] = 0.5;
    points.Append(pts);
    num_points.Append({1});
    std::vector<double> pv(31, 0.0);
    pv[0] = s;
    panda.Append(pv);
    c2w.Append({1, 0, 0, s, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});
    extr.Append({1, 0, 0, -s, 0, 1, 0, 0, 0, 0, 1, 0});
    intr.Append({320, 0, 320, 0, 320, 184, 0, 0, 1});
    task_info.steps.push_back(Json{
        {"success", last}, {"episode_step", i}, {"position_error", 0.05}, {"rotation_error", 0.0}});
    r.rewards.push_back(static_cast<float>(0.5 * s));
    r.success.push_back(last);
    r.terminated.push_back(last && !timeout);
    r.truncated.push_back(last && timeout);
  }
  r.extra["robot_base_pose"] = base;
  r.extra["policy_phase"] = phase;
  r.extra["object_image_points/pickup_obj/wrist_camera/points"] = points;
  r.extra["object_image_points/pickup_obj/wrist_camera/num_points"] = num_points;
  r.extra_json["task_info"] = task_info;
  r.env_states["articulations/panda"] = panda;
  CameraRecord cam;
  cam.name = "wrist_camera";
  cam.params = {{"cam2world_gl", c2w}, {"extrinsic_cv", extr}, {"intrinsic_cv", intr}};
  r.cameras.push_back(cam);
  r.obs_scene = Json{{"task_type", "pick"},
                     {"task_description", "Pick up the block"},
                     {"policy_dt_ms", 66.0},
                     {"object_name", "red_block"}};
  return r;
}

// Names the video of camera `cam` for the recorder's next episode and creates the file.
void AddVideo(const Recorder& rec, EpisodeRecord& r) {
  for (CameraRecord& c : r.cameras) {
    c.video_file = rec.VideoFileName(rec.next_index(), c.name);
    WriteText(rec.dir() / c.video_file, "not really an mp4");
  }
}

constexpr const char* kCheckScript = R"PY(
import json, sys
import h5py, numpy as np
f = h5py.File(sys.argv[1], "r")
assert list(f.keys()) == ["traj_0", "traj_1"], list(f.keys())
t0 = f["traj_0"]
T = 5
paths = []
t0.visit(lambda p: paths.append(p))
expect = {
  "actions": None, "actions/commanded_action": ("uint8", (T, 2000)),
  "actions/joint_pos": ("uint8", (T, 2000)),
  "env_states": None, "env_states/actors": None, "env_states/articulations": None,
  "env_states/articulations/panda": ("float32", (T, 31)),
  "fail": ("bool", (T,)), "rewards": ("float32", (T,)), "success": ("bool", (T,)),
  "terminated": ("bool", (T,)), "truncated": ("bool", (T,)), "obs_scene": ("object", ()),
  "obs": None, "obs/agent": None, "obs/agent/qpos": ("uint8", (T, 2000)),
  "obs/agent/qvel": ("uint8", (T, 2000)), "obs/extra": None,
  "obs/extra/robot_base_pose": ("float32", (T, 7)), "obs/extra/policy_phase": ("int64", (T,)),
  "obs/extra/task_info": ("uint8", (T, 4000)),
  "obs/extra/object_image_points": None, "obs/extra/object_image_points/pickup_obj": None,
  "obs/extra/object_image_points/pickup_obj/wrist_camera": None,
  "obs/extra/object_image_points/pickup_obj/wrist_camera/points": ("float32", (T, 10, 2)),
  "obs/extra/object_image_points/pickup_obj/wrist_camera/num_points": ("int32", (T, 1)),
  "obs/sensor_data": None, "obs/sensor_data/wrist_camera": ("uint8", (100,)),
  "obs/sensor_param": None, "obs/sensor_param/wrist_camera": None,
  "obs/sensor_param/wrist_camera/cam2world_gl": ("float64", (T, 4, 4)),
  "obs/sensor_param/wrist_camera/extrinsic_cv": ("float64", (T, 3, 4)),
  "obs/sensor_param/wrist_camera/intrinsic_cv": ("float64", (T, 3, 3)),
}
assert sorted(paths) == sorted(expect), sorted(set(paths) ^ set(expect))
for p, e in expect.items():
  obj = t0[p]
  if e is None:
    assert isinstance(obj, h5py.Group), p
  else:
    assert isinstance(obj, h5py.Dataset), p
    assert (str(obj.dtype), obj.shape) == e, (p, obj.dtype, obj.shape)
def rows(ds):
  return [json.loads(bytes(r).rstrip(b"\0")) for r in ds[()]]
qpos = rows(t0["obs/agent/qpos"])
f32 = lambda v: float(np.float32(v))
assert qpos[3] == {"arm": [f32(0.3), f32(0.2), f32(0.3), -1.5, 0.0, f32(1.6), f32(0.7)],
                   "base": [], "gripper": [f32(0.03), f32(0.02)]}, qpos[3]
raw = bytes(t0["obs/agent/qpos"][0]).rstrip(b"\0").decode()
assert raw == json.dumps(json.loads(raw), sort_keys=True, separators=(",", ":")), raw
assert rows(t0["obs/agent/qvel"])[2]["arm"][6] == 2.0
ca = rows(t0["actions/commanded_action"])
assert ca[0] == {} and ca[1] == {"arm": [1.0, 0, 0, 0, 0, 0, 0], "base": [], "gripper": [255.0]}
jp = rows(t0["actions/joint_pos"])
assert jp[4] == {} and jp[2] == {"arm": [2.0, 1, 2, 3, 4, 5, 6], "gripper": [0.0]}, jp
ti = rows(t0["obs/extra/task_info"])
assert ti[4] == {"success": True, "episode_step": 4, "position_error": 0.05, "rotation_error": 0.0}
assert t0["terminated"][()].tolist() == [False] * 4 + [True]
assert t0["truncated"][()].tolist() == [False] * 5
assert t0["success"][()].tolist() == [False] * 4 + [True]
assert t0["fail"][()].tolist() == [True] * 4 + [False]
assert t0["rewards"][()].tolist() == [0.0, 0.5, 1.0, 1.5, 2.0]
assert t0["obs/extra/policy_phase"][()].tolist() == [0, 1, 2, 3, 4]
pts = t0["obs/extra/object_image_points/pickup_obj/wrist_camera/points"][()]
assert pts[2, 0].tolist() == [0.25, 0.5] and np.isnan(pts[2, 1:]).all()
npts = t0["obs/extra/object_image_points/pickup_obj/wrist_camera/num_points"][()]
assert npts.ravel().tolist() == [1] * 5
assert t0["obs/extra/robot_base_pose"][1].tolist() == [1, 2, 3, 1, 0, 0, 0]
assert t0["env_states/articulations/panda"][3, :2].tolist() == [3.0, 0.0]
c2w = t0["obs/sensor_param/wrist_camera/cam2world_gl"][()]
assert c2w[3, 0, 3] == 3.0 and c2w[3, 3, 3] == 1.0
intr = t0["obs/sensor_param/wrist_camera/intrinsic_cv"][0].tolist()
assert intr == [[320, 0, 320], [0, 320, 184], [0, 0, 1]], intr
video = bytes(t0["obs/sensor_data/wrist_camera"][()]).rstrip(b"\0").decode()
assert video == "episode_00000000_wrist_camera_batch_1_of_1.mp4", video
video1 = bytes(f["traj_1/obs/sensor_data/wrist_camera"][()]).rstrip(b"\0").decode()
assert video1 == "episode_00000001_wrist_camera_batch_1_of_1.mp4", video1
import os
assert os.path.exists(os.path.join(os.path.dirname(sys.argv[1]), video))
scene = json.loads(t0["obs_scene"].asstr()[()])
assert scene == {"task_type": "pick", "task_description": "Pick up the block", "policy_dt_ms": 66.0,
                 "object_name": "red_block"}, scene
prov = json.loads(t0.attrs["provenance"])
assert prov["config_hash"] == "sha256:0123abcd"
assert prov["seed"] == 18446744073709551557
assert prov["episode_index"] == 0 and prov["source_episode"] == 7 and prov["scene"] == "house_0"
assert prov["assets"][0] == {"uid": "red_block", "library": "custom_assets", "license": "CC-BY-4.0",
                             "role": "pickup_obj"}, prov["assets"]
assert prov["mujoco_version"] == "2.2.2" and prov["mlspaces_version"] == "0.1.0"
assert prov["num_steps"] == 5 and prov["success"] is True and prov["terminated"] is True
assert prov["extra"] == {"policy": "pick_planner"}
p1 = json.loads(f["traj_1"].attrs["provenance"])
assert p1["episode_index"] == 1 and p1["truncated"] is True and p1["terminated"] is False
assert f["traj_1/terminated"][()].tolist() == [False] * 3
assert f["traj_1/truncated"][()].tolist() == [False, False, True]
assert f["traj_0/obs/agent/qpos"].compression == "gzip"
print("OK")
)PY";

TEST(RecorderTest, WritesTheOriginalLayoutReadableByH5py) {
  TempDir tmp;
  Recorder rec({tmp / "house_0"});
  EXPECT_EQ(rec.batch_file(), tmp / "house_0" / "trajectories_batch_1_of_1.h5");
  EpisodeRecord a = MakeEpisode(5);
  AddVideo(rec, a);
  EXPECT_EQ(rec.Write(a), 0);
  EXPECT_TRUE(fs::exists(rec.parts_dir() / "traj_00000000.h5"));
  EpisodeRecord b = MakeEpisode(3, /*timeout=*/true);
  AddVideo(rec, b);
  EXPECT_EQ(rec.Write(b), 1);
  EXPECT_TRUE(rec.Finish());
  EXPECT_THAT(ListFiles(tmp / "house_0"),
              ElementsAre("episode_00000000_wrist_camera_batch_1_of_1.mp4",
                          "episode_00000001_wrist_camera_batch_1_of_1.mp4",
                          "trajectories_batch_1_of_1.h5"));
  std::string out;
  ASSERT_EQ(RunPython(tmp.path(), kCheckScript, ShellQuote(rec.batch_file().string()), &out), 0);
  EXPECT_EQ(out, "OK\n");
  ExpectError([&] { rec.Write(a); }, {"already finished"});
}

TEST(RecorderTest, PartFilesAreReadableTrajectoriesOnTheirOwn) {
  TempDir tmp;
  Recorder rec({tmp.path(), 2, 3});
  EXPECT_EQ(rec.VideoFileName(12, "exo_camera_1_depth"),
            "episode_00000012_exo_camera_1_depth_batch_2_of_3.mp4");
  EpisodeRecord a = MakeEpisode(2);
  a.cameras[0].video_file = "";  // no video yet: no sensor_data entry, the group still exists
  rec.Write(a);
  const fs::path part = tmp / "trajectories_batch_2_of_3.parts/traj_00000000.h5";
  ASSERT_TRUE(fs::exists(part));
  std::string out;
  ASSERT_EQ(RunPython(tmp.path(),
                      "import sys, h5py\n"
                      "f = h5py.File(sys.argv[1], 'r')\n"
                      "print(list(f['traj_0/obs/sensor_data'].keys()), "
                      "f['traj_0/obs/agent/qpos'].shape)\n",
                      ShellQuote(part.string()), &out),
            0);
  EXPECT_EQ(out, "[] (2, 2000)\n");
}

TEST(RecorderTest, TerminatedAndTruncatedFollowTheTask) {
  TempDir tmp;
  Recorder rec({tmp.path()});
  EpisodeRecord r = MakeEpisode(3);
  r.cameras.clear();
  r.terminated = {false, true, false};
  ExpectError([&] { rec.Write(r); }, {"traj_0/terminated", "step 1 of 3"});
  r.terminated = {false, false, false};
  r.truncated = {true, false, true};
  ExpectError([&] { rec.Write(r); }, {"traj_0/truncated", "step 0"});
  r.truncated = {false, false, false};
  ExpectError([&] { rec.Write(r); }, {"traj_0/terminated", "neither terminated nor truncated"});
  // Done action on the horizon step: both flags.
  r.terminated = {false, false, true};
  r.truncated = {false, false, true};
  EXPECT_EQ(rec.Write(r), 0);
  rec.Finish();
  std::string out;
  ASSERT_EQ(RunPython(tmp.path(),
                      "import sys, h5py\n"
                      "t = h5py.File(sys.argv[1], 'r')['traj_0']\n"
                      "print(t['terminated'][()].tolist(), t['truncated'][()].tolist())\n",
                      ShellQuote(rec.batch_file().string()), &out),
            0);
  EXPECT_EQ(out, "[False, False, True] [False, False, True]\n");
}

TEST(RecorderTest, SameRecordsGiveByteIdenticalFiles) {
  TempDir tmp;
  auto write = [&](const std::string& name, double offset) {
    Recorder rec({tmp / name});
    EpisodeRecord r = MakeEpisode(4, false, offset);
    AddVideo(rec, r);
    rec.Write(r);
    std::string part = Slurp(rec.parts_dir() / "traj_00000000.h5");
    EpisodeRecord r2 = MakeEpisode(2, true, offset);
    AddVideo(rec, r2);
    rec.Write(r2);
    rec.Finish();
    return std::make_pair(part, Slurp(rec.batch_file()));
  };
  const auto a = write("a", 0);
  // HDF5 stores times with one-second resolution: a timestamp would differ after this.
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  const auto b = write("b", 0);
  const auto c = write("c", 0.5);
  ASSERT_FALSE(a.first.empty());
  ASSERT_FALSE(a.second.empty());
  EXPECT_TRUE(a.first == b.first) << "episode part files differ";
  EXPECT_TRUE(a.second == b.second) << "batch files differ";
  EXPECT_FALSE(a.second == c.second) << "different data, same bytes?";
}

// Without HDF5 (datagen --format lerobot) an episode is kept as its record, which a reopened
// Recorder (a resumed run) continues after and reads the provenance of, and which decodes to
// the same episode (NaN, integers past 2^63); Finish() renames the parts folder.
TEST(RecorderTest, WithoutHdf5EpisodesAreRecordsThatDecodeToTheSameEpisode) {
  TempDir tmp;
  RecorderOptions options{tmp / "rec"};
  options.hdf5 = false;
  const EpisodeRecord r0 = MakeEpisode(5);
  {
    Recorder rec(options);
    EpisodeRecord r = r0;
    AddVideo(rec, r);
    EXPECT_EQ(rec.Write(r), 0);
  }
  Recorder h5({tmp / "h5"});
  EpisodeRecord r = r0;
  AddVideo(h5, r);
  h5.Write(r);
  Recorder rec(options);
  EXPECT_EQ(rec.next_index(), 1);
  EXPECT_EQ(rec.PartProvenance(0), h5.PartProvenance(0));
  const std::string bytes = Slurp(rec.parts_dir() / "traj_00000000.rec");
  const EpisodeRecord back = DecodeEpisodeRecord(bytes, "traj_00000000.rec");
  EXPECT_EQ(EncodeEpisodeRecord(back), bytes);
  EXPECT_EQ(back.meta.seed, 18446744073709551557ull);
  const std::string pts = "object_image_points/pickup_obj/wrist_camera/points";
  EXPECT_TRUE(back.extra.at(pts).bytes() == r0.extra.at(pts).bytes());
  EXPECT_EQ(back.obs_scene.dump(), r0.obs_scene.dump());
  WriteEpisodeFile(back, 0, tmp / "a.h5");
  WriteEpisodeFile(r, 0, tmp / "b.h5");  // r: r0 with its video named as in the record
  EXPECT_TRUE(Slurp(tmp / "a.h5") == Slurp(tmp / "b.h5"));
  EpisodeRecord r1 = MakeEpisode(3, true);
  AddVideo(rec, r1);
  EXPECT_EQ(rec.Write(r1), 1);
  EXPECT_TRUE(rec.Finish());
  EXPECT_EQ(rec.batch_file(), tmp / "rec/trajectories_batch_1_of_1.episodes");
  EXPECT_FALSE(fs::exists(rec.parts_dir()));
  EXPECT_THAT(ListFiles(tmp / "rec"),
              ElementsAre("episode_00000000_wrist_camera_batch_1_of_1.mp4",
                          "episode_00000001_wrist_camera_batch_1_of_1.mp4",
                          "trajectories_batch_1_of_1.episodes/traj_00000000.rec",
                          "trajectories_batch_1_of_1.episodes/traj_00000001.rec"));
  ExpectError([&] { DecodeEpisodeRecord("not cbor", "x.rec"); },
              {"x.rec", "not an episode record"});
}

TEST(RecorderTest, BadInputNamesTheFieldAndWritesNothing) {
  TempDir tmp;
  Recorder rec({tmp.path()});
  const EpisodeRecord good = MakeEpisode(3);
  auto expect_bad = [&](const std::function<void(EpisodeRecord&)>& edit,
                        std::initializer_list<std::string> parts) {
    EpisodeRecord r = good;
    r.cameras[0].video_file.clear();
    edit(r);
    ExpectError([&] { rec.Write(r); }, parts);
    EXPECT_EQ(rec.next_index(), 0);
    EXPECT_TRUE(ListFiles(tmp.path()).empty());
  };
  expect_bad([](EpisodeRecord& r) { r.qvel.pop_back(); },
             {"traj_0/obs/agent/qvel", "has 2 steps, expected 3"});
  expect_bad([](EpisodeRecord& r) { r.rewards.push_back(0); }, {"traj_0/rewards", "has 4 steps"});
  expect_bad([](EpisodeRecord& r) { r.success.clear(); }, {"traj_0/success"});
  expect_bad([](EpisodeRecord& r) { r.actions["joint_pos"].pop_back(); },
             {"traj_0/actions/joint_pos", "has 2 steps"});
  expect_bad([](EpisodeRecord& r) { r.extra["tcp_pose"] = Series(DType::kFloat32, {7}); },
             {"traj_0/obs/extra/tcp_pose", "has 0 steps"});
  expect_bad([](EpisodeRecord& r) { r.extra_json["task_info"].steps.pop_back(); },
             {"traj_0/obs/extra/task_info"});
  expect_bad([](EpisodeRecord& r) { r.env_states["articulations/panda"] = Series(); },
             {"traj_0/env_states/articulations/panda"});
  expect_bad([](EpisodeRecord& r) { r.cameras[0].params["intrinsic_cv"] = Series(); },
             {"traj_0/obs/sensor_param/wrist_camera/intrinsic_cv", "has 0 steps"});
  expect_bad([](EpisodeRecord& r) { r.qpos.clear(); }, {"no observation"});
  expect_bad([](EpisodeRecord& r) { r.extra["task_info"] = r.extra["robot_base_pose"]; },
             {"traj_0/obs/extra/task_info", "written twice"});
  expect_bad([](EpisodeRecord& r) { r.extra["robot_base_pose/x"] = r.extra["robot_base_pose"]; },
             {"traj_0/obs/extra/robot_base_pose", "both a dataset and the group"});
  expect_bad([](EpisodeRecord& r) { r.extra["../escape"] = r.extra["robot_base_pose"]; },
             {"bad name"});
  expect_bad([](EpisodeRecord& r) { r.cameras.push_back(r.cameras[0]); },
             {"traj_0/obs/sensor_param/wrist_camera", "camera named twice"});
  expect_bad([](EpisodeRecord& r) { r.cameras[0].video_file = "missing.mp4"; },
             {"traj_0/obs/sensor_data/wrist_camera", "video file does not exist"});
  expect_bad([](EpisodeRecord& r) { r.meta.config_hash.clear(); },
             {"traj_0/provenance/config_hash", "missing"});
  expect_bad([](EpisodeRecord& r) { r.meta.mujoco_version.clear(); },
             {"traj_0/provenance/mujoco_version"});
  expect_bad([](EpisodeRecord& r) { r.meta.assets[1].license.clear(); },
             {"traj_0/provenance/assets/1/license"});
  expect_bad([](EpisodeRecord& r) { r.obs_scene = Json::array(); }, {"traj_0/obs_scene"});
  // Series rows of the wrong size are refused where they are appended.
  Series s(DType::kFloat32, {7});
  ExpectError([&] { s.Append({1, 2}); }, {"row 0 has 2 values, expected 7"});
  EXPECT_FALSE(rec.Finish());  // no episode: no file
  EXPECT_TRUE(ListFiles(tmp.path()).empty());
}

TEST(RecorderTest, FailedWriteLeavesNothingPartial) {
  TempDir tmp;
  Recorder rec({tmp.path()});
  EpisodeRecord r = MakeEpisode(3);
  r.cameras.clear();
  // The part's final name is taken by a non-empty folder: the HDF5 file is written completely,
  // then the rename fails. The temp file must go away and the episode must not count.
  WriteText(rec.parts_dir() / "traj_00000000.h5" / "blocker", "x");
  ExpectError([&] { rec.Write(r); }, {"traj_00000000.h5", "cannot rename into place"});
  EXPECT_EQ(rec.next_index(), 0);
  EXPECT_THAT(ListFiles(tmp.path()),
              ElementsAre("trajectories_batch_1_of_1.parts/traj_00000000.h5/blocker"));
  fs::remove_all(rec.parts_dir() / "traj_00000000.h5");
  EXPECT_EQ(rec.Write(r), 0);
  // Finishing onto a folder fails too; the parts survive for another try.
  fs::create_directories(rec.batch_file() / "blocker");
  ExpectError([&] { rec.Finish(); }, {"trajectories_batch_1_of_1.h5", "cannot rename"});
  EXPECT_THAT(ListFiles(tmp.path()),
              ElementsAre("trajectories_batch_1_of_1.parts/traj_00000000.h5"));
  fs::remove_all(rec.batch_file());
  EXPECT_TRUE(rec.Finish());
  EXPECT_THAT(ListFiles(tmp.path()), ElementsAre("trajectories_batch_1_of_1.h5"));
}

TEST(RecorderTest, ACrashLosesAtMostTheEpisodeInFlight) {
  TempDir tmp;
  {
    Recorder rec({tmp.path()});
    for (size_t t : {2, 3}) {
      EpisodeRecord r = MakeEpisode(t);
      AddVideo(rec, r);
      rec.Write(r);
    }
    // "Crash": no Finish(), and a half-written temp file of the third episode.
    WriteText(rec.parts_dir() / "traj_00000002.h5.tmp.999.0", "partial");
  }
  Recorder rec({tmp.path()});
  EXPECT_EQ(rec.next_index(), 2);
  EXPECT_FALSE(fs::exists(rec.parts_dir() / "traj_00000002.h5.tmp.999.0"));
  EpisodeRecord r = MakeEpisode(4);
  AddVideo(rec, r);
  EXPECT_EQ(rec.Write(r), 2);
  EXPECT_TRUE(rec.Finish());
  std::string out;
  ASSERT_EQ(RunPython(tmp.path(),
                      "import sys, json, h5py\n"
                      "f = h5py.File(sys.argv[1], 'r')\n"
                      "print([(k, f[k]['rewards'].shape[0], "
                      "json.loads(f[k].attrs['provenance'])['episode_index'], "
                      "bytes(f[k]['obs/sensor_data/wrist_camera'][()]).rstrip(b'\\0').decode()) "
                      "for k in f])\n",
                      ShellQuote(rec.batch_file().string()), &out),
            0);
  EXPECT_EQ(out,
            "[('traj_0', 2, 0, 'episode_00000000_wrist_camera_batch_1_of_1.mp4'), "
            "('traj_1', 3, 1, 'episode_00000001_wrist_camera_batch_1_of_1.mp4'), "
            "('traj_2', 4, 2, 'episode_00000002_wrist_camera_batch_1_of_1.mp4')]\n");
}

TEST(RecorderTest, LongJsonWidensTheRowInsteadOfTruncating) {
  TempDir tmp;
  Recorder rec({tmp.path()});
  EpisodeRecord r = MakeEpisode(2);
  r.cameras.clear();
  r.extra_json["task_info"].max_len = 16;
  rec.Write(r);
  rec.Finish();
  std::string out;
  ASSERT_EQ(RunPython(tmp.path(),
                      "import sys, json, h5py\n"
                      "d = h5py.File(sys.argv[1], 'r')['traj_0/obs/extra/task_info']\n"
                      "print(d.shape[1] > 16, [json.loads(bytes(r).rstrip(b'\\0')) for r in d][1]"
                      "['episode_step'])\n",
                      ShellQuote(rec.batch_file().string()), &out),
            0);
  EXPECT_EQ(out, "True 1\n");
}

TEST(RecorderTest, JsonEncodingMatchesPythonJsonDumps) {
  TempDir tmp;
  Json v = Json::parse(R"({"z": [0.1, 1e-05, 1e16, 1.0, -0.0, 123456789.125, 3],
                           "a": {"y": true, "b": null, "\u00e9t\u00e9": "caf\u00e9 \"q\"\n"},
                           "m": []})");
  v["nan"] = std::numeric_limits<double>::quiet_NaN();
  v["inf"] = -std::numeric_limits<double>::infinity();
  v["f32"] = static_cast<double>(0.1f);
  const std::string ours = DumpJsonCompactSorted(v);
  std::string out;
  ASSERT_EQ(RunPython(tmp.path(),
                      "import sys, json\n"
                      "v = json.loads(sys.argv[1])\n"
                      "sys.stdout.write(json.dumps(v, sort_keys=True, separators=(',', ':')))\n",
                      ShellQuote(ours), &out),
            0);
  EXPECT_EQ(ours, out);
  EXPECT_THAT(ours, HasSubstr("\"f32\":0.10000000149011612"));
  EXPECT_THAT(ours, HasSubstr("\"nan\":NaN"));
}

TEST(SeriesTest, ConvertsToItsDtype) {
  Series u8(DType::kUint8, {4});
  u8.Append({300, -5, std::nan(""), 7.9});
  EXPECT_THAT(u8.bytes(), ElementsAre(255, 0, 0, 7));
  Series f32(DType::kFloat32, {});
  f32.Append({0.1});
  f32.Append({2});
  ASSERT_EQ(f32.bytes().size(), 8u);
  float v = 0;
  std::memcpy(&v, f32.bytes().data(), sizeof v);
  EXPECT_EQ(v, 0.1f);
  EXPECT_EQ(f32.steps(), 2u);
  Series i64(DType::kInt64, {1});
  i64.AppendInts({(int64_t{1} << 62) + 1});
  int64_t w = 0;
  std::memcpy(&w, i64.bytes().data(), sizeof w);
  EXPECT_EQ(w, (int64_t{1} << 62) + 1);
  EXPECT_STREQ(DTypeName(DType::kBool), "bool");
  EXPECT_EQ(DTypeSize(DType::kFloat64), 8u);
}

}  // namespace
}  // namespace mlspaces::datagen
