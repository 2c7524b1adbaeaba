"""The evaluation env (``molmo_spaces.tasks.gym_env``): a ``gymnasium.Env`` made from a datagen
config, registered as ``MolmoSpaces/<ConfigName>-v<version>`` (needs the ``[gym]`` extra).

One env is one scene with its robot; a step is one policy step of the datagen rollout (action
noise, controller, ``policy_dt / sim_dt`` physics steps). Spaces are declared (MolmoSpaces'
env declares none):

- action: ``{"arm": Box(n_arm) joint targets in radians (within the joint limits), "gripper":
  Box(1) the gripper actuator's ctrl, between robot.yaml's ``gripper.open_ctrl`` and
  ``closed_ctrl`` (0 open .. 255 closed for franka_droid and xarm7)}`` -- the dataset's
  ``commanded_action`` layout; any robot (``robot_config.name``, docs/robots.md);
- observation: the dataset's layout, ``{"agent": {"qpos": {"arm", "gripper"}, "qvel": {...}},
  "extra": {"tcp_pose", "robot_base_pose", "obj_start", "obj_end", "object_image_points"},
  "sensor_data": {<camera>: Box(H, W, 3) uint8}}`` (one dict, not MolmoSpaces' one-element
  list). ``object_image_points`` (with cameras and ``camera_config.object_image_points``) is
  ``{key: {camera: {"points": NanPaddedBox(10, 2) float32, "num_points": Box(1) int32}}}``,
  drawn as the datagen recorder draws them; its keys are the first task's (docs/python.md).

``reset(seed=s)`` samples episode 0 of a datagen run with seed ``s``; later resets without a
seed take the run's next episodes, so a seeded env is deterministic, and a recorded episode's
actions replayed after ``reset(seed=run_seed, options={"episode": k})`` reproduce it. ``info``
holds ``success``, ``lift``, ``task`` (names and poses of the sampled task) and ``episode``.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np

try:
    import gymnasium as gym
    from gymnasium import spaces
except ImportError as e:  # pragma: no cover - depends on the install
    raise ImportError("mlspaces.tasks.gym_env needs gymnasium: pip install 'mlspaces[gym]'") from e

from .. import _core
from .. import _validate as _v
from ..configs import to_native
from ..datagen.config_registry import get_config_class, list_available_configs
from ..errors import MlspacesError

_NAMESPACE = "MolmoSpaces"
_OPTIONS = {"house_index", "episode", "force_advance_scene"}


def env_id_for_config(config_name: str, version: int = 0) -> str:
    """``"MolmoSpaces/<config_name>-v<version>"``."""
    config_name = _v.string(config_name, "config_name", "env_id_for_config", empty=False)
    version = _v.integer(version, "version", "env_id_for_config", minimum=0)
    return f"{_NAMESPACE}/{config_name}-v{version}"


def register_configs(version: int = 0) -> list[str]:
    """Registers every registered config with gymnasium (idempotent); returns the new ids."""
    version = _v.integer(version, "version", "register_configs", minimum=0)
    added = []
    for name in list_available_configs():
        env_id = env_id_for_config(name, version)
        if env_id in gym.registry:
            continue
        gym.register(id=env_id, entry_point="mlspaces.tasks.gym_env:GymEnv",
                     kwargs={"config_name": name}, max_episode_steps=None,
                     disable_env_checker=True, order_enforce=False)
        added.append(env_id)
    return added


def _options(options: Any, func: str) -> dict[str, Any]:
    """The sampling options (``house_index``, ``episode``: ints >= 0; ``force_advance_scene``:
    a bool), checked."""
    for key, value in options.items():
        if key not in _OPTIONS:
            raise _v.value_error(func, "options", f"unknown option {key!r}; known: "
                                                  f"{', '.join(sorted(_OPTIONS))}")
        if key == "force_advance_scene":
            _v.boolean(value, key, func)
        else:
            _v.integer(value, key, func, minimum=0)
    return dict(options)


def _box(shape: tuple[int, ...], low: float = -np.inf, high: float = np.inf) -> spaces.Box:
    return spaces.Box(low=low, high=high, shape=shape, dtype=np.float64)


class NanPaddedBox(spaces.Box):
    """A ``Box`` whose values may also be NaN: ``object_image_points``' ``points`` (x, y in
    [0, 1]), NaN past ``num_points``, as the dataset and MolmoSpaces' sensor store them."""

    def contains(self, x: Any) -> bool:
        if not isinstance(x, np.ndarray):
            try:
                x = np.asarray(x, dtype=self.dtype)
            except (ValueError, TypeError):
                return False
        if not np.can_cast(x.dtype, self.dtype) or x.shape != self.shape:
            return False
        known = ~np.isnan(x)
        return bool(np.all(x[known] >= self.low[known]) and np.all(x[known] <= self.high[known]))


def _points_space(keys: list[str], cameras: list[str]) -> spaces.Dict:
    """``{key: {camera: {"points": (10, 2) float32, "num_points": (1,) int32}}}`` for the
    cameras that track objects."""
    per_camera = {c: spaces.Dict({
        "points": NanPaddedBox(0.0, 1.0, shape=(10, 2), dtype=np.float32),
        "num_points": spaces.Box(0, 10, shape=(1,), dtype=np.int32),
    }) for c in cameras}
    return spaces.Dict({k: spaces.Dict(per_camera) for k in keys})


class GymEnv(gym.Env):
    """A datagen config as a gymnasium env (see the module docstring)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 15}

    def __init__(self, config_name: str | None = None, exp_config: Any = None, *,
                 config_overrides: dict[str, Any] | None = None, task_sampler: Any = None,
                 render_mode: str | None = None, render_camera: str | None = None,
                 **sample_task_kwargs: Any) -> None:
        func = "GymEnv"
        if (config_name is None) == (exp_config is None):
            raise MlspacesError("GymEnv: give exactly one of config_name and exp_config")
        if config_name is not None:
            config_name = _v.string(config_name, "config_name", func, empty=False)
        elif not hasattr(exp_config, "task_sampler_config") or \
                not hasattr(exp_config, "camera_config"):
            raise _v.type_error(func, "exp_config", "a datagen config (a PickBaseConfig)",
                                exp_config)
        config_overrides = _v.optional_mapping(config_overrides, "config_overrides", func)
        render_camera = _v.optional_string(render_camera, "render_camera", func)
        if task_sampler is not None:
            raise MlspacesError("GymEnv: task_sampler is not supported; the env makes its "
                                "sampler from the config's task_sampler_class")
        unknown = set(sample_task_kwargs) - _OPTIONS
        if unknown:
            raise MlspacesError(f"GymEnv: unknown keyword arguments {sorted(unknown)}")
        _options(sample_task_kwargs, func)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise _v.value_error(func, "render_mode",
                                 f"expected None or 'rgb_array', got {_v.describe(render_mode)}")
        cfg = get_config_class(config_name)() if exp_config is None else exp_config
        for key, value in (config_overrides or {}).items():
            if not hasattr(cfg, key):
                raise MlspacesError(f"GymEnv: config_overrides key {key!r} is not a field of "
                                    f"{type(cfg).__qualname__}")
            setattr(cfg, key, value)
        self.config = cfg
        self._config_name = config_name
        self.render_mode = render_mode
        self.render_camera = render_camera
        self._defaults = dict(sample_task_kwargs)
        cls = cfg.task_sampler_config.task_sampler_class
        from .opening_task_samplers import runs_in_python
        # OpenTaskSampler and the like: the engine's, by name, unless a subclass overrides a hook.
        self.task_sampler = cls(cfg) if runs_in_python(cls) else None
        self._env = _core.EvalEnv(json.dumps(to_native(cfg)), f"<config {type(cfg).__qualname__}>",
                                  os.getcwd(), self.task_sampler,
                                  render=True)
        w, h = (int(x) for x in cfg.camera_config.img_resolution)
        lower, upper = self._arm_limits()
        # The engine's cameras: the config's, or the robot's own (RobotCameraSystem).
        self._cameras = list(self._env.camera_names)
        if render_camera is not None and render_camera not in self._cameras:
            raise MlspacesError(f"GymEnv: render_camera {render_camera!r} is not one of "
                                f"{self._cameras}")
        n_arm, n_grip = self._env.num_arm, self._env.num_gripper
        grip_low, grip_high = sorted(float(c) for c in self._env.gripper_ctrl)
        self.action_space = spaces.Dict({
            "arm": spaces.Box(low=lower, high=upper, shape=(n_arm,), dtype=np.float64),
            "gripper": spaces.Box(low=grip_low, high=grip_high, shape=(1,), dtype=np.float64),
        })
        extra = {k: _box((7,)) for k in ("tcp_pose", "robot_base_pose", "obj_start", "obj_end")}
        self._point_keys: list[str] = []
        if self._cameras and cfg.camera_config.object_image_points:
            self._point_keys = self._probe_point_keys()
            extra["object_image_points"] = _points_space(self._point_keys,
                                                         self._env.image_point_cameras)
        self.observation_space = spaces.Dict({
            "agent": spaces.Dict({
                "qpos": spaces.Dict({"arm": _box((n_arm,)), "gripper": _box((n_grip,))}),
                "qvel": spaces.Dict({"arm": _box((n_arm,)), "gripper": _box((n_grip,))}),
            }),
            "extra": spaces.Dict(extra),
            "sensor_data": spaces.Dict({
                c: spaces.Box(0, 255, shape=(h, w, 3), dtype=np.uint8) for c in self._cameras}),
        })
        self._warned: set[tuple[str, ...]] = set()
        self._run_seed: int | None = None
        self._episode = -1
        self.task: dict[str, Any] | None = None

    def _probe_point_keys(self) -> list[str]:
        """The object_image_points keys of the space: those of the task the env samples first
        (seed 0, episode 0), all but ``gripper`` and ``pickup_obj`` task-dependent
        (``place_receptacle``, the ``added_<k>`` of config.added_objects)."""
        self._env.reset(0, int(self._defaults.get("house_index", 0)), 0)
        return list(self._env.image_point_keys)

    def _arm_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """The arm's joint ranges, from the model of the first scene (loaded here)."""
        self._env.load_house(int(self._defaults.get("house_index", 0)))
        return self._env.arm_limits

    # -- gymnasium API --------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        func = "GymEnv.reset"
        if seed is not None:
            seed = _v.integer(seed, "seed", func, minimum=0, maximum=_v.UINT64_MAX)
        options = _v.optional_mapping(options, "options", func)
        options = _options({**self._defaults, **(options or {})}, func)
        self._open(func)
        super().reset(seed=seed)
        if seed is not None:
            self._run_seed = int(seed)
            self._episode = -1
        elif self._run_seed is None:
            self._run_seed = int(self.np_random.integers(0, 2**63))
        self._episode = int(options.get("episode", self._episode + 1))
        house = int(options.get("house_index", 0))
        self._env.reset(self._run_seed, house, self._episode)
        self.task = self._env.task()
        return self._observation(), self._info()

    def step(self, action: dict[str, Any]):
        func = "GymEnv.step"
        self._open(func)
        if self.task is None:
            raise RuntimeError("step before reset")
        if not isinstance(action, Mapping) or "arm" not in action or "gripper" not in action:
            raise _v.type_error(func, "action", f"a dict with 'arm' ({self._env.num_arm} joint "
                                "targets) and 'gripper' (the gripper ctrl)", action)
        arm = _v.array(action["arm"], "action['arm']", func, (self._env.num_arm,))
        gripper = _v.array(action["gripper"], "action['gripper']", func).reshape(-1)
        if gripper.shape != (1,):
            raise _v.value_error(func, "action['gripper']",
                                 f"expected 1 value, got {gripper.shape[0]}")
        result = self._env.step(arm, float(gripper[0]))
        terminated = bool(result["success"] and self.config.end_on_success)
        info = self._info()
        info["lift"] = result["lift"]
        return (self._observation(), float(result["reward"]), terminated,
                bool(result["truncated"]), info)

    def render(self) -> np.ndarray:
        """The frame of ``render_camera`` (default: the first camera), ``(H, W, 3)`` uint8.
        Without a render mode there are no frames: a ``ValueError`` says how to ask for them
        (gymnasium's own envs return ``None`` with a warning, easy to miss)."""
        if self.render_mode is None:
            env_id = (self.spec.id if self.spec is not None else
                      env_id_for_config(self._config_name) if self._config_name else None)
            make = (f'gymnasium.make("{env_id}", render_mode="rgb_array")' if env_id else
                    'gymnasium.make(..., render_mode="rgb_array")')
            raise _v.value_error("GymEnv.render", "render_mode",
                                 'the env was made without a render mode, so it renders no '
                                 'frames: pass render_mode="rgb_array" to GymEnv(...) or '
                                 f'{make} (camera frames are also in every observation, '
                                 'obs["sensor_data"])')
        self._open("GymEnv.render")
        if self.task is None:
            raise RuntimeError("render before reset")
        if not self._cameras:
            raise MlspacesError("render: the config has no cameras")
        camera = self.render_camera or self._cameras[0]
        return self._env.render(self._cameras.index(camera))

    def close(self) -> None:
        """Frees the scene, its renderer and the sampler's env (idempotent); the env cannot
        be used after."""
        self.task = None
        env = getattr(self, "_env", None)  # None when __init__ failed
        if env is not None:
            env.close()

    def _open(self, func: str) -> None:
        if self._env.closed:
            raise RuntimeError(f"{func}: the env is closed (close() was called)")

    # -- helpers --------------------------------------------------------------------------

    def _observation(self) -> dict[str, Any]:
        obs = self._env.observation()
        frames, points = self._env.observe() if self._cameras else ([], None)
        obs["sensor_data"] = dict(zip(self._cameras, frames))
        if points is not None:
            obs["extra"]["object_image_points"] = self._fit_points(points)
        return obs

    def _fit_points(self, points: dict[str, Any]) -> dict[str, Any]:
        """The episode's points on the space's keys: a key this task lacks (an added object
        that is now the pickup object) has no points; one the space lacks is left out, with a
        warning (gymnasium spaces have fixed keys)."""
        extra = sorted(set(points) - set(self._point_keys))
        if extra and tuple(extra) not in self._warned:
            self._warned.add(tuple(extra))
            warnings.warn(f"object_image_points of {extra} are left out of the observation: "
                          f"the observation space has {self._point_keys} (from the first task)",
                          stacklevel=3)
        cameras = self._env.image_point_cameras
        out = {}
        for key in self._point_keys:
            if key in points:
                out[key] = points[key]
            else:
                out[key] = {c: {"points": np.full((10, 2), np.nan, dtype=np.float32),
                                "num_points": np.zeros(1, dtype=np.int32)} for c in cameras}
        return out

    def _info(self) -> dict[str, Any]:
        task = self._env.task()
        return {"success": bool(task["success"]), "task": task, "episode": self._episode,
                "run_seed": self._run_seed}


__all__ = ["GymEnv", "NanPaddedBox", "env_id_for_config", "register_configs"]
