"""Running a config object on the engine, and the ``python -m mlspaces.datagen`` command."""

from __future__ import annotations

import argparse
import datetime
import importlib
import json
import os
import sys
from pathlib import Path
from typing import Any

from .. import _core
from .. import _validate as _v
from ..configs import to_native
from ..errors import MlspacesError
from .config_registry import get_config_class


def _sampler_for(config: Any):
    cls = config.task_sampler_config.task_sampler_class
    if cls is None or isinstance(cls, str):
        return None  # an engine sampler, by name
    from ..tasks.opening_task_samplers import engine_sampler_name, runs_in_python
    if engine_sampler_name(cls) is not None and not runs_in_python(cls):
        return None  # OpenTaskSampler: the engine's, by name (to_native names it)
    if not isinstance(cls, type):
        raise MlspacesError("task_sampler_config.task_sampler_class: expected a PickTaskSampler "
                            f"subclass or an engine sampler name, got {cls!r}")
    return cls(config)


def native_config_text(config: Any) -> str:
    """The engine config of a config object, as the text the engine loads (JSON)."""
    if not hasattr(config, "task_sampler_config") or not hasattr(config, "model_copy"):
        raise _v.type_error("native_config_text", "config", "a datagen config (a PickBaseConfig)",
                            config)
    return json.dumps(to_native(config))


def run_config(config: Any, *, output_dir: str | os.PathLike[str] | None = None,
               resume: bool = False, shard: str | None = None, workers: int | None = None,
               seed: int | None = None, progress: bool = True, log_level: str = "info",
               gl: str | None = None) -> dict[str, Any]:
    """Runs a datagen config object (a ``PickBaseConfig``) and returns the run's report
    (``folder``, ``seed``, ``episodes_kept``, ``attempts``, ``successes``, ``batch_files``,
    ``summary``, ...). The sampler is ``config.task_sampler_config.task_sampler_class(config)``
    when that is a Python class. Relative paths resolve against the current directory. A run
    stopped by Ctrl-C (``KeyboardInterrupt``) continues with ``resume=True``. ``gl`` is
    ``"osmesa"`` or ``"egl"`` (default: the ``MLSPACES_GL`` environment variable, else osmesa),
    as ``mlspaces datagen --gl``."""
    func = "run_config"
    if not hasattr(config, "task_sampler_config") or not hasattr(config, "model_copy"):
        raise _v.type_error(func, "config", "a datagen config (a PickBaseConfig)", config)
    output_dir = _v.optional_path(output_dir, "output_dir", func)
    resume = _v.boolean(resume, "resume", func)
    shard = _v.optional_string(shard, "shard", func)
    workers = _v.optional_integer(workers, "workers", func, minimum=1)
    seed = _v.optional_integer(seed, "seed", func, minimum=0, maximum=_v.UINT64_MAX)
    progress = _v.boolean(progress, "progress", func)
    log_level = _v.choice(log_level, "log_level", func, ("debug", "info", "warning", "error"))
    gl = _v.optional_string(gl, "gl", func)
    if output_dir is not None:
        config = config.model_copy()
        config.output_dir = Path(output_dir)
    if seed is not None:
        config = config.model_copy()
        config.seed = seed
    sampler = _sampler_for(config)
    name = type(config).__qualname__
    return _core.run_datagen(
        native_config_text(config), f"<config {name}>", os.getcwd(), sampler,
        resume=resume, shard=shard or "", workers=workers or 0, progress=progress,
        log_level=log_level, gl=gl or "")


def _load(spec: str) -> tuple[str, type]:
    module, _, name = spec.rpartition(":")
    if module:
        if "" not in sys.path and os.getcwd() not in sys.path:
            sys.path.insert(0, os.getcwd())
        importlib.import_module(module)
    return name, get_config_class(name)


def main(argv: list[str] | None = None) -> None:
    """``python -m mlspaces.datagen [MODULE:]CONFIG``: imports MODULE (which registers its
    libraries and config), instantiates CONFIG and runs it into
    ``output_dir/CONFIG/<YYYYmmdd_HHMMSS>`` (or --output), then prints the success count."""
    parser = argparse.ArgumentParser(
        prog="python -m mlspaces.datagen",
        description="Generate pick demonstrations from a Python datagen config.")
    parser.add_argument("config", help="[MODULE:]CONFIG, e.g. datagen:CustomAssetsDataGenConfig")
    parser.add_argument("--output", help="the run folder (default: output_dir/CONFIG/<time>)")
    parser.add_argument("--resume", action="store_true",
                        help="continue the run in --output (after a kill or Ctrl-C)")
    parser.add_argument("--workers", type=int, help="worker processes (default: num_workers)")
    parser.add_argument("--shard", help="run shard I/N of the work items")
    parser.add_argument("--seed", type=int, help="the run seed (default: the config's)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if args.resume and not args.output:
        parser.error("--resume needs --output (the folder of the run to continue)")
    try:
        name, cls = _load(args.config)
        config = cls()
        output = args.output
        if output is None:
            base = Path(config.output_dir or "experiment_output") / name
            if "/mnt/shared" not in str(base):
                base = base / datetime.datetime.now().strftime("%Y%m%d_%H%M%S")
            output = base
        report = run_config(config, output_dir=output, resume=args.resume, shard=args.shard,
                            workers=args.workers, seed=args.seed, progress=not args.quiet,
                            log_level="warning" if args.quiet else "info")
    except KeyboardInterrupt:
        sys.stderr.write("mlspaces: interrupted; continue with --resume --output <run folder>\n")
        raise SystemExit(130) from None
    except (MlspacesError, ImportError) as e:
        sys.stderr.write(f"mlspaces: {e}\n")
        raise SystemExit(1) from None
    print(f"run folder: {report['folder']}")
    print(report["summary"], end="")
    print(f"Success count: {report['successes']}, Total count: {report['attempts']}")


__all__ = ["main", "native_config_text", "run_config"]
