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

#include "convert.h"
#include "mlspaces/core/error.h"

namespace mlspaces::python {

namespace dg = mlspaces::datagen;

namespace {

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

}  // namespace

PythonTaskSampler::PythonTaskSampler(dg::ExperimentConfig config, uint64_t seed, nb::object sampler)
    : TaskSampler(std::move(config), seed),
      sampler_(std::move(sampler)),
      overrides_init_scene_(Overrides(sampler_, "init_scene")),
      overrides_randomize_scene_(Overrides(sampler_, "randomize_scene")),
      overrides_on_candidate_selected_(Overrides(sampler_, "_on_candidate_selected")) {}

PythonTaskSampler::~PythonTaskSampler() {
  if (!Py_IsInitialized()) {
    (void)sampler_.release();
    (void)env_.release();
    return;
  }
  nb::gil_scoped_acquire gil;
  env_.reset();
  sampler_.reset();
}

void PythonTaskSampler::PrepareEnv(dg::Env& env) {
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
  if (overrides_init_scene_) sampler_.attr("init_scene")(env_);
}

bool PythonTaskSampler::Overrides(nb::handle sampler, const char* hook) {
  nb::object base =
      nb::module_::import_("mlspaces.tasks.pick_task_sampler").attr("PickTaskSampler");
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
    if (e.matches(nb::module_::import_("mlspaces.errors").attr("RobotPlacementError")) ||
        (value_error_rejects && e.matches(PyExc_ValueError))) {
      throw dg::TaskRejected(Who(hook) + ": " + std::string(e.what()));
    }
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
      sampler_.attr("_engine_randomize") = nb::cpp_function([this, &env, &rng] {
        nb::gil_scoped_release no_gil;
        TaskSampler::RandomizeScene(env, rng);
      });
      nb::object robot_view = env_.attr("current_robot").attr("robot_view");
      try {
        CallHook("randomize_scene", nb::make_tuple(env_, robot_view));
      } catch (...) {
        sampler_.attr("_engine_randomize") = nb::none();
        throw;
      }
      sampler_.attr("_engine_randomize") = nb::none();
      return;
    }
  }
  TaskSampler::RandomizeScene(env, rng);
}

std::string PythonTaskSampler::SelectPickupObject(dg::Env& env, Rng& rng) {
  std::string name = TaskSampler::SelectPickupObject(env, rng);
  nb::gil_scoped_acquire gil;
  if (name.empty() || !overrides_on_candidate_selected_) return name;
  nb::object ok =
      CallHook("_on_candidate_selected", nb::make_tuple(env_, name, env.BodyId(name), -1), true);
  if (!nb::cast<bool>(ok))
    throw dg::TaskRejected(Who("_on_candidate_selected") + " declined " + name);
  return name;
}

void PythonTaskSampler::SampleAndPlaceRobot(dg::Env& env, Rng& rng, dg::TaskDraft& draft) {
  (void)env;
  nb::gil_scoped_acquire gil;
  const std::string who = Who("_sample_and_place_robot");
  // Per-episode seeds for random, np.random and the sampler's generator, from the
  // episode's Rng: the same run seed and episode give the same draws, whatever the worker.
  const uint64_t seed = rng.NextU64();
  sampler_.attr("_begin_episode")(seed, nb::str(draft.pickup_obj_name->c_str()));
  CallHook("_sample_and_place_robot", nb::make_tuple(env_));
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
