// The data engine from Python: configs handed over as YAML text, Python task samplers (the
// user's PickTaskSampler subclass) driving the C++ runner, and the Env's model and data shared
// with the user's `mujoco` module.
#include <Python.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include <mujoco/mujoco.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/string.h>

#include <yaml-cpp/yaml.h>
#include "bindings.h"
#include "convert.h"

#include "mlspaces/core/yaml_archive.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/journal.h"
#include "mlspaces/datagen/run.h"
#include "mlspaces/datagen/task_sampler.h"

namespace mlspaces::python {

namespace {

namespace dg = mlspaces::datagen;

/// A deleter that keeps a Python object alive and drops it (under the GIL) when the C++ side
/// is done with the pointer it owns.
struct PyOwner {
  PyObject* owner;
  template <class T>
  void operator()(T*) const noexcept {
    if (!Py_IsInitialized()) return;  // the interpreter is gone: nothing left to free
    PyGILState_STATE state = PyGILState_Ensure();
    Py_DECREF(owner);
    PyGILState_Release(state);
  }
};

std::optional<Pose> PoseField(nb::handle task_config, const char* name, const std::string& who) {
  nb::object value = task_config.attr(name);
  if (value.is_none()) return std::nullopt;
  std::array<double, 7> v{};
  try {
    nb::object seq = nb::module_::import_("numpy").attr("asarray")(value, "float64");
    auto array = nb::cast<nb::ndarray<double, nb::c_contig, nb::device::cpu>>(
        nb::module_::import_("numpy").attr("ascontiguousarray")(seq));
    if (array.ndim() != 1 || array.shape(0) != 7) throw std::runtime_error("shape");
    for (size_t i = 0; i < 7; ++i) v[i] = array.data()[i];
  } catch (const std::exception&) {
    throw Error(who + " set task_config." + name +
                " to something that is not 7 numbers (x, y, z, qw, qx, qy, qz)");
  }
  for (double x : v) {
    if (!std::isfinite(x))
      throw Error(who + " set task_config." + name + " with a non-finite value");
  }
  Pose pose;
  pose.pos = {v[0], v[1], v[2]};
  pose.quat = {v[3], v[4], v[5], v[6]};
  return pose;
}

/// A TaskSampler whose hooks are the methods of a Python PickTaskSampler (mlspaces.tasks).
/// The C++ runner calls it with the GIL released; every hook takes the GIL for its call.
class PythonTaskSampler : public dg::TaskSampler {
 public:
  PythonTaskSampler(dg::ExperimentConfig config, uint64_t seed, nb::object sampler)
      : TaskSampler(std::move(config), seed), sampler_(std::move(sampler)) {}

  ~PythonTaskSampler() override {
    if (!Py_IsInitialized()) {
      (void)sampler_.release();
      (void)env_.release();
      return;
    }
    nb::gil_scoped_acquire gil;
    env_.reset();
    sampler_.reset();
  }

  void PrepareEnv(dg::Env& env) override {
    nb::gil_scoped_acquire gil;
    nb::module_ mujoco = nb::module_::import_("mujoco");
    // The model: a copy the Python MjModel owns (MjModel._from_model_ptr takes ownership);
    // the data: a Python MjData made for it. The Env uses both from now on.
    mjModel* copy = mj_copyModel(nullptr, env.model());
    if (copy == nullptr) throw Error("cannot copy the compiled model for Python");
    nb::object py_model =
        mujoco.attr("MjModel").attr("_from_model_ptr")(reinterpret_cast<uintptr_t>(copy));
    nb::object py_data = mujoco.attr("MjData")(py_model);
    auto* data = reinterpret_cast<mjData*>(nb::cast<uintptr_t>(py_data.attr("_address")));
    env.ShareModelAndData(std::shared_ptr<const mjModel>(copy, PyOwner{py_model.inc_ref().ptr()}),
                          std::shared_ptr<mjData>(data, PyOwner{py_data.inc_ref().ptr()}));
    env_ = sampler_.attr("_attach_env")(
        py_model, py_data, JsonToPython(env.metadata()), nb::str(env.scene_key().c_str()),
        nb::str(env.robot().prefix.c_str()), nb::str(env.robot_base_body().c_str()));
  }

 protected:
  void SampleAndPlaceRobot(dg::Env& env, Rng& rng, dg::TaskDraft& draft) override {
    (void)env;
    nb::gil_scoped_acquire gil;
    const std::string who = Who();
    // Per-episode seeds for random, np.random and the sampler's generator, from the
    // episode's Rng: the same run seed and episode give the same draws, whatever the worker.
    const uint64_t seed = rng.NextU64();
    sampler_.attr("_begin_episode")(seed, nb::str(draft.pickup_obj_name->c_str()));
    try {
      sampler_.attr("_sample_and_place_robot")(env_);
    } catch (nb::python_error& e) {
      if (e.matches(nb::module_::import_("mlspaces.errors").attr("RobotPlacementError"))) {
        throw dg::TaskRejected(who + ": " + std::string(e.what()));
      }
      throw;
    }
    nb::object task_config = sampler_.attr("config").attr("task_config");
    nb::object name = task_config.attr("pickup_obj_name");
    if (!name.is_none()) draft.pickup_obj_name = nb::cast<std::string>(name);
    draft.robot_base_pose = PoseField(task_config, "robot_base_pose", who);
    draft.pickup_obj_start_pose = PoseField(task_config, "pickup_obj_start_pose", who);
    draft.pickup_obj_goal_pose = PoseField(task_config, "pickup_obj_goal_pose", who);
  }

 private:
  std::string Who() const {
    nb::object name = nb::steal(PyObject_GetAttrString(
        reinterpret_cast<PyObject*>(Py_TYPE(sampler_.ptr())), "__qualname__"));
    const char* text = name.is_valid() ? PyUnicode_AsUTF8(name.ptr()) : nullptr;
    if (text == nullptr) {
      PyErr_Clear();
      text = "PickTaskSampler";
    }
    return std::string(text) + "._sample_and_place_robot";
  }

  nb::object sampler_;
  nb::object env_;
};

/// A canonical config YAML node (DumpConfig's output) as Python objects: quoted scalars are
/// strings, plain ones null / bool / int / float / string as YAML 1.2's core schema reads them.
nb::object YamlToPython(const YAML::Node& node) {
  if (node.IsNull()) return nb::none();
  if (node.IsSequence()) {
    nb::list out;
    for (const YAML::Node& item : node) out.append(YamlToPython(item));
    return out;
  }
  if (node.IsMap()) {
    nb::dict out;
    for (const auto& kv : node) out[nb::str(kv.first.Scalar().c_str())] = YamlToPython(kv.second);
    return out;
  }
  const std::string& s = node.Scalar();
  if (node.Tag() == "!") return nb::str(s.c_str());
  if (s == "null" || s == "~") return nb::none();
  if (s == "true") return nb::bool_(true);
  if (s == "false") return nb::bool_(false);
  if (s == ".nan") return nb::float_(std::nan(""));
  if (s == ".inf") return nb::float_(HUGE_VAL);
  if (s == "-.inf") return nb::float_(-HUGE_VAL);
  char* end = nullptr;
  errno = 0;
  const long long i = std::strtoll(s.c_str(), &end, 10);
  if (!s.empty() && *end == 0 && errno == 0) return nb::int_(i);
  errno = 0;
  const unsigned long long u = std::strtoull(s.c_str(), &end, 10);
  if (!s.empty() && s[0] != '-' && *end == 0 && errno == 0) {
    return nb::steal(PyLong_FromUnsignedLongLong(u));
  }
  const double d = std::strtod(s.c_str(), &end);
  if (!s.empty() && *end == 0) return nb::float_(d);
  return nb::str(s.c_str());
}

/// RunOptions' fork hooks: the interpreter's state around each worker's fork.
thread_local PyGILState_STATE fork_gil_state;

dg::LogLevel LevelOf(const std::string& name) {
  for (size_t i = 0; i < dg::EnumNames<dg::LogLevel>::kNames.size(); ++i) {
    if (dg::EnumNames<dg::LogLevel>::kNames[i] == name) return static_cast<dg::LogLevel>(i);
  }
  throw UsageError("log level must be debug, info, warning or error, got '" + name + "'");
}

}  // namespace

void BindDatagen(nb::module_& m) {
  // The canonical YAML of the C++ defaults (PickBaseConfig), and of a config text after
  // loading and validation (what a run's config.yaml holds).
  m.def("default_config_yaml", [] { return dg::DumpConfig(dg::ExperimentConfig{}); });
  // The C++ defaults as a dict (the Python config classes take their defaults from it).
  m.def("default_config", [] {
    return YamlToPython(LoadYamlString(dg::DumpConfig(dg::ExperimentConfig{}), "defaults"));
  });
  // A config YAML text as a dict (canonical YAML, e.g. a run's config.yaml).
  m.def(
      "config_yaml_to_dict",
      [](const std::string& text) { return YamlToPython(LoadYamlString(text, "config")); },
      nb::arg("text"));
  m.def(
      "resolve_config_yaml",
      [](const std::string& text, const std::string& origin, const std::filesystem::path& base_dir,
         bool validate) {
        const dg::ConfigRegistry configs = dg::ConfigRegistry::WithBuiltins();
        dg::ExperimentConfig config = dg::ParseConfigText(text, origin, base_dir, configs);
        if (validate) dg::Validate(config, origin);
        return dg::DumpConfig(config);
      },
      nb::arg("text"), nb::arg("origin"), nb::arg("base_dir"), nb::arg("validate") = true);

  // run_datagen(config_text, origin, base_dir, sampler, ...) -> dict: runs a config (YAML
  // text of the C++ fields) with `sampler` (a Python PickTaskSampler, or None for the
  // config's built-in sampler). The GIL is released while the engine runs.
  m.def(
      "run_datagen",
      [](const std::string& text, const std::string& origin, const std::filesystem::path& base_dir,
         nb::object sampler, bool resume, const std::string& shard, int workers, bool progress,
         const std::string& log_level, const std::string& gl) {
        const dg::ConfigRegistry configs = dg::ConfigRegistry::WithBuiltins();
        dg::ExperimentConfig config = dg::ParseConfigText(text, origin, base_dir, configs);
        dg::Validate(config, origin);
        dg::TaskSamplerRegistry samplers = dg::TaskSamplerRegistry::WithBuiltins();
        if (!sampler.is_none()) {
          nb::object keep = sampler;
          samplers.Register(config.task_sampler_config.task_sampler_class,
                            [keep](const dg::ExperimentConfig& c, uint64_t seed) {
                              nb::gil_scoped_acquire gil;
                              return std::make_unique<PythonTaskSampler>(c, seed, keep);
                            });
        }
        dg::RunOptions options;
        options.resume = resume;
        options.workers = workers;
        options.progress = progress;
        if (!shard.empty()) options.shard = dg::ParseShard(shard);
        options.gl_backend = sim::ParseGlBackend(gl);
        const dg::LogLevel threshold = LevelOf(log_level);
        const bool tty = isatty(STDERR_FILENO) != 0;
        options.log = [threshold, tty](dg::LogLevel level, const std::string& line) {
          if (level < threshold) return;
          const char* tag = level >= dg::LogLevel::kWarning ? "warning: " : "";
          // On a terminal, clear the progress bar's line first.
          std::fprintf(stderr, "%smlspaces: %s%s\n", tty ? "\r\033[K" : "", tag, line.c_str());
        };
        // Ctrl-C: the interpreter's SIGINT handler only sets a flag while C++ runs; look at
        // it after every attempt and stop there (the journal is consistent: --resume goes on).
        options.on_attempt = [](const dg::WorkItem&, const dg::AttemptRecord&) {
          nb::gil_scoped_acquire gil;
          if (PyErr_CheckSignals() != 0) throw nb::python_error();
        };
        options.before_fork = [] {
          fork_gil_state = PyGILState_Ensure();
          PyOS_BeforeFork();
        };
        options.after_fork_parent = [] {
          PyOS_AfterFork_Parent();
          PyGILState_Release(fork_gil_state);
        };
        options.after_fork_child = [] {
          PyOS_AfterFork_Child();
          PyGILState_Release(fork_gil_state);
        };
        dg::RunReport report;
        {
          nb::gil_scoped_release no_gil;
          report = dg::RunDatagen(config, samplers, options);
        }
        nb::dict out;
        out["folder"] = ToPathlib(report.folder);
        out["seed"] = report.seed;
        out["episodes_kept"] = report.episodes_kept;
        out["items_skipped"] = report.items_skipped;
        out["policy_steps"] = report.policy_steps;
        out["physics_steps"] = report.physics_steps;
        out["seconds"] = report.seconds;
        out["attempts"] = report.summary.attempts;
        out["successes"] = report.summary.count(dg::Outcome::kSuccess);
        out["summary"] = dg::FormatSummary(report.summary);
        nb::list files;
        for (const auto& f : report.batch_files) files.append(ToPathlib(f));
        out["batch_files"] = files;
        return out;
      },
      nb::arg("text"), nb::arg("origin"), nb::arg("base_dir"), nb::arg("sampler"),
      nb::arg("resume") = false, nb::arg("shard") = "", nb::arg("workers") = 0,
      nb::arg("progress") = true, nb::arg("log_level") = "info", nb::arg("gl") = "osmesa");
}

}  // namespace mlspaces::python
