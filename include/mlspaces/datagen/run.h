// A datagen run: the config's scenes split into work items (scene x batch), each run to its
// quota of kept episodes within its attempt budget; every attempt journaled, every kept
// episode written as it ends, a summary at the end (spec 2, 11). docs/datagen.md.
//
// Run folder (RunFolder(config)):
//   config.yaml                    the resolved config, seed filled in
//   journal.jsonl                  one line per attempt (journal.h); journal.shard_<i>_of_<n>.jsonl
//                                  for shard i of n
//   summary.txt                    outcome counts, success rates, stage times (per shard too)
//   house_<h>/trajectories_batch_<b>_of_<n>.h5
//
// Workers: num_workers processes (fork) take the work items round-robin; each builds its own
// env, planner and recorder and reports every attempt through a pipe to the parent, the only
// writer of the journal. Episodes are written by the workers as they end (recorder parts).
//
// Resume (RunOptions::resume): finished work items (batch file present) are skipped; an
// interrupted one continues after its last attempt, known from the journal and from the
// episodes already written (a kill between writing an episode and journaling it is repaired
// from the episode's provenance). Episodes depend only on their own seed, so the resumed
// dataset equals an uninterrupted run's.
//
// Sharding (RunOptions::shard = i/n): work item k (in PlanWorkItems order) belongs to shard
// k % n. Shards may share one folder (each has its own journal) or use their own folders
// (MergeRuns combines them).
#pragma once

#include "mlspaces/core/export.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/journal.h"
#include "mlspaces/datagen/task_sampler.h"
#include "mlspaces/sim/renderer.h"

namespace mlspaces::datagen {

/// One unit of work: `episodes` kept episodes of one scene, written as one batch file.
struct MLSPACES_API WorkItem {
  int64_t house = 0;  ///< index into scene_xml_paths
  std::filesystem::path scene_xml;
  int batch = 1;  ///< 1-based
  int num_batches = 1;
  int64_t episodes = 0;      ///< episodes to keep
  int64_t max_attempts = 0;  ///< episodes * max_total_attempts_multiplier
  /// First episode number of this item: episode numbers (which seed the episodes) are
  /// first_episode + attempt, unique per scene whatever the worker or order.
  int64_t first_episode = 0;

  std::string scene_name() const { return "house_" + std::to_string(house); }
};

/// The work items of a config, houses in order, batches in order. Per house:
/// batches = max(1, round_half_even(samples_per_house / episodes_per_batch)), episodes split
/// as evenly as possible (earlier batches get the remainder; docs/datagen.md).
MLSPACES_API std::vector<WorkItem> PlanWorkItems(const ExperimentConfig& config);

/// The run folder: output_dir, or ./experiment_output/<tag> when output_dir is null.
MLSPACES_API std::filesystem::path RunFolder(const ExperimentConfig& config);

/// Shard `index` of `count` (0 <= index < count).
struct MLSPACES_API Shard {
  int index = 0;
  int count = 1;
  /// "" for the whole run, else "shard_<i>_of_<n>".
  std::string Name() const;
};
/// Parses "i/N". @throws UsageError naming the flag for anything else.
MLSPACES_API Shard ParseShard(std::string_view text);
/// The items of `shard`: item k of `items` when k % count == index.
MLSPACES_API std::vector<WorkItem> ShardItems(const std::vector<WorkItem>& items,
                                              const Shard& shard);
/// The journal of a shard in `folder`: journal.jsonl, or journal.<shard name>.jsonl.
MLSPACES_API std::filesystem::path JournalPath(const std::filesystem::path& folder,
                                               const Shard& shard);

/// The data hash (DataConfigHashHex) a run folder's config.yaml records in its first line
/// when the run began, or "" when it records none. Resume and merge compare it.
MLSPACES_API std::string RecordedDataHash(const std::filesystem::path& config_file);

struct MLSPACES_API RunOptions {
  /// Continue the run found in the folder. Without it a folder that already holds a run is
  /// an error (so a typo in --output never mixes two runs).
  bool resume = false;
  Shard shard;
  /// Worker processes; 0 = config.num_workers. 1 runs in this process.
  int workers = 0;
  /// Headless GL for the cameras (one context per worker).
  sim::GlBackend gl_backend = sim::GlBackend::kOsMesa;
  /// Report progress on stderr per episode: episodes kept / target, attempts, success rate,
  /// episodes per hour, ETA; a bar on a terminal, else a line at most once a second.
  bool progress = true;
  /// Receives log lines (without newline): one per attempt at debug level, one per work item
  /// at info level, warnings.
  std::function<void(LogLevel, const std::string&)> log;
  /// Called in this process after every attempt is journaled (e.g. for custom progress). An
  /// exception it throws stops the run (what was journaled stays; `resume` continues).
  std::function<void(const WorkItem&, const AttemptRecord&)> on_attempt;
  /// Around each worker's fork (workers > 1): in this process before and after, and first
  /// thing in the worker. The Python binding updates the interpreter's state here
  /// (PyOS_BeforeFork / PyOS_AfterFork_*), so Python samplers run in forked workers.
  std::function<void()> before_fork, after_fork_parent, after_fork_child;
  /// false: no HDF5 (datagen --format lerobot, docs/lerobot.md): episodes are kept as
  /// EpisodeRecord parts (RecorderOptions::hdf5) and a finished work item is its folder
  /// house_<h>/trajectories_batch_<b>_of_<n>.episodes instead of a batch file.
  bool hdf5 = true;
};

struct MLSPACES_API RunReport {
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
/// stored in config.yaml (a resumed run reuses it); a sharded run needs an explicit seed.
/// @throws Error for a bad config, scene or library, or a folder holding a run (another
/// config's, or any without `resume`); attempt failures are journaled, not thrown.
MLSPACES_API RunReport RunDatagen(const ExperimentConfig& config,
                                  const TaskSamplerRegistry& samplers,
                                  const RunOptions& options = {});

struct MLSPACES_API MergeReport {
  int64_t batch_files = 0;
  int64_t episodes = 0;
  int64_t attempts = 0;
  /// Work items of the config that no input has finished (MergeRuns fails on any unless
  /// allow_partial).
  std::vector<std::string> missing;
};

/// Combines run folders (shards) of one config into `output`: every finished batch file and
/// the videos next to it (hard links where possible, else copies), the journals as one
/// journal.jsonl sorted by scene and episode, config.yaml and summary.txt.
/// @throws Error when the inputs hold different configs (data hash), two inputs hold the
/// same batch, `output` already holds a run, or (without allow_partial) a work item is missing.
MLSPACES_API MergeReport MergeRuns(const std::vector<std::filesystem::path>& inputs,
                                   const std::filesystem::path& output, bool allow_partial = false);

}  // namespace mlspaces::datagen
