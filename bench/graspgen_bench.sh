#!/usr/bin/env bash
# Grasp generation, speed and end-to-end quality (issue 31 points 4 and 5), on the mesh library
# bench/graspgen/make_mesh_library.py writes (mugs, bowls, L-brackets, cylinders, boxes; OBJ
# meshes of convex parts).
#
#   bench/graspgen_bench.sh [BUILD_DIR] [RESULTS_FILE]
#
# Defaults: build/, stdout only (RESULTS_FILE: also appended there). Environment:
#   SPEED_UID=mug_small        the ~10-part object of the speed figures
#   SPEED_COUNTS="100 1000"    --max-grasps of the speed runs, each with -j 1 and -j 2 (JOBS)
#   JOBS="1 2"
#   QUALITY_MAX_GRASPS=200     --max-grasps per object before the pick runs
#   EPISODES=9                 pick attempts per object (12 objects: 108 per seed)
#   SEEDS="1 2 3"              one datagen run per seed
#   SKIP_SPEED=1 / SKIP_QUALITY=1
#   KEEP_WORK=1                keep the temp folder (library, grasps, runs) and print its path
#
# (a) speed: `generate-grasps LIB --uid SPEED_UID --max-grasps N -j J --overwrite`, wall time
#     of the process (date +%s.%N), and the command's own per-object line (accepted, tested,
#     candidates, steps per accepted grasp, seconds); the NPZ of -j 1 and -j 2 compared (cmp).
# (b) quality: `generate-grasps LIB --max-grasps QUALITY_MAX_GRASPS` for every object, then
#     `datagen` of the generated project (franka_droid, no cameras,
#     filter_for_successful_trajectories off: every attempt counted; object yaw +-180 deg),
#     success per object and overall from journal.jsonl, with the failure messages.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
results="${2:-}"
cli="$build/apps/mlspaces/mlspaces"
py="$root/.venv/bin/python"
[[ -x "$cli" ]] || { echo "graspgen_bench: missing $cli (build it first)" >&2; exit 1; }
"$cli" generate-grasps --help > /dev/null 2>&1 ||
  { echo "graspgen_bench: $cli has no generate-grasps command" >&2; exit 1; }
speed_uid="${SPEED_UID:-mug_small}"
read -r -a speed_counts <<< "${SPEED_COUNTS:-100 1000}"
read -r -a jobs <<< "${JOBS:-1 2}"
quality_max="${QUALITY_MAX_GRASPS:-200}"
episodes="${EPISODES:-9}"
read -r -a seeds <<< "${SEEDS:-1 2 3}"

work="$(mktemp -d "${TMPDIR:-/tmp}/mlspaces_graspgen_XXXXXX")"
if [[ -n "${KEEP_WORK:-}" ]]; then echo "work folder: $work (kept)"; else trap 'rm -rf "$work"' EXIT; fi
if [[ -n "$results" ]]; then exec > >(tee -a "$results") 2>&1; fi

say() { printf '%s\n' "$*"; }
load() { cut -d' ' -f1-3 /proc/loadavg; }

say "== graspgen_bench $(date -u +%Y-%m-%dT%H:%M:%SZ)"
say "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)," \
  "load average at start $(load)"
say "source: $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo '?')" \
  "(+ uncommitted changes: $(git -C "$root" status --porcelain 2>/dev/null | wc -l) paths)"
say "cli: $cli"

"$py" "$root/bench/graspgen/make_mesh_library.py" "$work/project" --project --list
lib="$work/project/library"
"$cli" index-assets "$lib" --compute-metadata --overwrite > /dev/null

# The command's per-object line: "<uid>: N grasps (T tested of C candidates, S steps/grasp) in
# X s" (ObjectReportLine); prints "accepted tested candidates steps_per_grasp seconds", '?'
# for a figure the line does not have.
parse_line() {
  "$py" - "$1" "$2" <<'PY'
import re, sys
uid, text = sys.argv[1], open(sys.argv[2]).read()
line = next((l for l in text.splitlines() if l.strip().startswith(uid + ":")), "")
num = lambda pat: (m.group(1).replace(",", "") if (m := re.search(pat, line)) else "?")
print(num(r":\s*([\d,]+) grasps"), num(r"([\d,]+) tested"), num(r"of ([\d,]+) candidates"),
      num(r"([\d,.]+) steps/grasp"), num(r"in ([\d,.]+) s"))
PY
}

if [[ -z "${SKIP_SPEED:-}" ]]; then
  say ""
  say "-- (a) speed: $speed_uid ($(ls "$lib/$speed_uid"/*.obj | wc -l) convex parts), seed 0"
  printf '%-6s %3s %9s %9s %9s %11s %12s %9s %s\n' max_g -j wall_s accepted tested \
    candidates steps/grasp cmd_s load_1m
  for n in "${speed_counts[@]}"; do
    for j in "${jobs[@]}"; do
      out="$work/speed_${n}_j$j.txt"
      start="$(date +%s.%N)"
      "$cli" generate-grasps "$lib" --uid "$speed_uid" --max-grasps "$n" -j "$j" --seed 0 \
        --overwrite > "$out" 2>&1 || { say "generate-grasps failed:"; cat "$out"; exit 1; }
      end="$(date +%s.%N)"
      cp "$lib/$speed_uid/droid/grasps.npz" "$work/speed_${n}_j$j.npz"
      read -r acc tested cand spg secs < <(parse_line "$speed_uid" "$out")
      printf '%-6s %3s %9.2f %9s %9s %11s %12s %9s %s\n' "$n" "$j" \
        "$(echo "$end - $start" | bc)" "$acc" "$tested" "$cand" "$spg" "$secs" "$(load | cut -d' ' -f1)"
    done
    if [[ ${#jobs[@]} -ge 2 ]]; then
      a="$work/speed_${n}_j${jobs[0]}.npz" b="$work/speed_${n}_j${jobs[1]}.npz"
      if cmp -s "$a" "$b"; then say "  max_g $n: -j ${jobs[0]} and -j ${jobs[1]} NPZ identical"
      else say "  max_g $n: -j ${jobs[0]} and -j ${jobs[1]} NPZ DIFFER"; fi
    fi
  done
  say "  its output (last run):"
  sed 's/^/    /' "$out" | tail -n 5
fi

if [[ -z "${SKIP_QUALITY:-}" ]]; then
  say ""
  say "-- (b) quality: generate-grasps for every object, --max-grasps $quality_max, seed 0"
  start="$(date +%s.%N)"
  rc=0
  "$cli" generate-grasps "$lib" --max-grasps "$quality_max" --seed 0 --overwrite \
    > "$work/quality_gen.txt" 2>&1 || rc=$?
  end="$(date +%s.%N)"
  sed 's/^/  /' "$work/quality_gen.txt" | tail -n 30
  say "  exit $rc, wall $(echo "$end - $start" | bc) s, load average $(load)"
  mkdir -p "$work/runs"
  for seed in "${seeds[@]}"; do
    out="$work/runs/seed_$seed"
    say ""
    say "-- datagen: $episodes attempts per object, seed $seed:" \
      "mlspaces datagen project/datagen.yaml --episodes $episodes --seed $seed -q"
    start="$(date +%s.%N)"
    "$cli" datagen "$work/project/datagen.yaml" -q --seed "$seed" --episodes "$episodes" \
      --output "$out" > "$out.txt" 2>&1 || { say "datagen failed:"; cat "$out.txt"; exit 1; }
    end="$(date +%s.%N)"
    "$py" - "$work/project/datagen.yaml" "$out/journal.jsonl" "$(echo "$end - $start" | bc)" <<'PY'
import collections, json, re, sys
cfg, journal, wall = sys.argv[1:]
scenes = re.search(r"scene_xml_paths: \[(.*)\]", open(cfg).read()).group(1).split(", ")
uids = [re.search(r"scene_(.+)\.xml", s).group(1) for s in scenes]
rows = [json.loads(l) for l in open(journal)]
per = collections.defaultdict(list)
for r in rows:
    per[uids[int(r["scene"].split("_")[1])]].append(r)
print("%-16s %8s %9s %8s  %s" % ("object", "attempts", "successes", "rate", "failures"))
for uid in uids:
    rs = per[uid]
    ok = sum(r["outcome"] == "success" for r in rs)
    bad = collections.Counter(r["outcome"] for r in rs if r["outcome"] != "success")
    print("%-16s %8d %9d %7.1f%%  %s" % (uid, len(rs), ok, 100.0 * ok / max(len(rs), 1),
                                         dict(bad) or "-"))
n = len(rows)
ok = sum(r["outcome"] == "success" for r in rows)
print("%-16s %8d %9d %7.1f%%  (wall %.1f s)" % ("ALL", n, ok, 100.0 * ok / max(n, 1), float(wall)))
for r in rows:
    if r["outcome"] != "success":
        uid = uids[int(r["scene"].split("_")[1])]
        ex = r.get("extra", {})
        print("  fail %s ep %s: %s: %s [grasps %s, collision-free %s, used #%s, retries %s]" % (
            uid, r["episode"], r["outcome"], r["message"][:160], ex.get("num_grasps"),
            ex.get("num_collision_free"), ex.get("grasp_index"), ex.get("retries")))
PY
  done
fi
say ""
say "load average at end $(load)"
