#!/usr/bin/env python3
"""Benchmarks of the mlspaces Python API against its targets (issue point 10), and side by side
with the original MolmoSpaces (`molmo-spaces` from PyPI) when a bench venv holds it.

    bench/python_api_bench.sh [--quick]                  # from the repo root
    PYTHONPATH=build/python .venv/bin/python bench/python_api_bench.py [--quick] [--splits]

One run prints, as medians over several rounds of the per-call (or per-run) mean:

1. Library lookups, on a user library written here with numpy (the files of
   python/tests/conftest.py's write_library): 1,000 UIDs, each with an MJCF, a metadata JSON and
   a grasps NPZ of 1,000 float64 (N,4,4) transforms.
   - locate_uid_package(uid), cycling through the 1,000 UIDs (each looked up once before);
   - ObjectMeta.annotation(uid), warm (the same UID again after a first call);
   - load_pickup_grasps(uid, num_grasps=50) from a 1,000-grasp file.
   Each implementation runs in its own worker process (this file with --worker) on the same
   library: mlspaces with this interpreter, molmo_spaces with the bench venv's interpreter
   (--molmospaces-python, $MLSPACES_BENCH_MOLMOSPACES_PYTHON, else
   build/bench-venv-molmospaces/bin/python; `bench/python_api_bench.sh --setup-molmospaces`
   makes it). The original's lookups set up its resource manager first; the worker makes that
   setup offline and leaves the measured calls untouched (see setup_molmospaces_offline).
2. Datagen, physics only (task_config.enable_rendering=false, no cameras), on a copy of
   examples/custom_assets:
   (a) a Python sampler (the tutorial's BlockPickupTaskSampler, imported from its datagen.py)
       versus the engine's built-in 'block_pickup' sampler, both through
       mlspaces.datagen.run_config in one process, alternating (the built-in side falls back to
       the CLI on the same config when run_config rejects an engine sampler by name). The
       figure is the engine's own 'sample' stage timer (journal.jsonl): the two samplers draw
       different poses, so their episodes, and physics times, differ;
   (b) `python -m mlspaces.datagen` versus the CLI `mlspaces datagen` on the equivalent YAML
       (examples/custom_assets/datagen.yaml), same seed, alternating, whole processes timed:
       episodes kept per hour of an N-episode run, and without startup (from the difference
       between N- and 2-episode runs).
3. With --splits: each layer of the three mlspaces calls timed on its own, estimates of the
   per-call work of alternatives, and a check of the C++ random.sample port.

Targets: locate and warm annotation < 1 us per call, load 50 grasps < 15 us; the Python sampler
adds < 2 % to a physics-only episode; `python -m mlspaces.datagen` within 5 % of the CLI's
episodes per hour.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# The workers run this file with other interpreters (a bench venv) and from other folders:
# its sibling modules are found through this folder, not PYTHONPATH.
BENCH_DIR = str(Path(__file__).resolve().parent)
if BENCH_DIR not in sys.path:
    sys.path.insert(0, BENCH_DIR)

from python_api_bench_datagen import (  # noqa: E402
    CLI_PHYSICS_ONLY,
    frontend_compare,
    make_project,
    sampler_worker,
)
from python_api_bench_lookups import lookup_worker, splits_worker, write_library  # noqa: E402

REPO = Path(__file__).resolve().parents[1]

#: The original's figures on this machine class, from the issue text (us per call).
ISSUE_ORIGINAL_US = {"locate": 6.9, "annotation": 3.6, "load50": 148.0}
#: Targets (us per call) of the mlspaces calls.
TARGET_US = {"locate": 1.0, "annotation": 1.0, "load50": 15.0}
TARGET_SAMPLER_OVERHEAD_PCT = 2.0
TARGET_FRONTEND_RATIO = 0.95

LOOKUP_ROWS = [
    # key, label, headline (compared with a target)
    ("locate", "locate_uid_package(uid), 1,000 UIDs cycled", True),
    ("locate_same", "locate_uid_package(uid), one UID repeated", False),
    ("annotation", "ObjectMeta.annotation(uid), warm", True),
    ("load50", "load_pickup_grasps(uid, num_grasps=50), 1,000 in file", True),
    ("load_all", "load_pickup_grasps(uid, num_grasps=1000), whole file", False),
]


# ------------------------------------------------------------------------------------------
# Driver.


def find_molmospaces_python(arg: str | None) -> tuple[str | None, str]:
    cand = arg or os.environ.get("MLSPACES_BENCH_MOLMOSPACES_PYTHON")
    if cand:
        return (cand, "") if Path(cand).exists() else (None, f"{cand} does not exist")
    default = REPO / "build" / "bench-venv-molmospaces" / "bin" / "python"
    if default.exists():
        return str(default), ""
    return None, (f"no bench venv (looked for {default.relative_to(REPO)}; make it with "
                  "bench/python_api_bench.sh --setup-molmospaces, or pass "
                  "--molmospaces-python / MLSPACES_BENCH_MOLMOSPACES_PYTHON)")


def run_worker(python: str, args: list[str], env_extra: dict | None = None,
               env_drop: tuple = ()) -> dict:
    env = dict(os.environ)
    for k in env_drop:
        env.pop(k, None)
    env.update(env_extra or {})
    p = subprocess.run([python, str(Path(__file__).resolve())] + args, env=env,
                       capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError((p.stderr or p.stdout).strip().splitlines()[-1] if
                           (p.stderr or p.stdout).strip() else f"exit {p.returncode}",
                           p.stderr[-4000:])
    return json.loads(p.stdout.strip().splitlines()[-1])


def merge_sessions(sessions: list[dict]) -> dict:
    """Medians over every round of every worker session (min/max over them)."""
    out = {}
    for key in sessions[0]["results"]:
        meds = [s["results"][key]["median_us"] for s in sessions]
        out[key] = {"median_us": statistics.median(meds),
                    "min_us": min(s["results"][key]["min_us"] for s in sessions),
                    "max_us": max(s["results"][key]["max_us"] for s in sessions),
                    "sessions": meds}
    return out


def fmt_us(v: float) -> str:
    return f"{v:8.3f}" if v < 10 else f"{v:8.1f}"


def mark(ok: bool) -> str:
    return "PASS" if ok else "FAIL"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer rounds and episodes (smoke run)")
    ap.add_argument("--molmospaces-python", help="python of a venv with molmo-spaces installed")
    ap.add_argument("--no-molmospaces", action="store_true", help="skip the original")
    ap.add_argument("--cli", help="the mlspaces CLI (default: build/apps/mlspaces/mlspaces, "
                    "$MLSPACES_CLI_PATH, or mlspaces on PATH)")
    ap.add_argument("--episodes", type=int, help="episodes per datagen run (default 24; quick 6)")
    ap.add_argument("--rounds", type=int, help="datagen rounds (default 7; quick 2)")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--skip-datagen", action="store_true")
    ap.add_argument("--skip-lookups", action="store_true")
    ap.add_argument("--splits", action="store_true",
                    help="also time each layer of the mlspaces calls on its own")
    ap.add_argument("--keep", action="store_true", help="keep the temp folder")
    ap.add_argument("--worker", choices=["mlspaces", "molmo_spaces", "sampler", "splits"],
                    help=argparse.SUPPRESS)
    ap.add_argument("--library", help=argparse.SUPPRESS)
    ap.add_argument("--home", help=argparse.SUPPRESS)
    ap.add_argument("--lookup-rounds", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    quick = args.quick
    lookup_rounds = args.lookup_rounds or (5 if quick else 15)
    round_s = 0.02 if quick else 0.05

    if args.worker in ("mlspaces", "molmo_spaces"):
        res = lookup_worker(args.worker, Path(args.library), lookup_rounds, round_s,
                            Path(args.home) if args.home else None)
        print(json.dumps(res))
        return 0
    if args.worker == "splits":
        print(json.dumps(splits_worker(Path(args.library), lookup_rounds, round_s)))
        return 0
    if args.worker == "sampler":
        print(json.dumps(sampler_worker(Path(args.home), args.episodes, args.rounds, args.seed,
                                        args.cli)))
        return 0

    # Workers and datagen processes run in other folders: make PYTHONPATH absolute.
    if os.environ.get("PYTHONPATH"):
        os.environ["PYTHONPATH"] = os.pathsep.join(
            str(Path(p).resolve()) for p in os.environ["PYTHONPATH"].split(os.pathsep) if p)
    episodes = args.episodes or (6 if quick else 24)
    rounds = args.rounds or (2 if quick else 7)
    sessions = 1 if quick else 2
    tmp = Path(tempfile.mkdtemp(prefix="mlspaces_pyapi_bench_"))

    def say(s: str = "") -> None:
        print(s, flush=True)

    summary: list[tuple[str, str, str, str]] = []  # what, measured, target, verdict

    try:
        import mlspaces
        rev = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
                             capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "-uno"],
                               capture_output=True, text=True).stdout.strip()
        say(f"mlspaces Python API bench ({'quick' if quick else 'full'} run), "
            f"{time.strftime('%Y-%m-%d %H:%M:%S')}")
        say(f"  machine: {platform.machine()}, {os.cpu_count()} CPUs, {platform.platform()}")
        say(f"  mlspaces: {Path(mlspaces.__file__).parent} (git {rev}{'+dirty' if dirty else ''})")
        say(f"  python: {sys.executable} ({sys.version.split()[0]})")
        say(f"  timing: median over rounds of the per-call mean ({lookup_rounds} rounds of "
            f"~{round_s * 1000:.0f} ms per worker x {sessions} worker session(s) per package)")
        say()

        # --- lookups -------------------------------------------------------------------
        if not args.skip_lookups:
            lib = tmp / "library"
            t = time.perf_counter()
            write_library(lib, 1000, 1000)
            say(f"library: 1,000 UIDs x 1,000 grasps written in {time.perf_counter() - t:.1f} s "
                f"({lib})")
            say("  UIDs block_0000..block_0999: two tokens, as the tutorial's red_block (the "
                "original's locate does one index lookup per token and built-in object source)")
            worker_args = ["--library", str(lib), "--lookup-rounds", str(lookup_rounds)] + (
                ["--quick"] if quick else [])
            ms_python, ms_why = (None, "skipped (--no-molmospaces)") if args.no_molmospaces \
                else find_molmospaces_python(args.molmospaces_python)
            ours, orig, orig_err = [], [], None
            for s in range(sessions):
                ours.append(run_worker(sys.executable, ["--worker", "mlspaces"] + worker_args))
                if ms_python and orig_err is None:
                    home = tmp / f"molmospaces_home_{s}"
                    try:
                        orig.append(run_worker(
                            ms_python, ["--worker", "molmo_spaces", "--home", str(home)] +
                            worker_args,
                            {"MLSPACES_ASSETS_DIR": str(home / "assets"),
                             "MLSPACES_CACHE_DIR": str(home / "cache")}))
                    except RuntimeError as e:
                        orig_err = e.args[0]
                        sys.stderr.write(e.args[1] if len(e.args) > 1 else "")
            mine = merge_sessions(ours)
            theirs = merge_sessions(orig) if orig else None
            o0 = ours[0]
            say(f"mlspaces {o0['version']} ({o0['module']}), numpy {o0['numpy']}, install dir "
                f"of built-in data: {o0['assets_dir'] or 'none (user libraries only)'}")
            if orig:
                t0 = orig[0]
                say(f"molmo-spaces {t0['version']} ({ms_python}), numpy {t0['numpy']}; "
                    "offline resource-manager setup:")
                for step in t0["setup"]:
                    say(f"    - {step}")
                say(f"  first calls (cold, not in the table): locate {t0['first_locate_s']:.3f} s,"
                    f" annotation {t0['first_annotation_s']:.3f} s (mlspaces: "
                    f"{o0['first_locate_s'] * 1e6:.0f} us, {o0['first_annotation_s'] * 1e6:.0f} us)")
                agree = all(o["check"] == orig[0]["check"] for o in ours + orig)
                say(f"  same answers from both (locate tuple, annotation dict, the 50 grasps "
                    f"drawn after random.seed(1234)): {'yes' if agree else 'NO'}")
                if not agree:
                    say(f"    mlspaces: {o0['check']}\n    molmo-spaces: {orig[0]['check']}")
            else:
                why = orig_err or ms_why
                say(f"molmo-spaces: not installable here: {why}" if orig_err else
                    f"molmo-spaces: not run: {why}")
                say("  the original's figures below are the issue's, on this machine class")
            say(f"  Python call floor (a no-op Python function in the same loop): "
                f"{mine['noop']['median_us']:.3f} us")
            say()
            say("Library lookups, us per call (median; min-max over rounds)")
            hdr = (f"  {'call':<54} {'mlspaces':>9} {'min-max':>17} {'original':>9} "
                   f"{'ratio':>7} {'target':>8}  ")
            say(hdr)
            say("  " + "-" * (len(hdr) - 2))
            for key, label, headline in LOOKUP_ROWS:
                m = mine[key]
                if theirs:
                    ref = theirs[key]["median_us"]
                    ref_s = fmt_us(ref)
                else:
                    ref = ISSUE_ORIGINAL_US.get(key)
                    ref_s = (fmt_us(ref) + "*") if ref else "       -"
                ratio = f"{ref / m['median_us']:6.1f}x" if ref else "      -"
                tgt = TARGET_US.get(key) if headline else None
                verdict = (f"< {tgt:g} us  {mark(m['median_us'] < tgt)}" if tgt else "")
                if tgt:
                    vs = f" ({ref / m['median_us']:.1f}x faster than the original)" if theirs \
                        else ""
                    summary.append((label, f"{m['median_us']:.3g} us{vs}", f"< {tgt:g} us",
                                    mark(m["median_us"] < tgt)))
                say(f"  {label:<54} {fmt_us(m['median_us'])} "
                    f"{fmt_us(m['min_us']).strip():>8}-{fmt_us(m['max_us']).strip():<8} "
                    f"{ref_s:>9} {ratio:>7} {verdict}")
            say("  ratio = original / mlspaces (higher: mlspaces faster)" +
                ("" if theirs else "; * the issue's figure for the original"))
            if theirs:
                say("  the issue's figures for the original on this machine class: " + ", ".join(
                    f"{k} {v:g} us" for k, v in ISSUE_ORIGINAL_US.items()))
            say()
            if args.splits:
                sp = run_worker(sys.executable, ["--worker", "splits"] + worker_args)
                say("Layer splits of the mlspaces calls (each layer timed alone), us per call")
                bad = sp.pop("_port_mismatches")
                for k, v in sp.items():
                    say(f"  {k:<78} {fmt_us(v['median_us'])}")
                say(f"  the C++ port vs random.sample (same picks, same generator state after; "
                    f"1,600 seeded cases): {'exact' if bad == 0 else f'{bad} MISMATCHES'}")
                say()

        # --- datagen ---------------------------------------------------------------------
        if not args.skip_datagen:
            cli = Path(args.cli or os.environ.get("MLSPACES_CLI_PATH") or
                       REPO / "build" / "apps" / "mlspaces" / "mlspaces")
            if not cli.exists() and shutil.which("mlspaces"):
                cli = Path(shutil.which("mlspaces"))
            proj = make_project(tmp)
            say(f"Datagen, physics only (no cameras, enable_rendering=false), seed {args.seed}, "
                f"{episodes} episodes per run, {rounds} alternating rounds (+1 warm-up)")
            a = run_worker(sys.executable, ["--worker", "sampler", "--home", str(proj),
                                            "--episodes", str(episodes), "--rounds", str(rounds),
                                            "--seed", str(args.seed), "--cli", str(cli)],
                           env_drop=("MLSPACES_ASSETS_DIR",))

            def med(rows, f):
                vals = [f(r) for r in rows if f(r) is not None]
                return statistics.median(vals) if vals else float("nan")

            sides = ("python", "builtin")
            ep = {k: med(a[k], lambda r: r["episode_s"]) for k in sides}
            sample = {k: med(a[k], lambda r: r["sample_s"]) for k in sides}
            phys = {k: med(a[k], lambda r: r["physics_s"]) for k in sides}
            other = {k: med(a[k], lambda r: r["episode_s"] - r["physics_s"]) for k in sides}
            eng = {k: med(a[k], lambda r: r["engine_s"] / r["attempts"]) for k in sides}
            # The two samplers draw different poses (numpy's generator vs the engine's), so
            # their episodes differ: time per 1,000 physics steps compares equal work.
            per_kstep = {k: med(a[k], lambda r: r["engine_s"] / r["physics_steps"] * 1e3)
                         for k in sides}
            direct = (sample["python"] - sample["builtin"]) / ep["builtin"] * 100
            e2e = (eng["python"] / eng["builtin"] - 1) * 100
            norm = (per_kstep["python"] / per_kstep["builtin"] - 1) * 100
            via = ("run_config" if a["builtin_via"] == "run_config" else
                   "the CLI (run_config failed for it: " + a["error"] + ")")
            say("(a) Python sampler (the tutorial's BlockPickupTaskSampler, via run_config) vs "
                f"the built-in 'block_pickup' (via {via})")
            say("    ms per episode, median over rounds of the run's mean (engine timers: "
                "journal stages; run = the engine's run seconds)")
            say(f"  {'ms':<34} {'python':>10} {'built-in':>10} {'delta':>10}")
            for label, d, digits in (("episode (sum of stages)", ep, 2),
                                     ("  sample stage (the sampler)", sample, 3),
                                     ("  physics stage", phys, 2),
                                     ("  all stages but physics", other, 3),
                                     ("run seconds per episode", eng, 2),
                                     ("run seconds per 1,000 phys. steps", per_kstep, 2)):
                say(f"  {label:<34} {d['python'] * 1e3:10.{digits}f} "
                    f"{d['builtin'] * 1e3:10.{digits}f} "
                    f"{(d['python'] - d['builtin']) * 1e3:+10.{digits}f}")
            pa, ba = a["python"][0], a["builtin"][0]
            say(f"  per run: python {pa['kept']} kept / {pa['attempts']} attempts, "
                f"{pa['physics_steps']} physics steps; built-in {ba['kept']} / {ba['attempts']}, "
                f"{ba['physics_steps']} (other poses: numpy's draws vs the engine's)")
            say(f"  Python sampler overhead = sample-stage delta / built-in episode: "
                f"{direct:+.2f} %   target < {TARGET_SAMPLER_OVERHEAD_PCT:g} %  "
                f"{mark(direct < TARGET_SAMPLER_OVERHEAD_PCT)}")
            spread = {k: [r["engine_s"] / r["physics_steps"] * 1e6 for r in a[k]] for k in sides}
            say(f"  cross-checks (other episodes, and the machine's noise: run seconds per "
                f"physics step ranged {min(spread['python']):.1f}-{max(spread['python']):.1f} us "
                f"(python) and {min(spread['builtin']):.1f}-{max(spread['builtin']):.1f} us "
                f"(built-in) over the rounds): per physics step {norm:+.2f} %, per episode "
                f"{e2e:+.2f} %")
            summary.append(("Python sampler overhead per physics-only episode",
                            f"{direct:+.2f} % ({(sample['python'] - sample['builtin']) * 1e3:.2f} "
                            f"ms of {ep['builtin'] * 1e3:.0f} ms)",
                            f"< {TARGET_SAMPLER_OVERHEAD_PCT:g} %",
                            mark(direct < TARGET_SAMPLER_OVERHEAD_PCT)))
            say()

            small = 2
            fb = frontend_compare(proj, cli, episodes, small, rounds, args.seed, sys.executable)
            b = fb["runs"]
            wall = {k: {n: med(v[n], lambda r: r["wall_s"]) for n in v} for k, v in b.items()}
            kept = {k: {n: v[n][0]["kept"] for n in v} for k, v in b.items()}
            whole = {k: kept[k][episodes] / wall[k][episodes] * 3600 for k in b}
            steady = {k: (kept[k][episodes] - kept[k][small]) /
                      (wall[k][episodes] - wall[k][small]) * 3600 for k in b}
            steps = {k: {n: v[n][0]["policy_steps"] for n in v} for k, v in b.items()}
            steady_steps = {k: (steps[k][episodes] - steps[k][small]) /
                            (wall[k][episodes] - wall[k][small]) for k in b}
            per_ep_b = {k: 3600 / steady[k] for k in b}
            startup = {k: wall[k][small] - kept[k][small] * per_ep_b[k] for k in b}
            hashes = {k: {r["hash"] for r in v[episodes]} for k, v in b.items()}
            say(f"(b) whole processes, episodes kept per hour (median of {rounds} alternating "
                f"rounds of {episodes}- and {small}-episode runs)")
            say(f"  CLI: {cli} datagen datagen.yaml --episodes N " + " ".join(CLI_PHYSICS_ONLY))
            say(f"  {'command':<52} {'wall s':>7} {'ep/hour':>8} {'vs CLI':>7} "
                f"{'startup':>8} {'ep/h w/o':>9} {'vs CLI':>7} {'steps/s':>8} {'vs CLI':>7}")
            say(f"  {'':<52} {f'{episodes} ep':>7} {'':>8} {'':>7} {'s':>8} "
                f"{'startup':>9} {'':>7} {'w/o st.':>8} {'':>7}")
            labels = {"cli": "mlspaces datagen datagen.yaml (built-in sampler)",
                      "py_tutorial": "python -m mlspaces.datagen (tutorial Python sampler)",
                      "py_builtin": "python -m mlspaces.datagen (built-in sampler)"}
            verdicts = []
            for k in ("cli", "py_tutorial", "py_builtin"):
                if k in fb["failed"]:
                    say(f"  {labels[k]:<52} FAILED: {fb['failed'][k]}")
                    summary.append((f"{labels[k].split(' (')[0]} ({labels[k].split(' (')[1]} vs "
                                    "CLI", "did not run (see (b))",
                                    f">= {TARGET_FRONTEND_RATIO:.2f} x", "n/a"))
                    continue
                r1, r2 = whole[k] / whole["cli"], steady[k] / steady["cli"]
                r3 = steady_steps[k] / steady_steps["cli"]
                say(f"  {labels[k]:<52} {wall[k][episodes]:7.2f} {whole[k]:8.0f} {r1:7.3f} "
                    f"{startup[k]:8.2f} {steady[k]:9.0f} {r2:7.3f} {steady_steps[k]:8.0f} "
                    f"{r3:7.3f}")
                if k != "cli":
                    verdicts.append((k, r1, r2))
            for k, r1, r2 in verdicts:
                who = "python -m (tutorial sampler)" if k == "py_tutorial" else \
                    "python -m (built-in sampler)"
                summary.append((f"{who} vs CLI, episodes/hour w/o startup", f"{r2:.3f} x",
                                f">= {TARGET_FRONTEND_RATIO:.2f} x", mark(r2 >= TARGET_FRONTEND_RATIO)))
                summary.append((f"{who} vs CLI, whole process, {episodes} episodes",
                                f"{r1:.3f} x (startup {startup[k] - startup['cli']:+.2f} s)",
                                f">= {TARGET_FRONTEND_RATIO:.2f} x", mark(r1 >= TARGET_FRONTEND_RATIO)))
                say(f"  {labels[k]}: target >= {TARGET_FRONTEND_RATIO:.2f} x CLI: whole process "
                    f"({episodes} episodes) {r1:.3f} {mark(r1 >= TARGET_FRONTEND_RATIO)}; "
                    f"startup-free {r2:.3f} {mark(r2 >= TARGET_FRONTEND_RATIO)}")
            say(f"  startup = wall of the {small}-episode run less {small} episodes at the "
                f"startup-free rate; ep/h w/o startup = (kept({episodes}) - kept({small})) / "
                f"(wall({episodes}) - wall({small})); steps/s = policy steps (journal) per "
                "second, the same way (work-normalised: the Python sampler's episodes differ)")
            for k, _, _ in verdicts:
                gap = startup[k] - startup["cli"]
                # whole(N) / whole_cli(N) >= t  <=>  N >= t*S_p - S_c / (e_c - t*e_p) ...
                t = TARGET_FRONTEND_RATIO
                denom = per_ep_b["cli"] - t * per_ep_b[k]
                need = (t * startup[k] - startup["cli"]) / denom if denom > 0 else float("inf")
                when = (f"from about {max(0.0, need):.0f} episodes per run" if need != float("inf")
                        else "never (its startup-free rate is below that)")
                say(f"  {labels[k]}: startup {gap:+.2f} s vs the CLI; the whole-process ratio "
                    f"reaches {t:.2f} {when}")
            if "py_builtin" in b:
                same = hashes["py_builtin"] == hashes["cli"] and len(hashes["cli"]) == 1
                say(f"  data hash: CLI {','.join(sorted(map(str, hashes['cli'])))}, python -m "
                    f"built-in {','.join(sorted(map(str, hashes['py_builtin'])))} "
                    f"({'same episodes' if same else 'DIFFERENT'})")
            say()
        if summary:
            say("Summary (medians; targets of issue point 10)")
            w = max(len(r[0]) for r in summary)
            m = max(len(r[1]) for r in summary)
            for what, value, target, verdict in summary:
                say(f"  {what:<{w}}  {value:<{m}}  {target:<10} {verdict}")
            say()
    finally:
        if args.keep:
            print(f"(kept {tmp})")
        else:
            shutil.rmtree(tmp, ignore_errors=True)

    return 0


if __name__ == "__main__":
    sys.exit(main())
