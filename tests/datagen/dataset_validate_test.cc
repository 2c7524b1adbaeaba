// ValidateDataset / `mlspaces validate-dataset`: a dataset made by `mlspaces datagen` is valid;
// each corruption (made with h5py or on the files) is reported with file, HDF5 path and cause.
#include "mlspaces/datagen/dataset_validate.h"

#include <filesystem>
#include <memory>
#include <string>

#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
using mlspaces::testing::CliResult;
using mlspaces::testing::RunCli;
using mlspaces::testing::RunPython;
using mlspaces::testing::ShellQuote;
using mlspaces::testing::Slurp;
using mlspaces::testing::TempDir;
using mlspaces::testing::WriteText;
using ::testing::HasSubstr;

class DatasetValidateTest : public ::testing::Test {
 protected:
  // One datagen run for the suite (2 episodes, 96x64 videos: a second or two); each test
  // corrupts its own copy.
  static void SetUpTestSuite() {
    source_ = new TempDir();
    const CliResult r = RunCli(
        {"datagen", (fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "datagen.yaml").string(),
         "-q", "--seed", "3", "--episodes", "2", "--output", (*source_ / "run").string(), "--set",
         "camera_config.img_resolution=[96,64]", "--set", "camera_config.shadows=false", "--set",
         "camera_config.reflections=false"});
    generated_ = r.exit_code == 0;
    if (!generated_) generate_error_ = r.out + r.err;
  }
  static void TearDownTestSuite() {
    delete source_;
    source_ = nullptr;
  }

  void SetUp() override {
    ASSERT_TRUE(generated_) << "mlspaces datagen failed:\n" << generate_error_;
    fs::copy(*source_ / "run", run(), fs::copy_options::recursive);
    ASSERT_TRUE(fs::is_regular_file(batch()));
  }

  fs::path run() const { return tmp_ / "run"; }
  fs::path house() const { return run() / "house_0"; }
  fs::path batch() const { return house() / "trajectories_batch_1_of_1.h5"; }
  fs::path video(int k, const std::string& camera) const {
    char buf[32];
    std::snprintf(buf, sizeof buf, "episode_%08d_", k);
    return house() / (buf + camera + "_batch_1_of_1.mp4");
  }

  /// Runs `code` with `f` = the batch file opened read-write by h5py (json, numpy as np
  /// imported); returns what it prints.
  std::string Py(const std::string& code) {
    std::string out;
    RunPython(tmp_.path(),
              "import sys, json\nimport h5py\nimport numpy as np\n"
              "f = h5py.File(sys.argv[1], 'r+')\n" +
                  code + "\nf.close()\n",
              ShellQuote(batch().string()), &out);
    return out;
  }

  DatasetReport Validate() const { return ValidateDataset(run()); }

  /// The problems' lines, for failure messages.
  static std::string Lines(const DatasetReport& r) {
    std::string out;
    for (const DatasetProblem& p : r.problems) out += p.ToString() + "\n";
    return out;
  }

  /// Expects exactly one problem, at `file` and `path`, whose message contains `message`.
  static void ExpectOnly(const DatasetReport& r, const fs::path& file, const std::string& path,
                         const std::string& message) {
    ASSERT_EQ(r.problems.size(), 1u) << Lines(r);
    EXPECT_EQ(r.problems[0].path, file.string());
    EXPECT_EQ(r.problems[0].field, path);
    EXPECT_THAT(r.problems[0].message, HasSubstr(message));
  }

  /// Whether some problem is at `file` and `path` with a message containing `message`.
  static bool Has(const DatasetReport& r, const fs::path& file, const std::string& path,
                  const std::string& message) {
    for (const DatasetProblem& p : r.problems) {
      if (p.path == file.string() && p.field == path &&
          p.message.find(message) != std::string::npos) {
        return true;
      }
    }
    return false;
  }

  TempDir tmp_;
  static TempDir* source_;
  static bool generated_;
  static std::string generate_error_;
};

TempDir* DatasetValidateTest::source_ = nullptr;
bool DatasetValidateTest::generated_ = false;
std::string DatasetValidateTest::generate_error_;

TEST_F(DatasetValidateTest, GeneratedDatasetIsValid) {
  const DatasetReport r = Validate();
  EXPECT_TRUE(r.ok()) << Lines(r);
  EXPECT_EQ(r.files, 1);
  EXPECT_EQ(r.trajectories, 2);
  EXPECT_EQ(r.videos, 4);

  const CliResult cli = RunCli({"validate-dataset", run().string()});
  EXPECT_EQ(cli.exit_code, 0) << cli.out << cli.err;
  EXPECT_EQ(cli.out, "2 trajectories in 1 file, 4 videos: ok\n");
  EXPECT_EQ(cli.err, "");
}

TEST_F(DatasetValidateTest, MissingFolderIsAnError) {
  EXPECT_THROW(ValidateDataset(tmp_ / "nope"), Error);
  const CliResult cli = RunCli({"validate-dataset", (tmp_ / "nope").string()});
  EXPECT_EQ(cli.exit_code, 1);
  EXPECT_EQ(cli.out, "");
  EXPECT_EQ(cli.err, "mlspaces: error: " + (tmp_ / "nope").string() + ": no such folder\n");
  EXPECT_EQ(RunCli({"validate-dataset"}).exit_code, 2);
}

TEST_F(DatasetValidateTest, EmptyFolderHasNoTrajectories) {
  fs::create_directories(tmp_ / "empty");
  const DatasetReport r = ValidateDataset(tmp_ / "empty");
  ExpectOnly(r, tmp_ / "empty", "", "no trajectory file");
}

TEST_F(DatasetValidateTest, DeletedRequiredDataset) {
  Py("del f['traj_0/rewards']");
  ExpectOnly(Validate(), batch(), "traj_0/rewards", "missing");

  const CliResult cli = RunCli({"validate-dataset", run().string()});
  EXPECT_EQ(cli.exit_code, 1);
  EXPECT_EQ(cli.out, batch().string() +
                         ": traj_0/rewards: missing\n"
                         "2 trajectories in 1 file, 4 videos: 1 problem\n");
}

TEST_F(DatasetValidateTest, EveryProblemIsListed) {
  Py("del f['traj_0/actions/ee_twist']\n"
     "del f['traj_1/obs/agent/qvel']\n"
     "f['traj_1'].attrs['provenance'] = json.dumps({'seed': -1})");
  fs::remove(video(0, "exo_camera_1"));
  const DatasetReport r = Validate();
  EXPECT_TRUE(Has(r, batch(), "traj_0/actions/ee_twist", "missing")) << Lines(r);
  EXPECT_TRUE(Has(r, batch(), "traj_1/obs/agent/qvel", "missing")) << Lines(r);
  EXPECT_TRUE(Has(r, batch(), "traj_1@provenance/config_hash", "missing")) << Lines(r);
  EXPECT_TRUE(Has(r, batch(), "traj_1@provenance/seed", "expected an unsigned integer"))
      << Lines(r);
  EXPECT_TRUE(Has(r, batch(), "traj_0/obs/sensor_data/exo_camera_1", "does not exist")) << Lines(r);

  const CliResult cli = RunCli({"validate-dataset", run().string()});
  EXPECT_EQ(cli.exit_code, 1);
  EXPECT_THAT(cli.out, HasSubstr(batch().string() + ": traj_0/actions/ee_twist: missing\n"));
  EXPECT_THAT(cli.out, HasSubstr("2 trajectories in 1 file, 4 videos: " +
                                 std::to_string(r.problems.size()) + " problems\n"));
}

TEST_F(DatasetValidateTest, InvalidJsonRow) {
  Py("d = f['traj_1/actions/joint_pos']\nrow = d[3]\nrow[0] = ord('x')\nd[3] = row");
  ExpectOnly(Validate(), batch(), "traj_1/actions/joint_pos", "row 3 of 69 is not valid JSON");
}

TEST_F(DatasetValidateTest, JsonRowsMayHoldNaNAndInfinity) {
  // What DumpJsonCompactSorted writes for non-finite values (Python's json.loads reads it).
  Py("d = f['traj_0/obs/agent/qvel']\nrow = np.zeros(d.shape[1], np.uint8)\n"
     "t = b'{\"arm\":[NaN,Infinity,-Infinity],\"gripper\":[\"NaN\"]}'\n"
     "row[:len(t)] = np.frombuffer(t, np.uint8)\nd[2] = row");
  const DatasetReport r = Validate();
  EXPECT_TRUE(r.ok()) << Lines(r);
}

TEST_F(DatasetValidateTest, JsonRowWithBytesAfterThePadding) {
  Py("d = f['traj_0/actions/ee_pose']\nrow = d[4]\nrow[-1] = ord('}')\nd[4] = row");
  ExpectOnly(Validate(), batch(), "traj_0/actions/ee_pose",
             "row 4 of 65 has non-zero bytes after its zero padding starts");
}

TEST_F(DatasetValidateTest, JsonRowThatIsNotAnObject) {
  Py("d = f['traj_0/obs/agent/qpos']\nrow = np.zeros(d.shape[1], np.uint8)\n"
     "row[:3] = np.frombuffer(b'[1]', np.uint8)\nd[5] = row");
  ExpectOnly(Validate(), batch(), "traj_0/obs/agent/qpos", "row 5 of 65 is a JSON array");
}

TEST_F(DatasetValidateTest, ExtraJsonRowIsChecked) {
  Py("d = f['traj_0/obs/extra/task_info']\nd[7] = np.zeros(d.shape[1], np.uint8)");
  ExpectOnly(Validate(), batch(), "traj_0/obs/extra/task_info", "row 7 of 65 is empty");
}

TEST_F(DatasetValidateTest, WrongFirstDimension) {
  Py("d = f['traj_1/obs/extra/tcp_pose'][:-1]\n"
     "del f['traj_1/obs/extra/tcp_pose']\n"
     "f['traj_1/obs/extra/tcp_pose'] = d");
  ExpectOnly(Validate(), batch(), "traj_1/obs/extra/tcp_pose",
             "has 68 rows, expected 69 (T, the rows of obs/agent/qpos)");
}

TEST_F(DatasetValidateTest, WrongBoolType) {
  Py("d = f['traj_0/success'][:].astype(np.float32)\n"
     "del f['traj_0/success']\nf['traj_0/success'] = d");
  const DatasetReport r = Validate();
  EXPECT_TRUE(Has(r, batch(), "traj_0/success", "expected bool (T,)")) << Lines(r);
}

TEST_F(DatasetValidateTest, FailMustBeNotSuccess) {
  Py("d = f['traj_1/fail']\nd[0] = not d[0]");
  ExpectOnly(Validate(), batch(), "traj_1/fail", "row 0 equals success");
}

TEST_F(DatasetValidateTest, TerminatedOnMiddleRow) {
  Py("f['traj_0/terminated'][10] = True");
  const DatasetReport r = Validate();
  EXPECT_TRUE(Has(r, batch(), "traj_0/terminated",
                  "set on row 10 of 65: only the last row may end the episode"))
      << Lines(r);
  EXPECT_EQ(r.problems.size(), 1u) << Lines(r);
}

TEST_F(DatasetValidateTest, LastRowMustEndTheEpisode) {
  Py("f['traj_0/terminated'][-1] = False\nf['traj_0/truncated'][-1] = False");
  const DatasetReport r = Validate();
  EXPECT_TRUE(Has(r, batch(), "traj_0/terminated", "neither terminated nor truncated")) << Lines(r);
  // The provenance says terminated: it no longer matches the dataset.
  EXPECT_TRUE(Has(r, batch(), "traj_0@provenance/terminated", "last row")) << Lines(r);
}

TEST_F(DatasetValidateTest, TooShortEpisode) {
  Py("for name in ['obs/agent/qpos']:\n"
     "    d = f['traj_0/' + name][:1]\n"
     "    del f['traj_0/' + name]\n"
     "    f['traj_0/' + name] = d");
  const DatasetReport r = Validate();
  EXPECT_TRUE(Has(r, batch(), "traj_0/obs/agent/qpos", "T = 1 rows")) << Lines(r);
  EXPECT_TRUE(Has(r, batch(), "traj_0/rewards", "has 65 rows, expected 1")) << Lines(r);
}

TEST_F(DatasetValidateTest, ProvenanceMissingLicense) {
  Py("p = json.loads(f['traj_0'].attrs['provenance'])\n"
     "del p['assets'][0]['license']\n"
     "f['traj_0'].attrs['provenance'] = json.dumps(p)");
  ExpectOnly(Validate(), batch(), "traj_0@provenance/assets/0/license",
             "missing (uid \"red_block\")");
}

TEST_F(DatasetValidateTest, ObsSceneMustBeAnObject) {
  Py("del f['traj_1/obs_scene']\nf['traj_1/obs_scene'] = '[1, 2]'");
  ExpectOnly(Validate(), batch(), "traj_1/obs_scene", "is a JSON array, expected an object");
}

TEST_F(DatasetValidateTest, MissingVideo) {
  fs::remove(video(1, "wrist_camera"));
  ExpectOnly(Validate(), batch(), "traj_1/obs/sensor_data/wrist_camera",
             "video file does not exist: " + video(1, "wrist_camera").string());
}

TEST_F(DatasetValidateTest, VideoWithOtherFrameCount) {
  // traj_0 has 65 observations, traj_1 69.
  fs::copy_file(video(0, "wrist_camera"), video(1, "wrist_camera"),
                fs::copy_options::overwrite_existing);
  ExpectOnly(Validate(), batch(), "traj_1/obs/sensor_data/wrist_camera",
             "has 65 frames, expected 69 (T, one per observation)");
}

TEST_F(DatasetValidateTest, TruncatedVideo) {
  const std::string bytes = Slurp(video(0, "exo_camera_1"));
  ASSERT_GT(bytes.size(), 1000u);
  WriteText(video(0, "exo_camera_1"), bytes.substr(0, bytes.size() / 2));
  ExpectOnly(Validate(), batch(), "traj_0/obs/sensor_data/exo_camera_1", "cannot be decoded");
}

TEST_F(DatasetValidateTest, VideoSizeMustMatchTheCamera) {
  // The camera claims a 128x64 image: the 96x64 video should be 128x64.
  Py("d = f['traj_0/obs/sensor_param/wrist_camera/intrinsic_cv']\nk = d[:]\n"
     "k[:, 0, 2] = 64\nd[...] = k");
  ExpectOnly(Validate(), batch(), "traj_0/obs/sensor_data/wrist_camera",
             "is 96x64, expected 128x64");
}

TEST_F(DatasetValidateTest, CameraWithoutVideoAndUnnamedVideo) {
  Py("del f['traj_0/obs/sensor_data/exo_camera_1']");
  const DatasetReport r = Validate();
  EXPECT_TRUE(Has(r, batch(), "traj_0/obs/sensor_data/exo_camera_1", "has no video")) << Lines(r);
  EXPECT_TRUE(Has(r, video(0, "exo_camera_1"), "", "not named by any trajectory")) << Lines(r);
  EXPECT_EQ(r.problems.size(), 2u) << Lines(r);
  EXPECT_EQ(r.videos, 3);
}

TEST_F(DatasetValidateTest, VideoNamedTwice) {
  Py("f['traj_1/obs/sensor_data/exo_camera_1'][...] = f['traj_0/obs/sensor_data/exo_camera_1'][:]");
  const DatasetReport r = Validate();
  EXPECT_TRUE(Has(r, batch(), "traj_1/obs/sensor_data/exo_camera_1", "is also named by"))
      << Lines(r);
  EXPECT_TRUE(Has(r, video(1, "exo_camera_1"), "", "not named by any trajectory")) << Lines(r);
}

TEST_F(DatasetValidateTest, GarbageHdf5File) {
  const fs::path garbage = house() / "trajectories_batch_9_of_9.h5";
  WriteText(garbage, "this is not an HDF5 file\n");
  const DatasetReport r = Validate();
  ExpectOnly(r, garbage, "", "not a readable HDF5 file");
  EXPECT_EQ(r.files, 2);
  EXPECT_EQ(r.trajectories, 2);

  const CliResult cli = RunCli({"validate-dataset", run().string()});
  EXPECT_EQ(cli.exit_code, 1);
  EXPECT_THAT(cli.out, HasSubstr(garbage.string() + ": not a readable HDF5 file"));
  EXPECT_THAT(cli.out, HasSubstr("2 trajectories in 2 files, 4 videos: 1 problem\n"));
}

TEST_F(DatasetValidateTest, TruncatedHdf5File) {
  const std::string bytes = Slurp(batch());
  WriteText(batch(), bytes.substr(0, bytes.size() * 2 / 3));
  const DatasetReport r = Validate();
  // Its videos are not reported as unnamed: the file that names them could not be read.
  ExpectOnly(r, batch(), "", "not a readable HDF5 file (truncated file");
  EXPECT_EQ(r.trajectories, 0);
}

TEST_F(DatasetValidateTest, CorruptChunk) {
  // One chunk per dataset (deflate): damage its middle.
  const std::string out =
      Py("info = f['traj_1/obs/extra/robot_base_pose'].id.get_chunk_info(0)\n"
         "print(info.byte_offset + info.size // 2)");
  const size_t offset = std::stoul(out);
  std::string bytes = Slurp(batch());
  ASSERT_LT(offset + 16, bytes.size());
  for (size_t i = offset; i < offset + 16; ++i) bytes[i] = static_cast<char>(bytes[i] ^ 0x5a);
  WriteText(batch(), bytes);
  ExpectOnly(Validate(), batch(), "traj_1/obs/extra/robot_base_pose", "cannot read the data");
}

TEST_F(DatasetValidateTest, LeftoverTempFileAndParts) {
  const fs::path tmp = house() / "trajectories_batch_1_of_1.h5.tmp.1234.0";
  WriteText(tmp, "partial");
  const fs::path parts = house() / "trajectories_batch_1_of_1.parts";
  fs::create_directories(parts);
  fs::copy_file(batch(), parts / "traj_00000000.h5");  // not checked: inside .parts
  const DatasetReport r = Validate();
  ASSERT_EQ(r.problems.size(), 2u) << Lines(r);
  EXPECT_TRUE(Has(r, tmp, "", "unfinished write: leftover temp file")) << Lines(r);
  EXPECT_TRUE(Has(r, parts, "", "unfinished write")) << Lines(r);
  EXPECT_EQ(r.files, 1);
}

TEST_F(DatasetValidateTest, TrajectoryNumberingGap) {
  Py("f.move('traj_1', 'traj_2')");
  const DatasetReport r = Validate();
  EXPECT_TRUE(Has(r, batch(), "",
                  "numbering has gaps: 1 of traj_0 … traj_2 missing (first: "
                  "traj_1)"))
      << Lines(r);
  EXPECT_TRUE(Has(r, batch(), "traj_2@provenance/episode_index", "1, expected 2")) << Lines(r);
}

}  // namespace
}  // namespace mlspaces::datagen
