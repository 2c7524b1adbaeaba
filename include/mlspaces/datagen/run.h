// A datagen run: the config's scenes split into work items (scene x batch), each run to its
// quota of kept episodes within its attempt budget; every attempt journaled, every kept
// episode written as it ends, a summary at the end (spec 2, 11).
//
// Run folder (RunFolder(config)):
//   config.yaml                    the resolved config, seed filled in (its hash names the run)
//   journal.jsonl                  one line per attempt (journal.h)
//   summary.txt                    outcome counts, success rates, stage times
//   house_<h>/trajectories_batch_<b>_of_<n>.h5
//
// Re-running into a folder holding the same config continues it: finished work items (their
// batch file exists) are skipped; an interrupted one resumes after its last journaled attempt,
// keeping the episodes already written. A folder holding another config is an error.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/journal.h"
#include "mlspaces/datagen/task_sampler.h"

namespace mlspaces::datagen {

/// One unit of work: `episodes` kept episodes of one scene, written as one batch file.
struct WorkItem {
  int64_t house = 0;                  ///< index into scene_xml_paths
  std::filesystem::path scene_xml;
  int batch = 1;                      ///< 1-based
  int num_batches = 1;
  int64_t episodes = 0;               ///< episodes to keep
  int64_t max_attempts = 0;           ///< episodes * max_total_attempts_multiplier
  /// First episode number of this item: episode numbers (which seed the episodes) are
  /// first_episode + attempt, unique per scene whatever the worker or order.
  int64_t first_episode = 0;

  std::string scene_name() const { return "house_" + std::to_string(house); }
};

/// The work items of a config, houses in order, batches in order. Per house:
/// batches = max(1, round_half_even(samples_per_house / episodes_per_batch)), episodes split
/// as evenly as possible (earlier batches get the remainder), as the original.
std::vector<WorkItem> PlanWorkItems(const ExperimentConfig& config);

/// The run folder: output_dir, or ./experiment_output/<tag> when output_dir is null.
std::filesystem::path RunFolder(const ExperimentConfig& config);

struct RunOptions {
  /// Draw a progress bar (only on a terminal).
  bool progress = true;
  /// Receives log lines (without newline): one per attempt at info level and per work item.
  std::function<void(LogLevel, const std::string&)> log;
  /// Called after every attempt (e.g. for custom progress).
  std::function<void(const WorkItem&, const AttemptRecord&)> on_attempt;
};

struct RunReport {
  std::filesystem::path folder;
  uint64_t seed = 0;
  JournalSummary summary;  ///< over this invocation's attempts
  std::vector<std::filesystem::path> batch_files;
  int64_t items_skipped = 0;  ///< already finished before this invocation
  int64_t episodes_kept = 0;
  int64_t policy_steps = 0;
  int64_t physics_steps = 0;
  double seconds = 0;
};

/// Runs `config` (validated) with the samplers of `samplers`. A null seed is drawn once and
/// stored in config.yaml (a resumed run reuses it).
/// @throws Error for a bad config, scene or library, or a folder holding another run; attempt
/// failures are journaled, not thrown.
RunReport RunDatagen(const ExperimentConfig& config, const TaskSamplerRegistry& samplers,
                     const RunOptions& options = {});

}  // namespace mlspaces::datagen
