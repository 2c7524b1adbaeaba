// datagen --format lerobot and merge of LeRobot folders (docs/lerobot.md, "Direct from
// datagen"): the run writes no HDF5. Its workers keep each episode, as it ends, as its
// EpisodeRecord (house_<h>/trajectories_batch_<b>_of_<n>.parts/traj_<k>.rec, recorder.h) and
// its MP4s in a staging folder beside OUTPUT (<OUTPUT>.partial, per shard
// <OUTPUT>.<shard>.partial), which --resume continues; when every work item is done, the helper
// (export-lerobot --episode-records) writes OUTPUT from the records through a temp folder
// renamed into place, and the staging folder is removed. So OUTPUT is the bytes export-lerobot
// gives for the HDF5 run and appears complete or not at all.
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "commands.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/datagen/run.h"

namespace mlspaces::cli {
namespace fs = std::filesystem;

namespace {

bool IsLeRobot(const fs::path& dir) { return fs::is_regular_file(dir / "meta" / "info.json"); }

void Helper(const std::vector<std::string>& args, const std::string& what, const fs::path& keep) {
  const int rc = RunLeRobotHelper(args);
  if (rc != 0) {
    throw Error(what + " failed (exit " + std::to_string(rc) + ", above); kept " + keep.string(),
                args.size() > 2 ? args[2] : "");
  }
}

}  // namespace

fs::path LeRobotStaging(const fs::path& out, const datagen::Shard& shard) {
  const fs::path abs = fs::absolute(out).lexically_normal();
  const fs::path o = abs.has_filename() ? abs : abs.parent_path();
  const std::string shard_part = shard.count > 1 ? "." + shard.Name() : "";
  return o.parent_path() / (o.filename().string() + shard_part + ".partial");
}

fs::path PrepareLeRobotRun(datagen::ExperimentConfig& config, const datagen::Shard& shard,
                           bool resume) {
  fs::path out = fs::absolute(datagen::RunFolder(config)).lexically_normal();
  const fs::path staging = LeRobotStaging(out, shard);
  if (IsLeRobot(out)) {
    if (!resume) {
      throw Error(
          "holds a LeRobot dataset already; --resume finishes an interrupted run, else choose "
          "another output folder (--output)",
          out.string());
    }
    // Killed after the export was renamed into place, before the staging folder went.
    if (fs::exists(staging)) RemoveAll(staging);
    return {};
  }
  if (fs::exists(out)) {
    if (!fs::is_directory(out) || !fs::is_empty(out)) {
      throw Error(
          "exists and is not a LeRobot dataset; datagen --format lerobot writes a new folder "
          "(its episodes go to " +
              staging.filename().string() + " beside it until the run ends)",
          out.string());
    }
    fs::remove(out);
  }
  config.output_dir = staging;
  return out;
}

void FinishLeRobotRun(const fs::path& staging, const fs::path& out) {
  Helper({"export-lerobot", staging.string(), out.string(), "-q", "--episode-records"},
         "writing the LeRobot dataset of the run", staging);
  RemoveAll(staging);
}

bool MergeLeRobot(const std::string& output, const std::vector<std::string>& inputs, bool partial) {
  size_t lerobot = 0;
  for (const std::string& in : inputs) lerobot += IsLeRobot(in) ? 1 : 0;
  if (lerobot == 0) return false;
  if (lerobot != inputs.size()) {
    throw Error("mixes LeRobot datasets and HDF5 run folders; merge one kind", output);
  }
  const fs::path out = fs::absolute(output).lexically_normal();
  if (fs::exists(out)) throw Error("already exists; choose another folder", out.string());
  const fs::path parent = out.parent_path();
  CreateDirectories(parent);
  RemoveDeadTempFiles(parent);
  // Each input imported (import-lerobot), merged as HDF5 runs, exported again; all in temp
  // folders beside OUTPUT, removed at the end (a killed merge leaves only dead temp folders,
  // which the next one removes).
  const fs::path work = parent / (out.filename().string() + ".merge" + TempSuffix());
  struct Cleanup {
    fs::path p;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  } cleanup{work};
  CreateDirectories(work);
  std::vector<fs::path> runs;
  for (size_t i = 0; i < inputs.size(); ++i) {
    runs.push_back(work / ("input_" + std::to_string(i)));
    Helper({"import-lerobot", inputs[i], runs.back().string(), "-q"}, "import-lerobot", work);
  }
  const fs::path merged = work / "merged";
  const datagen::MergeReport r = datagen::MergeRuns(runs, merged, partial);
  Helper({"export-lerobot", merged.string(), out.string(), "-q"}, "the LeRobot export", work);
  std::printf(
      "merged %zu LeRobot datasets into %s: %lld batch files, %lld episodes, %lld attempts\n",
      inputs.size(), output.c_str(), static_cast<long long>(r.batch_files),
      static_cast<long long>(r.episodes), static_cast<long long>(r.attempts));
  for (const std::string& m : r.missing) Warn("not finished in any input: " + m);
  return true;
}

}  // namespace mlspaces::cli
