#include "python_sampler.h"

#include <Python.h>

#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include <mujoco/mujoco.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "convert.h"
#include "mlspaces/core/error.h"

namespace mlspaces::python {

namespace dg = mlspaces::datagen;

namespace {

/// Whether Python objects may still be released: the interpreter runs, or is finalizing (its
/// module teardown, when Py_IsInitialized() is already false but objects are freed as usual:
/// an env left open at exit is destroyed then, and must release what it holds, else the
/// sampler's module and everything it reaches leak, which nanobind reports at exit).
bool PythonAlive() {
#if PY_VERSION_HEX >= 0x030D0000
  return Py_IsInitialized() || Py_IsFinalizing();
#else
  return Py_IsInitialized() || _Py_IsFinalizing();
#endif
}

/// A deleter that keeps a Python object alive and drops it (under the GIL) when the C++ side
/// is done with the pointer it owns.
struct PyOwner {
  PyObject* owner;
  template <class T>
  void operator()(T*) const noexcept {
    if (!PythonAlive()) return;  // the interpreter is gone: nothing left to free
    PyGILState_STATE state = PyGILState_Ensure();
    Py_DECREF(owner);
    PyGILState_Release(state);
  }
};

/// A 7-vector field of the task config set by a hook; nullopt when the hook left it None.
std::optional<Pose> PoseField(nb::handle task_config, const char* name, const std::string& who) {
  nb::object value = task_config.attr(name);
  if (value.is_none()) return std::nullopt;
  const std::vector<double> v = DoublesFromPython(
      value, 7, who + " set task_config." + std::string(name) + " (x, y, z, qw, qx, qy, qz)");
  Array7 a;
  std::copy(v.begin(), v.end(), a.begin());
  return FromArray7(a);
}

/// The engine sampler a Python sampler stands for: the nearest `_engine_sampler` of its class
/// (OpenTaskSampler, PickAndPlaceTaskSampler, ...), else block_pickup (PickTaskSampler).
std::string EngineSamplerOf(nb::handle sampler) {
  nb::object name = nb::getattr(sampler.type(), "_engine_sampler", nb::none());
  return name.is_none() ? std::string("block_pickup") : nb::cast<std::string>(name);
}

}  // namespace

PythonTaskSampler::PythonTaskSampler(const dg::ExperimentConfig& config, uint64_t seed,
                                     nb::object sampler)
    : TaskSampler(config, seed),
      sampler_(std::move(sampler)),
      engine_(
          dg::TaskSamplerRegistry::WithBuiltins().Create(EngineSamplerOf(sampler_), config, seed)),
      overrides_init_scene_(Overrides(sampler_, "init_scene")),
      overrides_randomize_scene_(Overrides(sampler_, "randomize_scene")),
      overrides_on_candidate_selected_(Overrides(sampler_, "_on_candidate_selected")),
      overrides_place_(Overrides(sampler_, "_sample_and_place_robot")) {}

PythonTaskSampler::~PythonTaskSampler() {
  if (!PythonAlive()) {
    (void)sampler_.release();
    (void)env_.release();
    return;
  }
  nb::gil_scoped_acquire gil;
  env_.reset();
  sampler_.reset();
}

void PythonTaskSampler::AddAuxiliaryObjects(sim::Scene& scene) {
  engine_->AddAuxiliaryObjects(scene);
}

void PythonTaskSampler::PrepareEnv(dg::Env& env) {
  engine_->PrepareEnv(env);
  nb::gil_scoped_acquire gil;
  nb::module_ mujoco = nb::module_::import_("mujoco");
  // The model: a copy the Python MjModel owns (MjModel._from_model_ptr takes ownership);
  // the data: a Python MjData made for it. The Env uses both from now on.
  mjModel* copy = mj_copyModel(nullptr, env.model());
  if (copy == nullptr) throw Error("cannot copy the compiled model for Python");
  nb::object py_model =
      mujoco.attr("MjModel").attr("_from_model_ptr")(reinterpret_cast<uintptr_t>(copy));
  nb::object py_data = mujoco.attr("MjData")(py_model);
  // The mujoco module hands out its MjData's address as an integer.
  auto* data = reinterpret_cast<mjData*>(  // NOLINT(performance-no-int-to-ptr)
      nb::cast<uintptr_t>(py_data.attr("_address")));
  env.ShareModelAndData(std::shared_ptr<const mjModel>(copy, PyOwner{py_model.inc_ref().ptr()}),
                        std::shared_ptr<mjData>(data, PyOwner{py_data.inc_ref().ptr()}));
  env_ = sampler_.attr("_attach_env")(
      py_model, py_data, JsonToPython(env.metadata()), nb::str(env.scene_key().c_str()),
      nb::str(env.robot().prefix.c_str()), nb::str(env.robot_base_body().c_str()),
      nb::str(env.robot().name.c_str()));
  if (overrides_init_scene_) sampler_.attr("init_scene")(env_);
}

bool PythonTaskSampler::Overrides(nb::handle sampler, const char* hook) {
  // The base: the nearest class of the MRO that names an engine sampler (OpenTaskSampler,
  // ...), else PickTaskSampler.
  nb::object base =
      nb::module_::import_("mlspaces.tasks.pick_task_sampler").attr("PickTaskSampler");
  for (nb::handle c : sampler.type().attr("__mro__")) {
    if (nb::cast<bool>(c.attr("__dict__").attr("__contains__")("_engine_sampler"))) {
      base = nb::borrow(c);
      break;
    }
  }
  nb::object mine = nb::getattr(sampler.type(), hook, nb::none());
  return !mine.is(nb::getattr(base, hook, nb::none()));
}

nb::object PythonTaskSampler::CallHook(const char* hook, const nb::tuple& args,
                                       bool value_error_rejects) {
  try {
    nb::object fn = sampler_.attr(hook);
    PyObject* result = PyObject_CallObject(fn.ptr(), args.ptr());
    if (result == nullptr) throw nb::python_error();
    return nb::steal(result);
  } catch (nb::python_error& e) {
    // A ValueError rejects the candidate (the original's rule), except mlspaces' UsageError:
    // an mlspaces function called with a bad argument is a bug in the hook, and a bug that
    // rejected every candidate would end the run as a quiet "0 episodes".
    nb::module_ errors = nb::module_::import_("mlspaces.errors");
    if (e.matches(errors.attr("RobotPlacementError")) ||
        (value_error_rejects && e.matches(PyExc_ValueError) &&
         !e.matches(errors.attr("UsageError")))) {
      throw dg::TaskRejected(Who(hook) + ": " + std::string(e.what()));
    }
    throw;
  }
}

nb::object PythonTaskSampler::CallHookWithEngine(const char* hook, const nb::tuple& args,
                                                 const char* engine_attr, nb::object engine) {
  sampler_.attr(engine_attr) = std::move(engine);
  try {
    nb::object result = CallHook(hook, args);
    sampler_.attr(engine_attr) = nb::none();
    return result;
  } catch (...) {
    sampler_.attr(engine_attr) = nb::none();
    throw;
  }
}

void PythonTaskSampler::RandomizeScene(dg::Env& env, Rng& rng) {
  {
    nb::gil_scoped_acquire gil;
    if (overrides_randomize_scene_) {
      // The Python RNGs are seeded for this hook too; PickTaskSampler.randomize_scene (what a
      // subclass's super() call reaches) runs the engine's default through _engine_randomize.
      sampler_.attr("_begin_episode")(rng.NextU64(), nb::none());
      nb::object robot_view = env_.attr("current_robot").attr("robot_view");
      CallHookWithEngine("randomize_scene", nb::make_tuple(env_, robot_view), "_engine_randomize",
                         nb::cpp_function([this, &env, &rng] {
                           nb::gil_scoped_release no_gil;
                           RandomizeSceneOf(*engine_, env, rng);
                         }));
      return;
    }
  }
  RandomizeSceneOf(*engine_, env, rng);
}

std::string PythonTaskSampler::SelectPickupObject(dg::Env& env, Rng& rng) {
  std::string name = SelectPickupObjectOf(*engine_, env, rng);
  nb::gil_scoped_acquire gil;
  if (name.empty() || !overrides_on_candidate_selected_) return name;
  nb::object ok =
      CallHook("_on_candidate_selected", nb::make_tuple(env_, name, env.BodyId(name), -1), true);
  if (!nb::cast<bool>(ok))
    throw dg::TaskRejected(Who("_on_candidate_selected") + " declined " + name);
  return name;
}

void PythonTaskSampler::SampleAndPlaceRobot(dg::Env& env, Rng& rng, dg::TaskDraft& draft) {
  // Not overridden: the engine sampler's placement, without entering Python (the same
  // draws as that sampler by name, e.g. block_pickup).
  if (!overrides_place_) {
    SampleAndPlaceRobotOf(*engine_, env, rng, draft);
    return;
  }
  nb::gil_scoped_acquire gil;
  const std::string who = Who("_sample_and_place_robot");
  // Per-episode seeds for random, np.random and the sampler's generator, from the
  // episode's Rng: the same run seed and episode give the same draws, whatever the worker.
  const uint64_t seed = rng.NextU64();
  sampler_.attr("_begin_episode")(seed, nb::str(draft.pickup_obj_name->c_str()));
  // PickTaskSampler._sample_and_place_robot (a super() call) runs the engine's placement
  // through _engine_place, which returns the three poses it set.
  CallHookWithEngine("_sample_and_place_robot", nb::make_tuple(env_), "_engine_place",
                     nb::cpp_function([this, &env, &rng, &draft] {
                       {
                         nb::gil_scoped_release no_gil;
                         SampleAndPlaceRobotOf(*engine_, env, rng, draft);
                       }
                       auto seven = [](const Pose& p) {
                         const Array7 a = ToArray7(p);
                         return std::vector<double>(a.begin(), a.end());
                       };
                       return nb::make_tuple(seven(*draft.robot_base_pose),
                                             seven(*draft.pickup_obj_start_pose),
                                             seven(*draft.pickup_obj_goal_pose));
                     }));
  nb::object task_config = sampler_.attr("config").attr("task_config");
  nb::object name = task_config.attr("pickup_obj_name");
  if (!name.is_none()) draft.pickup_obj_name = nb::cast<std::string>(name);
  draft.robot_base_pose = PoseField(task_config, "robot_base_pose", who);
  draft.pickup_obj_start_pose = PoseField(task_config, "pickup_obj_start_pose", who);
  draft.pickup_obj_goal_pose = PoseField(task_config, "pickup_obj_goal_pose", who);
}

std::string PythonTaskSampler::Who(const char* hook) const {
  nb::object name = nb::steal(
      PyObject_GetAttrString(reinterpret_cast<PyObject*>(Py_TYPE(sampler_.ptr())), "__qualname__"));
  const char* text = name.is_valid() ? PyUnicode_AsUTF8(name.ptr()) : nullptr;
  if (text == nullptr) {
    PyErr_Clear();
    text = "PickTaskSampler";
  }
  return std::string(text) + "." + hook;
}

}  // namespace mlspaces::python
