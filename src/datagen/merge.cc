// MergeRuns (run.h): combines the folders of a sharded run into one dataset.
#include <algorithm>
#include <map>
#include <set>

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/datagen/recorder.h"
#include "mlspaces/datagen/run.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;
namespace {

// Links `from` to `to` (a copy across file systems), through a temp name renamed into place.
void LinkOrCopy(const fs::path& from, const fs::path& to) {
  const fs::path tmp = to.string() + ".tmp.merge";
  std::error_code ec;
  fs::remove(tmp, ec);
  // Linked already by a merge that was killed: done. (Linking again would leave the temp
  // name behind: rename() of two links to one file does nothing.)
  if (fs::equivalent(from, to, ec)) return;
  fs::create_hard_link(from, tmp, ec);
  if (ec) {
    ec.clear();
    fs::copy_file(from, tmp, fs::copy_options::overwrite_existing, ec);
    if (ec) throw Error("cannot copy: " + ec.message(), from.string());
  }
  fs::rename(tmp, to, ec);
  if (ec) throw Error("cannot rename into place: " + ec.message(), to.string());
  CrashPoint("merged file linked into place");
}

}  // namespace

MergeReport MergeRuns(const std::vector<fs::path>& inputs, const fs::path& output,
                      bool allow_partial) {
  if (inputs.empty()) throw UsageError("merge: no run folders given");
  const ConfigRegistry configs = ConfigRegistry::WithBuiltins();
  std::optional<ExperimentConfig> config;
  std::string config_text, hash;
  for (const fs::path& in : inputs) {
    const fs::path file = in / "config.yaml";
    if (!IsFile(file)) throw Error("not a run folder (no config.yaml)", in.string());
    ExperimentConfig c = LoadConfigFile(file, configs);
    std::string h = RecordedDataHash(file);  // shards may have run in other folders
    if (h.empty()) h = DataConfigHashHex(c);
    if (!config) {
      config = std::move(c);
      hash = h;
      config_text = ReadFile(file);
    } else if (h != hash) {
      throw Error("holds another config (data hash " + h + ", " + inputs[0].string() + " has " +
                      hash + "): only shards of one run can be merged",
                  file.string());
    }
  }
  if (std::error_code exists_ec; fs::exists(output / "config.yaml", exists_ec)) {
    throw Error("the output folder already holds a run", output.string());
  }
  MergeReport report;
  std::vector<std::pair<const WorkItem*, fs::path>> found;
  const std::vector<WorkItem> items = PlanWorkItems(*config);
  for (const WorkItem& item : items) {
    const fs::path rel =
        fs::path(item.scene_name()) / (BatchFileStem(item.batch, item.num_batches) + ".h5");
    std::optional<fs::path> where;
    for (const fs::path& in : inputs) {
      if (!IsFile(in / rel)) continue;
      if (where) {
        throw Error(
            "two inputs hold " + rel.string() + ": " + where->string() + " and " + in.string(),
            output.string());
      }
      where = in;
    }
    if (where) {
      found.emplace_back(&item, *where);
    } else {
      report.missing.push_back(rel.string());
    }
  }
  if (!report.missing.empty() && !allow_partial) {
    throw Error(std::to_string(report.missing.size()) + " of " + std::to_string(items.size()) +
                    " batches are not finished in any input (first: " + report.missing[0] +
                    "); finish those shards, or merge with --partial",
                output.string());
  }
  std::error_code ec;
  fs::create_directories(output, ec);
  if (ec) throw Error("cannot create the output folder: " + ec.message(), output.string());
  RemoveDeadTempFiles(output);  // journal or summary temp files of a merge that was killed
  for (const auto& [item, in] : found) {
    const fs::path dir = output / item->scene_name();
    CreateDirectories(dir);
    const std::string stem = BatchFileStem(item->batch, item->num_batches);
    const fs::path h5 = in / item->scene_name() / (stem + ".h5");
    LinkOrCopy(h5, dir / h5.filename());
    report.episodes += CountEpisodes(h5);
    ++report.batch_files;
    // The batch's videos: episode_<k>_<camera>_batch_<b>_of_<n>.mp4.
    const std::string suffix = "_" + stem.substr(std::string("trajectories_").size()) + ".mp4";
    for (const fs::path& e : ListFolder(in / item->scene_name())) {
      const std::string name = e.filename().string();
      if (name.rfind("episode_", 0) == 0 && name.size() > suffix.size() &&
          name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) {
        LinkOrCopy(e, dir / name);
      }
    }
  }
  // Journals: every input's, as one file sorted by scene and episode.
  std::vector<AttemptRecord> all;
  for (const fs::path& in : inputs) {
    for (const fs::path& e : ListFolder(in)) {
      const std::string name = e.filename().string();
      if (name.rfind("journal", 0) == 0 && e.extension() == ".jsonl") {
        const JournalContents j = ReadJournal(e);
        all.insert(all.end(), j.records.begin(), j.records.end());
      }
    }
  }
  std::stable_sort(all.begin(), all.end(), [](const AttemptRecord& a, const AttemptRecord& b) {
    return std::tie(a.scene, a.episode) < std::tie(b.scene, b.episode);
  });
  std::string lines;
  for (const AttemptRecord& r : all) lines += r.ToJson().dump() + "\n";
  report.attempts = static_cast<int64_t>(all.size());
  WriteFileAtomic(output / "journal.jsonl", lines);
  WriteFileAtomic(output / "summary.txt", "data hash " + hash + ", merged from " +
                                              std::to_string(inputs.size()) + " folders\n" +
                                              FormatSummary(Summarize(all)));
  WriteFileAtomic(output / "config.yaml", config_text);  // last: marks the folder complete
  return report;
}

}  // namespace mlspaces::datagen
