"""Datagen comparison of bench/python_api_bench.py, physics only: the physics-only variants of
the tutorial's config (BenchPhysicsOnly, written into a copy of examples/custom_assets by
make_project), the in-process Python vs built-in sampler worker (a), and the whole-process
`python -m mlspaces.datagen` vs CLI comparison (b). Nothing here imports mlspaces at import
time."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
EXAMPLE_DIR = REPO / "examples" / "custom_assets"


# ------------------------------------------------------------------------------------------
# Datagen.

BENCH_MODULE = '''\
"""Physics-only variants of the tutorial's config (written by bench/python_api_bench.py).
Importing datagen runs the tutorial's module as written: it registers the libraries and
CustomAssetsDataGenConfig, and defines BlockPickupTaskSampler."""
import os

from datagen import FrankaPickDroidDataGenConfig
from mlspaces.data_generation.config_registry import register_config

EPISODES = int(os.environ.get("BENCH_EPISODES", "20"))


@register_config("BenchPhysicsOnly")
class BenchPhysicsOnly(FrankaPickDroidDataGenConfig):
    """The tutorial's config (Python BlockPickupTaskSampler), no cameras, no rendering."""

    def model_post_init(self, ctx) -> None:
        super().model_post_init(ctx)
        self.task_config.enable_rendering = False
        self.camera_config.cameras = []
        self.task_sampler_config.samples_per_house = EPISODES


@register_config("BenchPhysicsOnlyBuiltin")
class BenchPhysicsOnlyBuiltin(BenchPhysicsOnly):
    """The same with the engine's built-in block_pickup sampler (the YAML's)."""

    def model_post_init(self, ctx) -> None:
        super().model_post_init(ctx)
        self.task_sampler_config.task_sampler_class = "block_pickup"
'''


def make_project(root: Path) -> Path:
    proj = root / "custom_assets"
    shutil.copytree(EXAMPLE_DIR, proj, ignore=shutil.ignore_patterns(
        "experiment_output", "__pycache__", "*.cc", "*.h"))
    (proj / "benchmod.py").write_text(BENCH_MODULE)
    return proj


def _stage(summary: str, name: str) -> float | None:
    m = re.search(rf"^{name}\s+([0-9.eE+-]+)\s+(\d+)\s+([0-9.eE+-]+)\s*$", summary, re.M)
    return float(m.group(1)) if m else None


def _data_hash(folder: Path) -> str | None:
    try:
        first = (folder / "summary.txt").read_text().splitlines()[0]
    except (OSError, IndexError):
        return None
    m = re.search(r"data hash (\w+)", first)
    return m.group(1) if m else None


def _journal(folder: Path) -> dict:
    """Per-attempt engine timings of a run folder's journal: mean seconds per attempt of each
    stage and of their sum (the episode, without process startup and file writing)."""
    rows = [json.loads(line) for line in (folder / "journal.jsonl").read_text().splitlines()
            if line.strip()]
    stages: dict[str, float] = {}
    for r in rows:
        for k, v in r.get("timings", {}).items():
            stages[k] = stages.get(k, 0.0) + v
    n = max(1, len(rows))
    out = {k: v / n for k, v in stages.items()}
    out["episode"] = sum(stages.values()) / n
    return out


CLI_PHYSICS_ONLY = ["--set", "task_config.enable_rendering=false",
                    "--set", "camera_config.cameras=[]"]


def sampler_worker(project: Path, episodes: int, rounds: int, seed: int, cli: str) -> dict:
    """(a): run_config with the Python sampler vs the built-in one, alternating, in-process.
    When run_config cannot run a built-in sampler (a binding bug), the built-in side runs
    through the CLI on the equivalent YAML (noted in the result)."""
    os.chdir(project)
    sys.path.insert(0, str(project))
    os.environ["BENCH_EPISODES"] = str(episodes)
    import benchmod
    from mlspaces.datagen import run_config

    configs = {"python": benchmod.BenchPhysicsOnly(), "builtin": benchmod.BenchPhysicsOnlyBuiltin()}
    runs: dict = {"python": [], "builtin": [], "builtin_via": "run_config", "error": None}
    scratch = project / "runs_a"

    def one(name: str, tag: str) -> dict:
        out = scratch / f"{name}_{tag}"
        if name == "python" or runs["builtin_via"] == "run_config":
            t = time.perf_counter()
            try:
                rep = run_config(configs[name], output_dir=out, seed=seed, progress=False,
                                 log_level="warning")
            except TypeError as e:
                if name == "python":
                    raise
                runs["builtin_via"] = "cli"
                text = str(e)
                runs["error"] = f"{type(e).__name__}: {text.splitlines()[0].split('. ')[0]}" + (
                    " (invoked with sampler=None)" if "NoneType" in text else "")
                return one(name, tag)
            wall = time.perf_counter() - t
            row = {"wall_s": wall, "engine_s": rep.get("seconds"), "kept": rep.get("episodes_kept"),
                   "attempts": rep.get("attempts"), "physics_steps": rep.get("physics_steps")}
        else:
            cmd = [cli, "datagen", "datagen.yaml", "--episodes", str(episodes), "--output",
                   str(out), "--seed", str(seed), "-q"] + CLI_PHYSICS_ONLY
            t = time.perf_counter()
            p = subprocess.run(cmd, capture_output=True, text=True, check=True)
            wall = time.perf_counter() - t
            m = re.search(r"episodes kept: (\d+) in ([0-9.]+) s \((\d+) policy steps, (\d+) "
                          r"physics steps\)", p.stdout)
            row = {"wall_s": wall, "engine_s": float(m.group(2)), "kept": int(m.group(1)),
                   "attempts": None, "physics_steps": int(m.group(4))}
        j = _journal(out)
        if row["attempts"] is None:
            row["attempts"] = len((out / "journal.jsonl").read_text().splitlines())
        row.update({"episode_s": j["episode"], "sample_s": j.get("sample"),
                    "physics_s": j.get("physics"), "hash": _data_hash(out)})
        shutil.rmtree(out, ignore_errors=True)
        return row

    one("python", "warm")  # imports, first-episode lazy init
    one("builtin", "warm")
    for r in range(rounds):
        for name in (("python", "builtin") if r % 2 == 0 else ("builtin", "python")):
            runs[name].append(one(name, str(r)))
    return runs


def frontend_compare(project: Path, cli: Path, episodes: int, small: int, rounds: int,
                     seed: int, python: str) -> dict:
    """(b): whole processes, alternating: python -m mlspaces.datagen (tutorial Python sampler;
    and with the built-in sampler) vs the CLI on datagen.yaml with the same overrides. Each
    variant runs `episodes` and `small` episodes: the difference of the two gives the
    startup-free rate."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("MLSPACES_ASSETS_DIR", None)
    scratch = project / "runs_b"
    scratch.mkdir(exist_ok=True)
    variants = {
        "cli": lambda n: [str(cli), "datagen", "datagen.yaml", "--episodes", str(n),
                          "--set", "task_config.enable_rendering=false",
                          "--set", "camera_config.cameras=[]"],
        "py_tutorial": lambda n: [python, "-m", "mlspaces.datagen", "benchmod:BenchPhysicsOnly"],
        "py_builtin": lambda n: [python, "-m", "mlspaces.datagen",
                                 "benchmod:BenchPhysicsOnlyBuiltin"],
    }

    def one(name: str, n: int, tag: str) -> dict:
        out = scratch / f"{name}_{n}_{tag}"
        cmd = variants[name](n) + ["--output", str(out), "--seed", str(seed), "-q"]
        t = time.perf_counter()
        p = subprocess.run(cmd, cwd=project, env=dict(env, BENCH_EPISODES=str(n)),
                           capture_output=True, text=True)
        wall = time.perf_counter() - t
        if p.returncode != 0:
            lines = p.stderr.strip().splitlines() or [""]
            err = next((x for x in lines if re.match(r"^\w+(Error|Exception): ", x)), lines[-1])
            if "NoneType" in p.stderr:
                err = err.split(". ")[0] + " (invoked with sampler=None)"
            failed[name] = (f"`{' '.join(cmd[1:4] if name != 'cli' else cmd[:3])}` exit "
                            f"{p.returncode}: {err[:300]}")
            return None
        m = (re.search(r"episodes kept: (\d+)", p.stdout) if name == "cli" else
             re.search(r"Success count: (\d+), Total count: (\d+)", p.stdout))
        kept = int(m.group(1)) if m else None
        steps = 0
        for line in (out / "journal.jsonl").read_text().splitlines():
            if line.strip():
                steps += json.loads(line).get("extra", {}).get("policy_steps", 0)
        row = {"wall_s": wall, "kept": kept, "hash": _data_hash(out), "policy_steps": steps}
        shutil.rmtree(out, ignore_errors=True)
        return row

    failed: dict[str, str] = {}
    for name in variants:
        one(name, small, "warm")
    order = [k for k in variants if k not in failed]
    runs: dict = {k: {episodes: [], small: []} for k in order}
    for r in range(rounds):
        for name in (order if r % 2 == 0 else order[::-1]):
            for n in ((episodes, small) if r % 2 == 0 else (small, episodes)):
                runs[name][n].append(one(name, n, str(r)))
    return {"runs": runs, "failed": failed}
