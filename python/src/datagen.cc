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
#include "python_sampler.h"

#include "mlspaces/core/strings.h"
#include "mlspaces/core/yaml_archive.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/journal.h"
#include "mlspaces/datagen/run.h"
#include "mlspaces/datagen/task_sampler.h"

namespace mlspaces::python {

namespace {

namespace dg = mlspaces::datagen;

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
         const nb::object& sampler, bool resume, const std::string& shard, int workers,
         bool progress, const std::string& log_level, const std::string& gl) {
        const dg::ConfigRegistry configs = dg::ConfigRegistry::WithBuiltins();
        dg::ExperimentConfig config = dg::ParseConfigText(text, origin, base_dir, configs);
        dg::Validate(config, origin);
        // A Python sampler is the run's only one (its class may stand for an engine sampler,
        // whose name the config then holds: PythonTaskSampler runs that one's default hooks).
        dg::TaskSamplerRegistry samplers =
            sampler.is_none() ? dg::TaskSamplerRegistry::WithBuiltins() : dg::TaskSamplerRegistry{};
        if (!sampler.is_none()) {
          samplers.Register(config.task_sampler_config.task_sampler_class,
                            [keep = sampler](const dg::ExperimentConfig& c, uint64_t seed) {
                              nb::gil_scoped_acquire gil;
                              return std::make_unique<PythonTaskSampler>(c, seed, keep);
                            });
        }
        dg::RunOptions options;
        options.resume = resume;
        options.workers = workers;
        options.progress = progress;
        if (!shard.empty()) options.shard = dg::ParseShard(shard);
        options.gl_backend = sim::ResolveGlBackend(gl, "gl");
        const dg::LogLevel threshold = LevelOf(log_level);
        const bool tty = isatty(STDERR_FILENO) != 0;
        options.log = [threshold, tty](dg::LogLevel level, const std::string& line) {
          if (level < threshold) return;
          const char* tag = level >= dg::LogLevel::kWarning ? "warning: " : "";
          // On a terminal, clear the progress bar's line first.
          std::fprintf(stderr, "%smlspaces: %s%s\n", tty ? "\r\033[K" : "", tag,
                       Printable(line).c_str());
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
      nb::arg("text"), nb::arg("origin"), nb::arg("base_dir"), nb::arg("sampler").none(),
      nb::arg("resume") = false, nb::arg("shard") = "", nb::arg("workers") = 0,
      nb::arg("progress") = true, nb::arg("log_level") = "info", nb::arg("gl") = "");
}

}  // namespace mlspaces::python
