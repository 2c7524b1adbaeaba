// The evaluation env (datagen::EvalEnv) for mlspaces.tasks.gym_env: reset, step, observations
// in the dataset's layout, camera frames.
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <nanobind/ndarray.h>
#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "bindings.h"
#include "convert.h"
#include "mlspaces/core/transform.h"
#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/eval_env.h"
#include "python_sampler.h"

namespace mlspaces::python {

namespace {

namespace dg = mlspaces::datagen;

/// A fresh float64 vector array.
nb::object Vector(std::vector<double> values) {
  const size_t n = values.size();
  return OwnedNumpy<double>(std::move(values), {n});
}

/// [x, y, z, qw, qx, qy, qz] as a fresh array.
nb::object PoseVector(const Pose& pose) {
  const Array7 a = ToArray7(pose);
  return Vector(std::vector<double>(a.begin(), a.end()));
}

class PyEvalEnv {
 public:
  PyEvalEnv(const std::string& text, const std::string& origin,
            const std::filesystem::path& base_dir, const nb::object& sampler, bool render,
            const std::string& gl) {
    const dg::ConfigRegistry configs = dg::ConfigRegistry::WithBuiltins();
    dg::ExperimentConfig config = dg::ParseConfigText(text, origin, base_dir, configs);
    dg::Validate(config, origin);
    std::unique_ptr<dg::TaskSampler> s;
    if (sampler.is_none()) {
      s = dg::TaskSamplerRegistry::WithBuiltins().Create(config, 0);
    } else {
      auto py = std::make_unique<PythonTaskSampler>(config, 0, sampler);
      python_ = py.get();
      s = std::move(py);
    }
    dg::EvalEnvOptions options;
    options.render = render;
    options.gl_backend = sim::ResolveGlBackend(gl, "gl");
    env_ = std::make_unique<dg::EvalEnv>(std::move(config), std::move(s), options);
  }

  void Reset(uint64_t seed, int64_t house, int64_t episode) {
    nb::gil_scoped_release no_gil;
    env().Reset(seed, house, episode);
  }

  nb::dict Step(nb::handle arm, double gripper) {
    const std::vector<double> q = DoublesFromPython(arm, env().robot().num_arm(), "action 'arm'");
    dg::EvalStep step;
    {
      nb::gil_scoped_release no_gil;
      step = env().Step(q, gripper);
    }
    nb::dict out;
    out["success"] = step.verdict.success;
    out["reward"] = step.verdict.reward;
    out["lift"] = step.verdict.lift;
    out["truncated"] = step.truncated;
    return out;
  }

  /// The observation in the dataset's layout (docs/dataset.md): agent joint state per move
  /// group and the extra poses (tcp_pose in the robot base frame).
  nb::dict Observation() const {
    const robots::RobotView& robot = env().robot();
    const mjData* d = env().env().data();
    nb::dict qpos, qvel;
    qpos["arm"] = Vector(robot.ArmQpos(d));
    qpos["gripper"] = Vector(robot.GripperQpos(d));
    qvel["arm"] = Vector(robot.ArmQvel(d));
    qvel["gripper"] = Vector(robot.GripperQvel(d));
    nb::dict agent;
    agent["qpos"] = qpos;
    agent["qvel"] = qvel;
    const Mat4 base = robot.BasePose(d);
    const dg::Task& task = env().task();
    nb::dict extra;
    extra["tcp_pose"] = PoseVector(ToPose(InverseRigid(base) * robot.TcpPose(d)));
    extra["robot_base_pose"] = PoseVector(env().env().GetRobotBasePose());
    extra["obj_start"] = PoseVector(task.pickup_obj_start_pose);
    extra["obj_end"] = PoseVector(task.pickup_obj_goal_pose);
    nb::dict out;
    out["agent"] = agent;
    out["extra"] = extra;
    return out;
  }

  nb::object Render(size_t index) {
    const size_t height = static_cast<size_t>(env().image_height());
    const size_t width = static_cast<size_t>(env().image_width());
    std::vector<uint8_t> rgb(height * width * 3);
    {
      nb::gil_scoped_release no_gil;
      env().Render(index, rgb.data());
    }
    return OwnedNumpy<uint8_t>(std::move(rgb), {height, width, 3});
  }

  /// One observation's camera frames, as the datagen recorder renders them: (frames, points)
  /// with frames a list per camera ((H, W, 3) uint8) and points the object_image_points,
  /// {key: {camera: {"points": (10, 2) float32, "num_points": (1,) int32}}}, or None when
  /// camera_config.object_image_points is off.
  nb::tuple Observe() {
    dg::EvalEnv& e = env();
    const size_t height = static_cast<size_t>(e.image_height());
    const size_t width = static_cast<size_t>(e.image_width());
    const std::vector<std::string> cameras = e.camera_names();
    std::vector<std::vector<uint8_t>> frames(cameras.size(),
                                             std::vector<uint8_t>(height * width * 3));
    std::vector<unsigned char*> rgb(frames.size());
    for (size_t i = 0; i < frames.size(); ++i) rgb[i] = frames[i].data();
    std::vector<std::vector<dg::ImagePoints>> points;
    {
      nb::gil_scoped_release no_gil;
      e.Observe(rgb, &points);
    }
    nb::list images;
    for (auto& f : frames) images.append(OwnedNumpy<uint8_t>(std::move(f), {height, width, 3}));
    const std::vector<dg::TrackedObject> objects = e.image_point_objects();
    if (objects.empty()) return nb::make_tuple(images, nb::none());
    nb::dict out;
    for (size_t k = 0; k < objects.size(); ++k) {
      nb::dict per_camera;
      for (size_t i = 0; i < cameras.size(); ++i) {
        if (points[i].empty()) continue;  // a follower camera
        const dg::ImagePoints& p = points[i][k];
        nb::dict entry;
        entry["points"] = OwnedNumpy<float>(std::vector<float>(p.points.begin(), p.points.end()),
                                            {dg::kMaxImagePoints, 2});
        entry["num_points"] = OwnedNumpy<int32_t>(std::vector<int32_t>{p.count}, {1});
        per_camera[cameras[i].c_str()] = entry;
      }
      out[objects[k].key.c_str()] = per_camera;
    }
    return nb::make_tuple(images, out);
  }

  nb::dict Task() const {
    const dg::Task& t = env().task();
    nb::dict out;
    out["pickup_obj_name"] = t.pickup_obj_name;
    out["robot_base_pose"] = PoseVector(t.robot_base_pose);
    out["pickup_obj_start_pose"] = PoseVector(t.pickup_obj_start_pose);
    out["pickup_obj_goal_pose"] = PoseVector(t.pickup_obj_goal_pose);
    out["episode"] = t.episode;
    out["seed"] = t.seed;
    out["success"] = env().verdict().success;
    out["steps"] = env().steps();
    return out;
  }

  /// The engine env. @throws Error after Close().
  dg::EvalEnv& env() {
    if (!env_) throw Error("the env is closed (GymEnv.close() was called)");
    return *env_;
  }
  const dg::EvalEnv& env() const { return const_cast<PyEvalEnv*>(this)->env(); }
  nb::object python_env() const { return python_ ? python_->python_env() : nb::none(); }
  /// Frees the engine env (renderer, scene, the Python sampler it holds); idempotent.
  void Close() {
    python_ = nullptr;
    env_.reset();
  }
  bool closed() const { return env_ == nullptr; }
  int Traverse(visitproc visit, void* arg) const {
    return python_ ? python_->Traverse(visit, arg) : 0;
  }

 private:
  std::unique_ptr<dg::EvalEnv> env_;
  PythonTaskSampler* python_ = nullptr;
};

// The env holds the Python sampler (and through it the sampler's env and config): tp_traverse
// shows those references to the cyclic GC, so a cycle through them (the sampler's class, its
// module, an object that holds the env) is collected, also at interpreter exit; tp_clear
// breaks it by closing the env.
int EvalEnvTraverse(PyObject* self, visitproc visit, void* arg) {
  Py_VISIT(Py_TYPE(self));
  if (!nb::inst_ready(self)) return 0;
  return nb::inst_ptr<PyEvalEnv>(self)->Traverse(visit, arg);
}

int EvalEnvClear(PyObject* self) {
  if (nb::inst_ready(self)) nb::inst_ptr<PyEvalEnv>(self)->Close();
  return 0;
}

PyType_Slot eval_env_slots[] = {{Py_tp_traverse, reinterpret_cast<void*>(EvalEnvTraverse)},
                                {Py_tp_clear, reinterpret_cast<void*>(EvalEnvClear)},
                                {0, nullptr}};

}  // namespace

void BindEval(nb::module_& m) {
  nb::class_<PyEvalEnv>(m, "EvalEnv", "The datagen scene driven one policy step at a time.",
                        nb::type_slots(eval_env_slots))
      .def(nb::init<const std::string&, const std::string&, const std::filesystem::path&,
                    nb::object, bool, const std::string&>(),
           nb::arg("text"), nb::arg("origin"), nb::arg("base_dir"), nb::arg("sampler").none(),
           nb::arg("render") = true, nb::arg("gl") = "")
      .def(
          "load_house",
          [](PyEvalEnv& e, int64_t house) {
            nb::gil_scoped_release no_gil;
            e.env().LoadHouse(house);
          },
          nb::arg("house"))
      .def("reset", &PyEvalEnv::Reset, nb::arg("seed"), nb::arg("house"), nb::arg("episode"))
      .def("step", &PyEvalEnv::Step, nb::arg("arm").none(), nb::arg("gripper"))
      .def("observation", &PyEvalEnv::Observation)
      .def("render", &PyEvalEnv::Render, nb::arg("camera"))
      .def("observe", &PyEvalEnv::Observe)
      .def("task", &PyEvalEnv::Task)
      .def_prop_ro("camera_names", [](PyEvalEnv& e) { return e.env().camera_names(); })
      // The cameras object_image_points are drawn in (datagen::TracksObjectsIn: not followers).
      .def_prop_ro("image_point_cameras",
                   [](PyEvalEnv& e) {
                     std::vector<std::string> out;
                     for (const std::string& c : e.env().camera_names()) {
                       if (dg::TracksObjectsIn(c)) out.push_back(c);
                     }
                     return out;
                   })
      // The current episode's object_image_points keys (empty when it records none).
      .def_prop_ro("image_point_keys",
                   [](PyEvalEnv& e) {
                     std::vector<std::string> keys;
                     for (const auto& o : e.env().image_point_objects()) keys.push_back(o.key);
                     return keys;
                   })
      .def_prop_ro("image_size",
                   [](PyEvalEnv& e) {
                     return nb::make_tuple(e.env().image_height(), e.env().image_width());
                   })
      .def_prop_ro("num_arm", [](PyEvalEnv& e) { return e.env().robot().num_arm(); })
      .def_prop_ro("num_gripper", [](PyEvalEnv& e) { return e.env().robot().num_gripper(); })
      .def_prop_ro("arm_limits",
                   [](PyEvalEnv& e) {
                     return nb::make_tuple(Vector(e.env().robot().arm_lower()),
                                           Vector(e.env().robot().arm_upper()));
                   })
      // The gripper actuator's ctrl when open and when closed (robot.yaml gripper.open_ctrl /
      // closed_ctrl).
      .def_prop_ro("gripper_ctrl",
                   [](PyEvalEnv& e) {
                     const robots::RobotSpec& r = e.env().env().robot();
                     return nb::make_tuple(r.gripper_open_ctrl, r.gripper_closed_ctrl);
                   })
      .def_prop_ro("started", [](PyEvalEnv& e) { return e.env().started(); })
      .def_prop_ro("task_horizon", [](PyEvalEnv& e) { return e.env().config().task_horizon; })
      .def_prop_ro("python_env", &PyEvalEnv::python_env)
      .def("close", &PyEvalEnv::Close)
      .def_prop_ro("closed", &PyEvalEnv::closed);
}

}  // namespace mlspaces::python
