// PythonTaskSampler: a datagen TaskSampler whose hooks are the methods of a Python
// PickTaskSampler (python/mlspaces/tasks/pick_task_sampler.py) or of a subclass of one of the
// engine's samplers' Python classes (OpenTaskSampler, PickAndPlaceTaskSampler, ...), used by
// the runner (datagen.cc), the evaluation env (eval.cc) and the scene picture (render.cc).
#pragma once

#include <cstdint>
#include <memory>

#include "bindings.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/env.h"
#include "mlspaces/datagen/task_sampler.h"

namespace mlspaces::python {

/// The engine calls it with the GIL released; every hook takes the GIL for its call. A hook the
/// Python class does not override is the engine's own: that of the engine sampler the class
/// stands for (its nearest `_engine_sampler` class attribute, e.g. "OpenTaskSampler"; none:
/// block_pickup), which also adds the scene's auxiliary objects (receptacles).
/// PrepareEnv shares the Env's model and data with Python: the model becomes a
/// mujoco.MjModel (MjModel._from_model_ptr of a copy), the data a mujoco.MjData made for it,
/// and the Env uses both from then on (Env::ShareModelAndData), so what the Python hook writes
/// is what the engine simulates. The Python sampler's `env` is a CPUMujocoEnv over them.
class PythonTaskSampler : public datagen::TaskSampler {
 public:
  PythonTaskSampler(const datagen::ExperimentConfig& config, uint64_t seed, nb::object sampler);
  ~PythonTaskSampler() override;

  void PrepareEnv(datagen::Env& env) override;
  void AddAuxiliaryObjects(sim::Scene& scene) override;
  /// The Python CPUMujocoEnv of the last PrepareEnv (None before).
  nb::object python_env() const { return env_; }
  /// Visits the Python objects this holds (the sampler, its env), for the tp_traverse of the
  /// Python object that owns this, so the cyclic GC sees the references.
  int Traverse(visitproc visit, void* arg) const {
    Py_VISIT(sampler_.ptr());
    Py_VISIT(env_.ptr());
    return 0;
  }

 protected:
  void RandomizeScene(datagen::Env& env, Rng& rng) override;
  std::string SelectPickupObject(datagen::Env& env, Rng& rng) override;
  void SampleAndPlaceRobot(datagen::Env& env, Rng& rng, datagen::TaskDraft& draft) override;

 private:
  /// "<class qualname>.<hook>" for messages.
  std::string Who(const char* hook) const;
  /// Whether the Python class overrides PickTaskSampler's `hook` (else the engine's default
  /// runs without entering Python). Looked up once, at construction.
  static bool Overrides(nb::handle sampler, const char* hook);
  /// Calls `hook` with `args`, turning RobotPlacementError (and, for
  /// _on_candidate_selected, ValueError) into TaskRejected.
  nb::object CallHook(const char* hook, const nb::tuple& args, bool value_error_rejects = false);
  /// CallHook with `engine` (the engine's default of the hook, which the Python base class's
  /// method calls) set as the sampler's attribute `engine_attr` for the call's duration.
  nb::object CallHookWithEngine(const char* hook, const nb::tuple& args, const char* engine_attr,
                                nb::object engine);

  nb::object sampler_;
  nb::object env_;
  std::unique_ptr<datagen::TaskSampler> engine_;  // the engine sampler whose hooks are defaults
  bool overrides_init_scene_ = false;
  bool overrides_randomize_scene_ = false;
  bool overrides_on_candidate_selected_ = false;
  bool overrides_place_ = false;
};

}  // namespace mlspaces::python
