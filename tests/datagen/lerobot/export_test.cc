// export-lerobot on real files: episodes written by the Recorder with real H.264 videos
// (VideoWriter), exported, and read back with Arrow C++ (parquet), ProbeVideo and JSON; and
// import-lerobot / ValidateLeRobot of such exports.
#include "mlspaces/datagen/lerobot/export.h"
#include "mlspaces/datagen/lerobot/import.h"
#include "mlspaces/datagen/lerobot/validate.h"

#include <arrow/api.h>
#include <arrow/io/file.h>
#include <parquet/arrow/reader.h>

#include <cmath>
#include <iterator>
#include <tuple>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/json.h"
#include "mlspaces/datagen/recorder.h"
#include "mlspaces/datagen/video.h"
#include "test_util.h"

namespace mlspaces::datagen::lerobot {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::CrashPoints;
using ::mlspaces::testing::ExpectError;
using ::mlspaces::testing::RunCli;
using ::mlspaces::testing::TempDir;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

enum class End { kSuccess, kFailed, kTruncated };

struct Spec {
  size_t t = 6;
  End end = End::kSuccess;
  double dt_ms = 66.0;
  double video_fps = 0;  // 0: 1000 / dt_ms
  bool camera = true;
  std::string task = "Pick up the block";
};

// One episode of `s.t` observations; values depend on (episode, row) so rows can be checked.
EpisodeRecord MakeEpisode(const Spec& s, int e) {
  EpisodeRecord r;
  r.meta.config_hash = "sha256:0";
  r.meta.scene = "house_0";
  r.meta.task_description = s.task;
  r.meta.assets = {{"red_block", "custom_assets", "CC-BY-4.0", "pickup_obj"}};
  r.meta.mujoco_version = "3.5.0";
  r.meta.mlspaces_version = "0.1.0";
  Series base(DType::kFloat32, {7});
  Series phase(DType::kInt64, {});
  for (size_t i = 0; i < s.t; ++i) {
    const double v = 10.0 * e + static_cast<double>(i);
    const bool first = i == 0, last = i + 1 == s.t;
    r.qpos.push_back({{"arm", {v, 0.5, 0, 0, 0, 0, 0}}, {"base", {}}, {"gripper", {0.01, 0.02}}});
    r.qvel.push_back({{"arm", {0, 0, 0, 0, 0, 0, -v}}, {"base", {}}, {"gripper", {0, 0}}});
    r.actions["commanded_action"].push_back(
        first ? MoveGroupValues{}
              : MoveGroupValues{
                    {"arm", {v + 0.25, 0, 0, 0, 0, 0, 0}}, {"base", {}}, {"gripper", {1}}});
    r.actions["joint_pos"].push_back(
        last ? MoveGroupValues{}
             : MoveGroupValues{{"arm", {v, 1, 2, 3, 4, 5, 6}}, {"gripper", {0}}});
    base.Append({v, 2, 3, 1, 0, 0, 0});
    phase.AppendInts({static_cast<int64_t>(i)});
    r.rewards.push_back(static_cast<float>(0.5 * v));
    r.success.push_back(last && s.end == End::kSuccess);
    r.terminated.push_back(last && s.end != End::kTruncated);
    r.truncated.push_back(last && s.end == End::kTruncated);
  }
  r.extra["robot_base_pose"] = base;
  r.extra["policy_phase"] = phase;
  if (s.camera) {
    CameraRecord cam;
    cam.name = "wrist_camera";
    r.cameras.push_back(cam);
  }
  r.obs_scene =
      Json{{"task_type", "pick"}, {"task_description", s.task}, {"policy_dt_ms", s.dt_ms}};
  return r;
}

// A run folder (house_0, one batch) of these episodes, each camera a real 32x32 H.264 video of
// t frames (frame i of episode e has grey level 8 * e + i). `hdf5` false: as datagen --format
// lerobot writes it (episode records, no HDF5).
fs::path WriteRun(const fs::path& run, const std::vector<Spec>& specs, bool hdf5 = true) {
  RecorderOptions options{run / "house_0"};
  options.hdf5 = hdf5;
  Recorder rec(options);
  for (size_t e = 0; e < specs.size(); ++e) {
    EpisodeRecord r = MakeEpisode(specs[e], static_cast<int>(e));
    for (CameraRecord& c : r.cameras) {
      c.video_file = rec.VideoFileName(rec.next_index(), c.name);
      VideoOptions vo;
      vo.fps = specs[e].video_fps > 0 ? specs[e].video_fps : 1000.0 / specs[e].dt_ms;
      VideoWriter w(rec.dir() / c.video_file, 32, 32, vo);
      for (size_t i = 0; i < specs[e].t; ++i) {
        std::vector<unsigned char> px(32 * 32 * 3, static_cast<unsigned char>(8 * e + i));
        w.AddFrame(px.data());
      }
      w.Finish();
    }
    rec.Write(r);
  }
  rec.Finish();
  return run;
}

std::shared_ptr<arrow::Table> ReadParquet(const fs::path& p) {
  auto in = arrow::io::ReadableFile::Open(p.string()).ValueOrDie();
  auto reader = parquet::arrow::OpenFile(in, arrow::default_memory_pool()).ValueOrDie();
  std::shared_ptr<arrow::Table> t;
  EXPECT_TRUE(reader->ReadTable(&t).ok());
  return t->CombineChunks().ValueOrDie();
}

// Row `i` of a fixed_size_list<float> column, or of a scalar column as one value.
std::vector<double> Row(const arrow::Table& t, const std::string& col, int64_t i) {
  auto c = t.GetColumnByName(col);
  EXPECT_NE(c, nullptr) << col;
  auto a = c->chunk(0);
  std::vector<double> out;
  if (a->type_id() == arrow::Type::FIXED_SIZE_LIST) {
    auto l = std::static_pointer_cast<arrow::FixedSizeListArray>(a);
    auto v = l->value_slice(i);
    for (int64_t k = 0; k < v->length(); ++k) {
      out.push_back(std::static_pointer_cast<arrow::FloatArray>(v)->Value(k));
    }
  } else if (a->type_id() == arrow::Type::FLOAT) {
    out.push_back(std::static_pointer_cast<arrow::FloatArray>(a)->Value(i));
  } else if (a->type_id() == arrow::Type::INT64) {
    out.push_back(static_cast<double>(std::static_pointer_cast<arrow::Int64Array>(a)->Value(i)));
  } else if (a->type_id() == arrow::Type::BOOL) {
    out.push_back(std::static_pointer_cast<arrow::BooleanArray>(a)->Value(i) ? 1 : 0);
  } else if (a->type_id() == arrow::Type::DOUBLE) {
    out.push_back(std::static_pointer_cast<arrow::DoubleArray>(a)->Value(i));
  }
  return out;
}

TEST(LeRobotExport, WritesTheV3LayoutWithTheSuccessfulCompleteEpisodes) {
  TempDir tmp;
  const fs::path run = WriteRun(tmp / "run", {{.t = 5},
                                              {.t = 4, .end = End::kFailed},
                                              {.t = 7, .task = "Pick up the mug"},
                                              {.t = 6, .end = End::kTruncated}});
  const fs::path out = tmp / "lerobot";
  std::vector<int64_t> progress;
  ExportOptions options;
  options.progress = [&](int64_t done, int64_t total) {
    progress.push_back(done);
    EXPECT_EQ(total, 2);
  };
  const ExportReport r = ExportLeRobot(run, out, options);
  EXPECT_EQ(r.episodes, 2);
  EXPECT_EQ(r.frames, 4 + 6);
  EXPECT_EQ(r.tasks, 2);
  EXPECT_THAT(progress, ElementsAre(1, 2));
  ASSERT_EQ(r.skipped.size(), 2u);
  EXPECT_THAT(r.skipped[0], HasSubstr("traj_1: failed"));
  EXPECT_THAT(r.skipped[1], HasSubstr("traj_3: truncated"));
  EXPECT_THAT(mlspaces::testing::ListFiles(out),
              ::testing::IsSupersetOf(
                  {"meta/info.json", "meta/stats.json", "meta/tasks.parquet",
                   "meta/episodes/chunk-000/file-000.parquet", "data/chunk-000/file-000.parquet",
                   "videos/observation.images.wrist_camera/chunk-000/file-000.mp4"}));
  // Nothing else beside it (the temp folder was renamed).
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp.path()), fs::directory_iterator()), 2);

  const Json info = Json::parse(ReadFile(out / "meta/info.json"));
  EXPECT_EQ(info["codebase_version"], "v3.0");
  EXPECT_EQ(info["total_episodes"], 2);
  EXPECT_EQ(info["total_frames"], 10);
  EXPECT_EQ(info["total_tasks"], 2);
  EXPECT_NEAR(info["fps"].get<double>(), 1000.0 / 66.0, 1e-12);
  EXPECT_EQ(info["features"]["observation.state"]["shape"], Json::array({9}));
  EXPECT_EQ(info["features"]["observation.state"]["names"][7], "gripper_0");
  EXPECT_EQ(info["features"]["action"]["shape"], Json::array({8}));
  EXPECT_EQ(info["features"]["extra.policy_phase"]["dtype"], "int64");
  EXPECT_EQ(info["features"]["observation.images.wrist_camera"]["shape"], Json::array({32, 32, 3}));
  EXPECT_EQ(info["data_path"], "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet");

  const auto data = ReadParquet(out / "data/chunk-000/file-000.parquet");
  ASSERT_EQ(data->num_rows(), 10);
  // Frame t of episode 0 (traj_0): observation row t, command row t + 1.
  EXPECT_EQ(Row(*data, "observation.state", 2)[0], 2.0);
  EXPECT_EQ(Row(*data, "observation.velocity", 2)[6], -2.0);
  EXPECT_EQ(Row(*data, "action", 2)[0], 3.25);
  EXPECT_EQ(Row(*data, "command.joint_pos", 2)[0], 3.0);
  EXPECT_TRUE(std::isnan(Row(*data, "command.joint_pos", 3)[0]));  // the done row has none
  EXPECT_EQ(Row(*data, "extra.robot_base_pose", 1)[0], 1.0);
  EXPECT_EQ(Row(*data, "extra.policy_phase", 3)[0], 3.0);
  EXPECT_EQ(Row(*data, "next.reward", 3)[0], 2.0);
  EXPECT_EQ(Row(*data, "next.done", 3)[0], 1.0);
  EXPECT_EQ(Row(*data, "next.done", 2)[0], 0.0);
  EXPECT_EQ(Row(*data, "next.success", 3)[0], 1.0);
  // Frame 0 of the second exported episode (traj_2).
  EXPECT_EQ(Row(*data, "observation.state", 4)[0], 20.0);
  EXPECT_EQ(Row(*data, "episode_index", 4)[0], 1.0);
  EXPECT_EQ(Row(*data, "frame_index", 4)[0], 0.0);
  EXPECT_EQ(Row(*data, "index", 9)[0], 9.0);
  EXPECT_EQ(Row(*data, "task_index", 4)[0], 1.0);
  EXPECT_NEAR(Row(*data, "timestamp", 5)[0], 0.066, 1e-6);

  const auto eps = ReadParquet(out / "meta/episodes/chunk-000/file-000.parquet");
  ASSERT_EQ(eps->num_rows(), 2);
  EXPECT_EQ(Row(*eps, "length", 1)[0], 6.0);
  EXPECT_EQ(Row(*eps, "dataset_from_index", 1)[0], 4.0);
  EXPECT_EQ(Row(*eps, "dataset_to_index", 1)[0], 10.0);
  // The video of episode 1 starts after the 5 frames of episode 0's video.
  EXPECT_NEAR(Row(*eps, "videos/observation.images.wrist_camera/from_timestamp", 1)[0], 5 * 0.066,
              1e-9);
  EXPECT_NEAR(Row(*eps, "videos/observation.images.wrist_camera/to_timestamp", 1)[0], 12 * 0.066,
              1e-9);

  const auto tasks = ReadParquet(out / "meta/tasks.parquet");
  ASSERT_EQ(tasks->num_rows(), 2);
  EXPECT_EQ(std::static_pointer_cast<arrow::StringArray>(tasks->GetColumnByName("task")->chunk(0))
                ->GetString(1),
            "Pick up the mug");
  ASSERT_NE(tasks->schema()->metadata(), nullptr);
  EXPECT_THAT(tasks->schema()->metadata()->Get("pandas").ValueOrDie(),
              HasSubstr(R"("index_columns":["task"])"));

  // Re-muxed, not re-encoded: every frame of both episodes, grey levels as written.
  std::vector<int> grey;
  const VideoInfo v =
      ProbeVideo(out / "videos/observation.images.wrist_camera/chunk-000/file-000.mp4",
                 [&](const VideoFrame& f) { grey.push_back(f.rgb[0]); });
  EXPECT_EQ(v.frames, 5 + 7);
  EXPECT_NEAR(grey[5], 16, 2);  // episode 2's first frame

  const Json stats = Json::parse(ReadFile(out / "meta/stats.json"));
  EXPECT_EQ(stats["observation.state"]["max"][0], 25.0);
  EXPECT_EQ(stats["observation.state"]["count"], Json::array({10}));
  // Pixel stats in [0, 1], per channel, over the frames of the exported episodes (12 frames,
  // grey levels 0..4 and 16..22; H.264 moves a level by at most 2).
  const Json& pixels = stats["observation.images.wrist_camera"];
  EXPECT_EQ(pixels["count"], Json::array({12}));
  ASSERT_EQ(pixels["mean"].size(), 3u);
  EXPECT_NEAR(pixels["mean"][1][0][0].get<double>(), (10.0 + 133.0) / 12 / 255, 2.0 / 255);
  EXPECT_NEAR(pixels["max"][0][0][0].get<double>(), 22.0 / 255, 2.0 / 255);
}

TEST(LeRobotExport, ReencodesWithH264OrAv1WhenAsked) {
  TempDir tmp;
  const fs::path run = WriteRun(tmp / "run", {{.t = 3}, {.t = 4}});
  for (auto [codec, name, decoder] : {std::tuple{VideoCodec::kH264, "h264", "h264"},
                                      std::tuple{VideoCodec::kAv1, "av1", "libdav1d"}}) {
    ExportOptions options;
    options.codec = codec;
    const fs::path out = tmp / name;
    EXPECT_EQ(ExportLeRobot(run, out, options).frames, 5);
    std::vector<int> grey;
    const VideoInfo v =
        ProbeVideo(out / "videos/observation.images.wrist_camera/chunk-000/file-000.mp4",
                   [&](const VideoFrame& f) { grey.push_back(f.rgb[0]); });
    EXPECT_EQ(v.frames, 7) << name;
    EXPECT_EQ(v.codec, decoder);
    EXPECT_NEAR(v.fps, 1000.0 / 66, 1e-6);
    EXPECT_NEAR(grey[3], 8, 4) << name;  // episode 1's first frame (level 8)
    const Json info = Json::parse(ReadFile(out / "meta/info.json"));
    EXPECT_EQ(info["features"]["observation.images.wrist_camera"]["info"]["video.codec"], name);
  }
}

TEST(LeRobotExport, BadInputIsOneLineNamingTheFile) {
  TempDir tmp;
  const fs::path run = WriteRun(tmp / "run", {{.t = 3}, {.t = 3}});
  ExportOptions fps30;
  fps30.fps = 30;
  ExpectError([&] { ExportLeRobot(run, tmp / "a", fps30); },
              {"trajectories_batch_1_of_1.h5: traj_0", "policy_dt_ms",
               "--fps 30 is not the dataset's 15.1515"});
  ExportLeRobot(run, tmp / "b");
  ExpectError([&] { ExportLeRobot(run, tmp / "b"); }, {"/b", "already exists"});
  ExpectError([&] { ExportLeRobot(tmp / "nothing_here", tmp / "c"); }, {"nothing_here"});

  const fs::path fps = WriteRun(tmp / "fps", {{.t = 3}, {.t = 3, .dt_ms = 50}});
  ExpectError([&] { ExportLeRobot(fps, tmp / "d"); },
              {"traj_1", "policy_dt_ms 50 (fps 20) is not the first episode's 66"});

  const fs::path cams = WriteRun(tmp / "cams", {{.t = 3}, {.t = 3, .camera = false}});
  ExpectError(
      [&] { ExportLeRobot(cams, tmp / "e"); },
      {"traj_1", "obs/sensor_data", "cameras none are not the first episode's (wrist_camera"});

  const fs::path video = WriteRun(tmp / "video", {{.t = 3}, {.t = 3, .video_fps = 30}});
  ExpectError([&] { ExportLeRobot(video, tmp / "f"); },
              {"episode_00000001_wrist_camera_batch_1_of_1.mp4",
               "frame rate 30 is not the dataset's 15.1515"});

  const fs::path failed = WriteRun(tmp / "failed", {{.t = 3, .end = End::kFailed}});
  ExpectError([&] { ExportLeRobot(failed, tmp / "g"); },
              {"no successful, complete episode to export (1 left out)"});
  // A failure half-way leaves neither the dataset nor a temp folder.
  for (const char* name : {"a", "c", "d", "e", "f", "g"})
    EXPECT_FALSE(fs::exists(tmp / name)) << name;
  const auto entries = std::distance(fs::directory_iterator(tmp.path()), fs::directory_iterator());
  EXPECT_EQ(entries, 6);  // run, b, fps, cams, video, failed: nothing else
}

// A run killed after any durable step leaves no dataset or a complete one, never a partial one
// or a temp folder that survives the next run; the rerun writes the same dataset.
TEST(LeRobotExport, KilledAtAnyStepLeavesNothingOrTheWholeDataset) {
  TempDir tmp;
  const fs::path run = WriteRun(tmp / "run", {{.t = 3}, {.t = 4}});
  CrashPoints crash(tmp / "counter");
  const fs::path ref = tmp / "ref";
  auto r = RunCli({"export-lerobot", run.string(), ref.string(), "-q"}, crash.Counting());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const uint64_t steps = crash.Count();
  EXPECT_GE(steps, 2u + 2u);  // two episodes, the meta files, the files done, the rename
  const std::string ref_data = ReadFile(ref / "data/chunk-000/file-000.parquet");
  for (uint64_t n = 1; n <= steps; ++n) {
    const fs::path out = tmp / ("out" + std::to_string(n));
    r = RunCli({"export-lerobot", run.string(), out.string(), "-q"}, crash.KillAt(n));
    ASSERT_TRUE(r.sigkilled) << n << ": " << r.err;
    // Killed before the rename: nothing under the name; after it: everything.
    EXPECT_EQ(fs::exists(out), n == steps) << n;
    if (fs::exists(out)) continue;
    r = RunCli({"export-lerobot", run.string(), out.string(), "-q"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(ReadFile(out / "data/chunk-000/file-000.parquet"), ref_data) << n;
    for (const auto& entry : fs::directory_iterator(tmp.path())) {
      EXPECT_EQ(entry.path().filename().string().find(".tmp."), std::string::npos) << entry.path();
    }
  }
}

// datagen --format lerobot's dataset, written from episode records (no HDF5 run), is the bytes
// of export-lerobot of the HDF5 run of the same episodes, left-out ones included; the records'
// run holds no HDF5 file.
TEST(LeRobotExport, EpisodeRecordsGiveTheBytesOfTheHdf5RunsExport) {
  TempDir tmp;
  const std::vector<Spec> specs = {{.t = 5},
                                   {.t = 4, .end = End::kFailed},
                                   {.t = 7, .task = "Pick up the mug"},
                                   {.t = 6, .end = End::kTruncated},
                                   {.t = 3}};
  const fs::path h5 = WriteRun(tmp / "h5", specs);
  const fs::path rec = WriteRun(tmp / "rec", specs, /*hdf5=*/false);
  for (const std::string& f : mlspaces::testing::ListFiles(rec)) {
    const fs::path path(f);
    EXPECT_EQ(path.extension(),
              path.filename().string().rfind("episode_", 0) == 0 ? ".mp4" : ".rec")
        << f;
  }
  EXPECT_TRUE(fs::is_directory(rec / "house_0/trajectories_batch_1_of_1.episodes"));
  const ExportReport a = ExportLeRobot(h5, tmp / "a");
  const ExportReport b = ExportLeRobotRecords(rec, tmp / "b");
  EXPECT_EQ(b.episodes, 3);
  EXPECT_EQ(b.skipped.size(), 2u);
  EXPECT_EQ(a.frames, b.frames);
  const std::set<std::string> files = mlspaces::testing::ListFiles(tmp / "a");
  EXPECT_EQ(mlspaces::testing::ListFiles(tmp / "b"), files);
  EXPECT_THAT(files, ::testing::Contains("meta/mlspaces/hdf5/episode_000002.h5"));
  for (const std::string& f : files) {
    EXPECT_TRUE(ReadFile(tmp / "a" / f) == ReadFile(tmp / "b" / f)) << f;
  }
  // Without meta/mlspaces/: the episode files read from are not kept.
  ExportOptions bare;
  bare.mlspaces_meta = false;
  ExportLeRobotRecords(rec, tmp / "c", bare);
  EXPECT_FALSE(fs::exists(tmp / "c/meta/mlspaces"));
  EXPECT_EQ(ReadFile(tmp / "c/data/chunk-000/file-000.parquet"),
            ReadFile(tmp / "a/data/chunk-000/file-000.parquet"));
}

// import-lerobot gives back the exported episodes byte for byte (batch file, videos), keeping
// the traj_<k> names of a batch with a left-out (failed) episode; validate-dataset's checks
// pass on the export; a killed import leaves nothing under its name.
TEST(LeRobotImport, GivesBackTheExportedEpisodesByteForByte) {
  TempDir tmp;
  const fs::path run = WriteRun(tmp / "run", {{.t = 3}, {.t = 4}, {.t = 5}});
  ExportLeRobot(run, tmp / "ds");
  const LeRobotReport check = ValidateLeRobot(tmp / "ds");
  EXPECT_TRUE(check.ok()) << (check.problems.empty() ? "" : check.problems.front());
  EXPECT_EQ(check.frames, 2 + 3 + 4);
  const ImportReport r = ImportLeRobot(tmp / "ds", tmp / "back");
  EXPECT_EQ(r.episodes, 3);
  EXPECT_EQ(r.videos, 3);
  for (const char* f : {"house_0/trajectories_batch_1_of_1.h5",
                        "house_0/episode_00000000_wrist_camera_batch_1_of_1.mp4",
                        "house_0/episode_00000002_wrist_camera_batch_1_of_1.mp4"}) {
    EXPECT_EQ(ReadFile(tmp / "back" / f), ReadFile(run / f)) << f;
  }
  ExpectError([&] { ImportLeRobot(tmp / "ds", tmp / "back"); }, {"/back", "already exists"});
  ExpectError([&] { ImportLeRobot(run, tmp / "x"); }, {"meta/info.json", "not a LeRobot dataset"});

  // A failed middle episode: traj_0 and traj_2 come back under their names.
  const fs::path gap = WriteRun(tmp / "gap", {{.t = 3}, {.t = 3, .end = End::kFailed}, {.t = 4}});
  ExportLeRobot(gap, tmp / "gap_ds");
  ImportLeRobot(tmp / "gap_ds", tmp / "gap_back");
  const std::string back = ReadFile(tmp / "gap_back/house_0/trajectories_batch_1_of_1.h5");
  EXPECT_NE(back.find("traj_2"), std::string::npos);
  EXPECT_EQ(back.find("traj_1"), std::string::npos);
  EXPECT_EQ(ReadFile(tmp / "gap_back/house_0/episode_00000002_wrist_camera_batch_1_of_1.mp4"),
            ReadFile(gap / "house_0/episode_00000002_wrist_camera_batch_1_of_1.mp4"));

  CrashPoints crash(tmp / "counter");
  auto cli = RunCli({"import-lerobot", (tmp / "ds").string(), (tmp / "k").string(), "-q"},
                    crash.KillAt(1));
  ASSERT_TRUE(cli.sigkilled) << cli.err;
  EXPECT_FALSE(fs::exists(tmp / "k"));
  cli = RunCli({"import-lerobot", (tmp / "ds").string(), (tmp / "k").string(), "-q"});
  ASSERT_EQ(cli.exit_code, 0) << cli.err;
  EXPECT_EQ(ReadFile(tmp / "k/house_0/trajectories_batch_1_of_1.h5"),
            ReadFile(run / "house_0/trajectories_batch_1_of_1.h5"));
}

}  // namespace
}  // namespace mlspaces::datagen::lerobot
