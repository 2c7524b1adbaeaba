#include "mlspaces/datagen/run.h"

#include <signal.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/file_lock.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/progress.h"
#include "mlspaces/core/subprocess.h"
#include "mlspaces/core/yaml_archive.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/episode_runner.h"
#include "mlspaces/datagen/preflight.h"
#include "mlspaces/datagen/recorder.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/sim/renderer.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;

// Python's round(): halves to even.
int64_t RoundHalfEven(double x) {
  const double f = std::floor(x);
  const double diff = x - f;
  if (diff > 0.5) return static_cast<int64_t>(f) + 1;
  if (diff < 0.5) return static_cast<int64_t>(f);
  const auto i = static_cast<int64_t>(f);
  return i % 2 == 0 ? i : i + 1;
}

uint64_t DrawSeed() {
  std::random_device device;
  return (static_cast<uint64_t>(device()) << 32) ^ device();
}

// What differs between two configs in the values that shape the data (DataFields, paths left
// out), as "seed 0 -> 1, task_sampler_config.samples_per_house 4 -> 8" (at most 6, then "and
// N more"); empty when those values are the same.
std::string ConfigChanges(const ExperimentConfig& before, const ExperimentConfig& after) {
  // Paths compare by content (the data hash), not by location: a moved project is the same.
  auto data_yaml = [](const ExperimentConfig& c) {
    return YAML::Load(DumpConfig(DataFields(c, false)));
  };
  auto text = [](const YAML::Node& node) {
    if (!node.IsDefined()) return std::string("(none)");
    YAML::Emitter out;
    out << YAML::Flow << node;
    std::string s = out.c_str();
    return s.size() > 60 ? s.substr(0, 57) + "..." : s;
  };
  std::vector<std::string> changes;
  std::function<void(const YAML::Node&, const YAML::Node&, const std::string&)> walk =
      [&](const YAML::Node& a, const YAML::Node& b, const std::string& key) {
        if (a.IsMap() && b.IsMap()) {
          std::vector<std::string> keys;
          for (const auto& kv : a) keys.push_back(kv.first.as<std::string>());
          for (const auto& kv : b) {
            const std::string k = kv.first.as<std::string>();
            if (!a[k]) keys.push_back(k);
          }
          for (const std::string& k : keys) walk(a[k], b[k], YamlChildKey(key, k));
        } else if (a.IsSequence() && b.IsSequence() && a.size() == b.size()) {
          for (size_t i = 0; i < a.size(); ++i) {
            walk(a[i], b[i], key + "[" + std::to_string(i) + "]");
          }
        } else if (text(a) != text(b)) {
          changes.push_back(key + " " + text(a) + " -> " + text(b));
        }
      };
  walk(data_yaml(before), data_yaml(after), "");
  std::string out;
  for (size_t i = 0; i < changes.size() && i < 6; ++i) out += (i ? ", " : "") + changes[i];
  if (changes.size() > 6) out += " and " + std::to_string(changes.size() - 6) + " more";
  return out;
}

// The config to run, checked against a run already in the folder: a null seed takes the
// stored one, a null licence policy too (else MLSPACES_LICENSE_POLICY's when it is not "all";
// null means "all"). Without `resume`, a folder whose run (this shard's journal) exists is
// refused.
ExperimentConfig SettleRunConfig(const ExperimentConfig& config, const fs::path& file,
                                 const fs::path& journal, const RunOptions& options) {
  ExperimentConfig run = config;
  if (options.shard.count > 1 && !run.seed) {
    throw UsageError(
        "a sharded run needs a seed (set `seed` or --seed), so that every shard "
        "draws the same episodes");
  }
  if (!IsFile(file)) {
    if (!run.seed) run.seed = DrawSeed();
    if (!run.license_policy && ResolveLicensePolicy() != LicensePolicy::kAll) {
      run.license_policy = ResolveLicensePolicy();  // MLSPACES_LICENSE_POLICY, recorded
    }
    return run;
  }
  const ExperimentConfig stored = LoadConfigFile(file, ConfigRegistry::WithBuiltins());
  if (!run.seed) run.seed = stored.seed;
  // A null policy: the stored run's, else MLSPACES_LICENSE_POLICY (null stays null for "all").
  if (!run.license_policy) run.license_policy = stored.license_policy;
  if (!run.license_policy && ResolveLicensePolicy() != LicensePolicy::kAll) {
    run.license_policy = ResolveLicensePolicy();
  }
  // The hash recorded when the run began (its paths may since have moved with the folder).
  std::string stored_hash = RecordedDataHash(file);
  if (stored_hash.empty()) stored_hash = DataConfigHashHex(stored);
  if (const std::string run_hash = DataConfigHashHex(run); stored_hash != run_hash) {
    // Which fields changed (seed, episodes, ...); the hashes when the fields say nothing.
    std::string changes = ConfigChanges(stored, run);
    if (changes.empty()) {
      changes =
          "the same fields, but a library, scene or robot file they name changed since "
          "the run began: data hash " +
          stored_hash + ", now " + run_hash;
    }
    throw Error("the folder holds a run of another config (" + changes +
                    "); --resume continues a run only with its own config: choose another "
                    "output folder (--output), or remove this one to start over",
                file.string());
  }
  std::error_code ec;
  if (!options.resume && fs::file_size(journal, ec) > 0 && !ec) {
    throw Error(
        "the folder already holds this run: pass --resume to continue it, or choose "
        "another output folder",
        file.string());
  }
  return run;
}

std::string Duration(double seconds) {
  char buf[32];
  const auto s = static_cast<int64_t>(std::max(0.0, seconds));
  if (s >= 3600) {
    std::snprintf(buf, sizeof buf, "%lldh%02lldm", static_cast<long long>(s / 3600),
                  static_cast<long long>(s % 3600 / 60));
  } else {
    std::snprintf(buf, sizeof buf, "%lldm%02llds", static_cast<long long>(s / 60),
                  static_cast<long long>(s % 60));
  }
  return buf;
}

// Runs work items in this process: env per scene (kept while consecutive items share it),
// recorder per item, resume bookkeeping. Reports through `emit` (JSON messages):
//   {"item": k, "attempt": {...}, "kept": bool}   one attempt, after its episode is written
//   {"item": k, "finished": true, "kept": n, "batch_file": "..."}
class ItemRunner {
 public:
  using Emit = std::function<void(const Json&)>;

  // `registry` and `sampler` are the run's (a forked worker uses its own copies of them).
  ItemRunner(const ExperimentConfig& config, const Registry& registry, TaskSampler& sampler,
             const fs::path& folder, const std::vector<AttemptRecord>& earlier, sim::GlBackend gl,
             bool hdf5, Emit emit)
      : config_(config),
        folder_(folder),
        earlier_(earlier),
        gl_(gl),
        hdf5_(hdf5),
        emit_(std::move(emit)),
        registry_(registry),
        sampler_(sampler),
        hash_(DataConfigHashHex(config)) {}

  void Run(size_t index, const WorkItem& item) {
    const std::string scene = item.scene_name();
    RecorderOptions rec_options;
    rec_options.dir = folder_ / scene;
    rec_options.batch = item.batch;
    rec_options.num_batches = item.num_batches;
    rec_options.hdf5 = hdf5_;
    Recorder recorder(rec_options);
    // Where the item stopped: after its last journaled attempt, or after its last written
    // episode when the kill came between writing it and journaling it (that attempt's line
    // is restored from the episode's provenance).
    std::set<int64_t> journaled;
    int64_t next = 0;
    for (const AttemptRecord& r : earlier_) {
      if (r.scene == scene && r.episode >= item.first_episode &&
          r.episode < item.first_episode + item.max_attempts) {
        journaled.insert(r.episode);
        next = std::max(next, r.episode - item.first_episode + 1);
      }
    }
    for (int k = 0; k < recorder.next_index(); ++k) {
      const Json prov = recorder.PartProvenance(k);
      const int64_t episode = prov.value("source_episode", int64_t{-1});
      if (episode < item.first_episode || episode >= item.first_episode + item.max_attempts) {
        throw Error("episode part " + std::to_string(k) + " belongs to episode " +
                        std::to_string(episode) + ", outside this batch",
                    recorder.parts_dir().string());
      }
      next = std::max(next, episode - item.first_episode + 1);
      if (journaled.count(episode) == 0) {
        const Json* attempt = prov.contains("extra") && prov["extra"].contains("attempt")
                                  ? &prov["extra"]["attempt"]
                                  : nullptr;
        if (attempt == nullptr) {
          throw Error("episode part " + std::to_string(k) + " has no attempt record",
                      recorder.parts_dir().string());
        }
        emit_(Json{{"item", index}, {"attempt", *attempt}, {"kept", true}, {"restored", true}});
      }
    }
    int64_t kept = recorder.next_index();
    // Videos of this item's episodes that were never kept (a kill mid-episode).
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(rec_options.dir, ec)) {
      const std::string name = e.path().filename().string();
      long long episode = -1;
      if (std::sscanf(name.c_str(), ".episode_%lld_", &episode) == 1 &&
          episode >= item.first_episode && episode < item.first_episode + item.max_attempts) {
        fs::remove(e.path(), ec);
      }
    }
    if (env_house_ != item.house) {
      runner_.reset();
      env_.reset();
      env_.emplace(CreateSceneEnv(config_, sampler_, item.scene_xml, scene));
      sampler_.PrepareEnv(*env_);
      env_house_ = -1;  // a scene whose preflight throws is built again by the next item
      // Broken input stops the run here, before the scene's first attempt, when no pickup
      // candidate is left; broken candidates beside good ones are reported (preflight.h).
      for (const Error& problem :
           PreflightScene(*env_, item.scene_xml, registry_, config_).problems) {
        emit_(Json{{"warning", scene + ": attempts on this pickup candidate will fail: " +
                                   std::string(problem.what())}});
      }
      EpisodeRunnerOptions runner_options;
      runner_options.scene_name = scene;
      runner_options.video_dir = rec_options.dir;
      runner_options.gl_backend = gl_;
      runner_options.config_hash = hash_;  // hashed once, not per scene
      runner_ =
          std::make_unique<EpisodeRunner>(*env_, sampler_, registry_, config_, runner_options);
      env_house_ = item.house;
      one_pass_told_ = false;
    }
    int64_t sequential_rejects = 0;
    // Attempts of this invocation, and those that failed for an input reason (the first kept).
    int64_t ran = 0, input_failed = 0;
    std::optional<Error> input_error;
    for (int64_t a = next; kept < item.episodes && a < item.max_attempts; ++a) {
      EpisodeResult result = runner_->Run(item.first_episode + a);
      ++ran;
      TellOnePassMissed(scene);
      if (result.input_error) {
        ++input_failed;
        if (!input_error) input_error = result.input_error;
      }
      const bool keep = result.record.has_value() &&
                        (result.success || !config_.filter_for_successful_trajectories);
      if (keep) {
        // The videos take their final names (episode index in the batch), then the episode.
        for (CameraRecord& cam : result.record->cameras) {
          for (auto [file, camera] : {std::pair{&cam.video_file, cam.name},
                                      std::pair{&cam.depth_video_file, cam.name + "_depth"}}) {
            if (file->empty()) continue;
            const std::string final_name = recorder.VideoFileName(recorder.next_index(), camera);
            RenamePath(rec_options.dir / *file, rec_options.dir / final_name);
            *file = final_name;
            CrashPoint("video given its final name");
          }
        }
        recorder.Write(*result.record);
        ++kept;
      } else if (result.record) {
        for (const CameraRecord& cam : result.record->cameras) {
          for (const std::string& file : {cam.video_file, cam.depth_video_file}) {
            if (!file.empty()) fs::remove(rec_options.dir / file, ec);
          }
        }
      }
      Json message{{"item", index},
                   {"attempt", result.attempt.ToJson()},
                   {"kept", keep},
                   {"policy_steps", result.policy_steps},
                   {"physics_steps", result.physics_steps}};
      emit_(message);
      if (result.attempt.outcome == Outcome::kSamplerReject) {
        if (++sequential_rejects >=
            config_.task_sampler_config.max_allowed_sequential_task_sampler_failures) {
          emit_(Json{{"warning", scene + ": the task sampler rejected " +
                                     std::to_string(sequential_rejects) +
                                     " tasks in a row; giving up on this batch"}});
          break;
        }
      } else {
        sequential_rejects = 0;
      }
    }
    if (kept == 0 && ran > 0 && input_failed == ran) {
      // Every attempt failed on the input: the run stops, naming the file and the field.
      throw Error(input_error->message() + " (every attempt of " + scene + " batch " +
                      std::to_string(item.batch) + "/" + std::to_string(item.num_batches) +
                      " failed so)",
                  input_error->path(), input_error->field(), input_error->uid());
    }
    const bool wrote = recorder.Finish();
    emit_(Json{{"item", index},
               {"finished", true},
               {"kept", kept},
               {"batch_file", wrote ? recorder.batch_file().string() : std::string()}});
  }

 private:
  const ExperimentConfig& config_;
  fs::path folder_;
  const std::vector<AttemptRecord>& earlier_;
  sim::GlBackend gl_;
  bool hdf5_;  // RunOptions::hdf5
  Emit emit_;
  const Registry& registry_;
  TaskSampler& sampler_;
  std::string hash_;  // DataConfigHashHex(config_)
  std::optional<Env> env_;
  // Once per scene: frames with shadows that one pass could not draw (they cost about twice
  // as much through mjr_render), and why. The same text from every worker: said once.
  void TellOnePassMissed(const std::string& scene) {
    const CameraRecorder* cameras = runner_->cameras();
    if (one_pass_told_ || cameras == nullptr || cameras->renderer().one_pass_missed().empty()) {
      return;
    }
    emit_(Json{{"warning", scene + ": one-pass shadows cannot draw its camera frames (" +
                               cameras->renderer().one_pass_missed() +
                               "): they take MuJoCo's passes, about twice the render time"
                               " (docs/sim.md, \"Shadows in one pass\")"}});
    one_pass_told_ = true;
  }

  std::unique_ptr<EpisodeRunner> runner_;
  int64_t env_house_ = -1;
  bool one_pass_told_ = false;
};

// A forked worker: runs its items, reports through `fd`; returns the exit status.
int WorkerMain(int fd, pid_t parent, const ExperimentConfig& config, const Registry& registry,
               TaskSampler& sampler, const fs::path& folder, sim::GlBackend gl, bool hdf5,
               int worker, int workers, const std::vector<AttemptRecord>& earlier,
               const std::vector<std::pair<size_t, WorkItem>>& items) {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // a killed parent takes its workers along
  if (::getppid() != parent) ::_exit(3);
  ::signal(SIGPIPE, SIG_IGN);
  // Mesa's software rasteriser starts one thread per core in every process; with several
  // workers that oversubscribes the cores. Share them out unless the user chose. A worker with
  // one core rasterises on its own thread (0): a rasteriser thread beside it costs 1-5% in
  // hand-overs (bench/render_bench.sh). The frames are the same bytes either way.
  if (std::getenv("LP_NUM_THREADS") == nullptr) {
    const long cores = std::max(1L, ::sysconf(_SC_NPROCESSORS_ONLN));
    const long share = cores / workers;
    ::setenv("LP_NUM_THREADS", std::to_string(share > 1 ? share : 0).c_str(), 1);
  }
  sim::SetRenderWorker(worker);  // EGL devices are taken in turn by the workers
  int code = 0;
  auto emit = [fd](const Json& message) {
    if (!WriteAll(fd, message.dump() + "\n")) ::_exit(4);
  };
  try {
    ItemRunner runner(config, registry, sampler, folder, earlier, gl, hdf5, emit);
    for (const auto& [index, item] : items) runner.Run(index, item);
  } catch (const std::exception& e) {
    emit(Json{{"error", e.what()}});
    code = 1;
  }
  return code;
}

}  // namespace

std::string Shard::Name() const {
  if (count <= 1) return "";
  return "shard_" + std::to_string(index) + "_of_" + std::to_string(count);
}

Shard ParseShard(std::string_view text) {
  Shard s;
  const size_t slash = text.find('/');
  auto parse = [](std::string_view part, int& out) {
    const auto [ptr, ec] = std::from_chars(part.data(), part.data() + part.size(), out);
    return !part.empty() && ec == std::errc() && ptr == part.data() + part.size();
  };
  if (slash == std::string_view::npos || !parse(text.substr(0, slash), s.index) ||
      !parse(text.substr(slash + 1), s.count) || s.count < 1 || s.index < 0 || s.index >= s.count) {
    throw UsageError("--shard: expected I/N with 0 <= I < N, got '" + std::string(text) + "'");
  }
  return s;
}

std::vector<WorkItem> ShardItems(const std::vector<WorkItem>& items, const Shard& shard) {
  std::vector<WorkItem> out;
  for (size_t k = 0; k < items.size(); ++k) {
    if (static_cast<int>(k % static_cast<size_t>(shard.count)) == shard.index) {
      out.push_back(items[k]);
    }
  }
  return out;
}

// config.yaml's first line, before the hash: written by RunDatagen, read by RecordedDataHash.
constexpr std::string_view kDataHashLine = "# mlspaces datagen run; data hash ";

std::string RecordedDataHash(const fs::path& config_file) {
  std::string first;
  if (std::ifstream in(config_file); !std::getline(in, first)) return "";
  if (!first.starts_with(kDataHashLine)) return "";
  return first.substr(kDataHashLine.size());
}

fs::path JournalPath(const fs::path& folder, const Shard& shard) {
  return folder / (shard.count <= 1 ? "journal.jsonl" : "journal." + shard.Name() + ".jsonl");
}

std::vector<WorkItem> PlanWorkItems(const ExperimentConfig& config) {
  const TaskSamplerConfig& s = config.task_sampler_config;
  std::vector<int64_t> houses;
  if (s.house_inds) {
    houses = *s.house_inds;
  } else {
    for (size_t i = 0; i < s.scene_xml_paths.size(); ++i) houses.push_back(static_cast<int64_t>(i));
  }
  std::vector<WorkItem> items;
  for (const int64_t house : houses) {
    if (house < 0 || house >= static_cast<int64_t>(s.scene_xml_paths.size())) {
      throw Error("house index " + std::to_string(house) + " is out of range (" +
                      std::to_string(s.scene_xml_paths.size()) + " scene_xml_paths)",
                  "", "task_sampler_config.house_inds");
    }
    const int64_t n = s.samples_per_house;
    const int64_t batches = std::max<int64_t>(
        1, RoundHalfEven(static_cast<double>(n) / static_cast<double>(s.episodes_per_batch)));
    int64_t first = 0;
    for (int64_t b = 0; b < batches; ++b) {
      WorkItem item;
      item.house = house;
      item.scene_xml = s.scene_xml_paths[house];
      item.batch = static_cast<int>(b + 1);
      item.num_batches = static_cast<int>(batches);
      item.episodes = n / batches + (b < n % batches ? 1 : 0);
      item.max_attempts = item.episodes * s.max_total_attempts_multiplier;
      item.first_episode = first;
      first += item.max_attempts;
      if (item.episodes > 0) items.push_back(item);
    }
  }
  return items;
}

fs::path RunFolder(const ExperimentConfig& config) {
  if (config.output_dir) return *config.output_dir;
  return fs::current_path() / "experiment_output" / config.tag;
}

RunReport RunDatagen(const ExperimentConfig& input, const TaskSamplerRegistry& samplers,
                     const RunOptions& options) {
  const auto t_start = Clock::now();
  auto log = [&](LogLevel level, const std::string& line) {
    if (options.log && level >= input.log_level) options.log(level, line);
  };
  RunReport report;
  report.folder = RunFolder(input);
  std::error_code ec;
  fs::create_directories(report.folder, ec);
  if (ec) throw Error("cannot create the run folder: " + ec.message(), report.folder.string());
  const std::string shard_name = options.shard.Name();
  // An exclusive lock on the run folder (per shard), held by the run and inherited by its
  // forked workers: it lives until every process holding it is gone, so a resumed run never
  // overlaps a killed run's last workers. A second run waits (and says so) rather than fail:
  // a requeued Slurm task may start while its killed predecessor is still being torn down.
  const FileLock lock(
      report.folder / (shard_name.empty() ? ".lock" : ".lock." + shard_name), [&](long pid) {
        log(LogLevel::kWarning, "waiting for the datagen run with pid " + std::to_string(pid) +
                                    " working in " + report.folder.string() + " to end");
      });
  // Temp files a killed run left in the folder (config.yaml or a summary mid-write): those of
  // processes that no longer exist (".tmp.<pid>.<n>", TempSuffix), so a shard sharing the
  // folder keeps its own.
  RemoveDeadTempFiles(report.folder);
  const fs::path config_file = report.folder / "config.yaml";
  const fs::path journal_file = JournalPath(report.folder, options.shard);
  const ExperimentConfig config = SettleRunConfig(input, config_file, journal_file, options);
  report.seed = *config.seed;
  const std::string hash = DataConfigHashHex(config);
  if (!IsFile(config_file)) {
    WriteFileAtomic(config_file, std::string(kDataHashLine) + hash + "\n" + DumpConfig(config));
  }
  const std::vector<WorkItem> items = ShardItems(PlanWorkItems(config), options.shard);
  // The libraries and the sampler, before any worker starts (a bad sampler name or library
  // fails here, once); forked workers inherit them.
  Registry registry(Registry::Options{config.libraries.assets_dir});
  config.libraries.ApplyTo(registry);
  const std::unique_ptr<TaskSampler> sampler = samplers.Create(config, report.seed);

  Journal journal(journal_file);
  const std::vector<AttemptRecord> earlier = ReadJournal(journal_file).records;

  // What is left to do.
  std::vector<std::pair<size_t, WorkItem>> todo;
  int64_t total_episodes = 0, done_episodes = 0;
  for (size_t k = 0; k < items.size(); ++k) {
    const WorkItem& item = items[k];
    total_episodes += item.episodes;
    const fs::path dir = report.folder / item.scene_name();
    const std::string stem = BatchFileStem(item.batch, item.num_batches);
    // Finished: its batch file (without HDF5: its folder of episode records, recorder.h).
    if (IsFile(dir / (stem + ".h5")) || fs::is_directory(dir / (stem + ".episodes"), ec)) {
      fs::remove_all(dir / (stem + ".parts"), ec);  // left by a kill after the merge
      ++report.items_skipped;
      done_episodes += item.episodes;
      log(LogLevel::kInfo, item.scene_name() + " batch " + std::to_string(item.batch) + "/" +
                               std::to_string(item.num_batches) + ": already done, skipped");
      continue;
    }
    todo.emplace_back(k, item);
  }

  // Progress per episode on stderr: a bar on a terminal, else a line at most once a second.
  ProgressStyle progress_style;
  progress_style.enabled = options.progress;
  progress_style.lines_when_not_tty = true;
  progress_style.unit = "episodes";
  ProgressBar bar(options.shard.count > 1 ? "datagen " + options.shard.Name() : "datagen",
                  static_cast<size_t>(total_episodes), progress_style);
  std::vector<AttemptRecord> attempts;
  int64_t successes = 0, kept_now = 0;
  std::map<size_t, int64_t> kept_messages;  // per item: kept episodes reported so far
  const auto t_work = Clock::now();
  auto progress_note = [&] {
    if (attempts.empty()) {
      return std::string(done_episodes >= total_episodes ? "done in an earlier run"
                         : done_episodes > 0             ? "resuming"
                                                         : "starting");
    }
    const double secs = Since(t_work);
    const double per_hour = secs > 0 ? kept_now / secs * 3600.0 : 0;
    const int64_t left = total_episodes - done_episodes;
    char buf[160];
    std::snprintf(buf, sizeof buf, "%zu attempt%s, success %.1f%%, %.0f ep/h, ETA %s",
                  attempts.size(), attempts.size() == 1 ? "" : "s",
                  attempts.empty() ? 0.0 : 100.0 * successes / attempts.size(), per_hour,
                  per_hour > 0 ? Duration(left / per_hour * 3600.0).c_str() : "?");
    return std::string(buf);
  };
  // Before the first scene loads: the bar at once, a plain line within seconds (none when
  // input stops the run sooner: its error line alone says why).
  bar.Start(static_cast<size_t>(done_episodes), progress_note());
  // Every message of every worker comes through here: the journal's only writer.
  std::set<std::string> said;  // warnings logged
  auto handle = [&](const Json& m) {
    if (m.contains("warning")) {
      // Workers on the same scene say the same: once is enough.
      if (said.insert(m["warning"].get<std::string>()).second) {
        log(LogLevel::kWarning, m["warning"].get<std::string>());
      }
      return;
    }
    const WorkItem& item = items.at(m["item"].get<size_t>());
    if (m.contains("attempt")) {
      AttemptRecord r = AttemptRecord::FromJson(m["attempt"], "worker message", "attempt");
      journal.Append(r);
      attempts.push_back(r);
      if (r.outcome == Outcome::kSuccess) ++successes;
      if (m.value("kept", false)) {
        ++kept_now;
        ++done_episodes;
        ++kept_messages[m["item"].get<size_t>()];
      }
      report.policy_steps += m.value("policy_steps", int64_t{0});
      report.physics_steps += m.value("physics_steps", int64_t{0});
      std::string line = item.scene_name() + " batch " + std::to_string(item.batch) + "/" +
                         std::to_string(item.num_batches) + " episode " +
                         std::to_string(r.episode) + ": " + std::string(OutcomeName(r.outcome));
      if (!r.message.empty()) line += " (" + r.message + ")";
      if (m.value("restored", false)) line += " [journal line restored from the episode file]";
      log(LogLevel::kDebug, line);
      bar.Update(static_cast<size_t>(done_episodes), progress_note());
      if (options.on_attempt) options.on_attempt(item, r);
      return;
    }
    if (m.contains("finished")) {
      const int64_t kept = m["kept"].get<int64_t>();
      report.episodes_kept += kept;
      // The item is done: count what it kept before this invocation and what it fell short by.
      done_episodes += item.episodes - kept_messages[m["item"].get<size_t>()];
      const std::string file = m["batch_file"].get<std::string>();
      if (kept < item.episodes) {
        log(LogLevel::kWarning, item.scene_name() + " batch " + std::to_string(item.batch) +
                                    ": kept " + std::to_string(kept) + " of " +
                                    std::to_string(item.episodes) + " episodes within " +
                                    std::to_string(item.max_attempts) + " attempts");
      }
      if (!file.empty()) {
        report.batch_files.push_back(file);
        log(LogLevel::kInfo, "wrote " + file + " (" + std::to_string(kept) + " episodes)");
      }
      bar.Update(static_cast<size_t>(done_episodes), progress_note());
    }
  };

  const int workers =
      std::max<int>(1, std::min<int64_t>(options.workers > 0 ? options.workers : config.num_workers,
                                         static_cast<int64_t>(todo.size())));
  if (workers <= 1) {
    ItemRunner runner(config, registry, *sampler, report.folder, earlier, options.gl_backend,
                      options.hdf5, handle);
    for (const auto& [index, item] : todo) runner.Run(index, item);
  } else {
    std::vector<Child> pool;
    const pid_t self = ::getpid();
    for (int w = 0; w < workers; ++w) {
      std::vector<std::pair<size_t, WorkItem>> mine;
      for (size_t k = w; k < todo.size(); k += workers) mine.push_back(todo[k]);
      if (options.before_fork) options.before_fork();
      std::optional<Child> child;
      try {
        child.emplace(Child::Start([&](int fd) {
          if (options.after_fork_child) options.after_fork_child();
          for (const Child& earlier_worker : pool) ::close(earlier_worker.fd());
          return WorkerMain(fd, self, config, registry, *sampler, report.folder, options.gl_backend,
                            options.hdf5, w, workers, earlier, mine);
        }));
      } catch (...) {
        if (options.after_fork_parent) options.after_fork_parent();
        throw;
      }
      if (options.after_fork_parent) options.after_fork_parent();
      pool.push_back(std::move(*child));
    }
    std::string first_error;
    ReadChildLines(pool, [&](size_t, std::string_view line) {
      const Json m = ParseJson(line, "worker message");
      if (m.contains("error")) {
        if (first_error.empty()) first_error = m["error"].get<std::string>();
        for (Child& c : pool) c.Kill();
        return;
      }
      handle(m);
    });
    for (size_t i = 0; i < pool.size(); ++i) {
      const ChildExit exit = pool[i].Wait();
      if (first_error.empty() && !exit.ok()) {
        first_error = "worker " + std::to_string(i) + " ended abnormally (" +
                      (exit.signaled ? "signal " : "exit ") + std::to_string(exit.number) + ")";
      }
    }
    if (!first_error.empty()) throw Error(first_error);
  }
  bar.Update(static_cast<size_t>(done_episodes), progress_note());
  bar.Finish();
  report.summary = Summarize(attempts);
  // The summary covers the whole run (this shard), earlier invocations included.
  const std::string shard = options.shard.Name();
  WriteFileAtomic(report.folder / (shard.empty() ? "summary.txt" : "summary." + shard + ".txt"),
                  "data hash " + hash + ", seed " + std::to_string(report.seed) +
                      (shard.empty() ? "" : ", " + shard) + "\n" +
                      FormatSummary(Summarize(ReadJournal(journal_file).records)));
  report.seconds = Since(t_start);
  return report;
}

}  // namespace mlspaces::datagen
