#!/usr/bin/env bash
# Two builds side by side in one run (e.g. the last MuJoCo 2.2.2 commit against the MuJoCo 3.5
# build): physics steps/s (the datagen model: arm + gripper + block), compose and compile of
# the scene + robot + 10 objects, compute-metadata assets/s on generated mesh assets, render
# ms/frame at 640x368 RGB+depth with and without shadows/reflections (OSMesa and EGL), and
# tutorial episodes/h with and without the two cameras. Rounds alternate the builds (A B A B
# ...) so both see the same machine; the table shows medians over the rounds and NEW/OLD.
#
#   bench/engine_compare.sh OLD_BUILD NEW_BUILD [ROUNDS] [MESH_ASSETS]
#
# Defaults: 3 rounds, 999 mesh assets (UV spheres of 400..2,000 vertices, one OBJ each).
# Each build needs apps/mlspaces/mlspaces and bench/{datagen_bench,sim_compose_bench,
# sim_render_bench}. Prints the machine's load average before and after: figures taken beside
# other work are noisy, ratios less so.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
[ $# -ge 2 ] || { sed -n '2,14p' "$0"; exit 2; }
old="$(cd "$1" && pwd)"
new="$(cd "$2" && pwd)"
rounds="${3:-3}"
assets="${4:-999}"
for b in "$old" "$new"; do
  for exe in apps/mlspaces/mlspaces bench/datagen_bench bench/sim_compose_bench bench/sim_render_bench; do
    [ -x "$b/$exe" ] || { echo "engine_compare: missing $b/$exe (build with benches)" >&2; exit 1; }
  done
done
work="$(mktemp -d "${TMPDIR:-/tmp}/mlspaces_engine_compare_XXXXXX")"
trap 'rm -rf "$work"' EXIT
out="$work/results.jsonl"
: > "$out"
echo "load before: $(cut -d' ' -f1-3 /proc/loadavg)"

# The mesh library: deterministic UV spheres with a little noise (no two alike).
python3 - "$work/meshlib" "$assets" <<'PY'
import json, math, os, random, sys
lib, n = sys.argv[1], int(sys.argv[2])
rng = random.Random(2026)
for i in range(n):
    uid = f"mesh_{i:05d}"
    d = os.path.join(lib, uid)
    os.makedirs(d)
    rings = rng.randint(14, 31)
    segs = 2 * rings
    lines = []
    for a in range(1, rings):
        th = math.pi * a / rings
        for b in range(segs):
            ph = 2 * math.pi * b / segs
            r = 0.04 * (1 + 0.05 * rng.random())
            lines.append(f"v {r*math.sin(th)*math.cos(ph):.6f} {r*math.sin(th)*math.sin(ph):.6f} {r*math.cos(th):.6f}")
    lines.append("v 0 0 0.04")
    lines.append("v 0 0 -0.04")
    top, bot = (rings - 1) * segs + 1, (rings - 1) * segs + 2
    idx = lambda a, b: (a - 1) * segs + (b % segs) + 1
    for b in range(segs):
        lines.append(f"f {top} {idx(1, b)} {idx(1, b + 1)}")
        lines.append(f"f {bot} {idx(rings - 1, b + 1)} {idx(rings - 1, b)}")
    for a in range(1, rings - 1):
        for b in range(segs):
            lines.append(f"f {idx(a, b)} {idx(a + 1, b)} {idx(a + 1, b + 1)} {idx(a, b + 1)}")
    open(os.path.join(d, uid + ".obj"), "w").write("\n".join(lines) + "\n")
    open(os.path.join(d, uid + ".xml"), "w").write(
        f'<mujoco model="{uid}"><asset><mesh name="{uid}" file="{uid}.obj"/></asset>'
        f'<worldbody><body name="{uid}"><freejoint/><geom type="mesh" mesh="{uid}" '
        f'density="800"/></body></worldbody></mujoco>\n')
    json.dump({"assetId": uid, "category": "sphere"}, open(os.path.join(d, uid + ".json"), "w"))
PY

record() {  # build label, metric, value
  printf '{"build": "%s", "metric": "%s", "value": %s}\n' "$1" "$2" "$3" >> "$out"
}

seconds() {  # command...; prints wall seconds
  local t0 t1
  t0=$(date +%s.%N)
  "$@" > /dev/null 2>&1
  t1=$(date +%s.%N)
  python3 -c "print($t1 - $t0)"
}

gbench() {  # build label, binary, filter: records each benchmark's figure
  local label="$1" bin="$2" filter="$3"
  "$bin" --benchmark_filter="$filter" --benchmark_format=json 2>/dev/null |
    python3 -c '
import json, re, sys
# One JSON document per benchmark process (the render bench forks one per GL backend);
# programs may print other lines around them.
text, dec = sys.stdin.read(), json.JSONDecoder()
starts = [m.start() for m in re.finditer("^\\{\\s*\"context\"", text, re.M)]
for start in starts:
    try:
        doc, _ = dec.raw_decode(text, start)
    except ValueError:  # a benchmark that failed: its error went to stderr
        continue
    for b in doc.get("benchmarks", []):
        if b.get("error_occurred"): continue
        v = b["items_per_second"] if "items_per_second" in b else b["real_time"]
        print(b["name"], v)
' | while read -r name value; do record "$label" "$name" "$value"; done
}

one_round() {  # build label, build dir
  local label="$1" b="$2" cli="$2/apps/mlspaces/mlspaces" s
  gbench "$label" "$b/bench/datagen_bench" 'BM_BareMjStep'
  gbench "$label" "$b/bench/sim_compose_bench" '.'
  gbench "$label" "$b/bench/sim_render_bench" 'RgbDepth'
  rm -f "$work"/meshlib/*/*_computed.json
  s=$(seconds "$cli" index-assets "$work/meshlib" --compute-metadata --overwrite -o "$work/index.json")
  record "$label" "compute-metadata assets/s" "$(python3 -c "print($assets / $s)")"
  local yaml="$root/examples/custom_assets/datagen.yaml" common
  common=(datagen "$yaml" -q --seed 11 --episodes 4 --set task_sampler_config.episodes_per_batch=1)
  rm -rf "$work/dg"
  s=$(seconds "$cli" "${common[@]}" --set task_config.enable_rendering=false --output "$work/dg")
  record "$label" "episodes/h, no cameras" "$(python3 -c "print(4 * 3600 / $s)")"
  rm -rf "$work/dg"
  s=$(seconds "$cli" "${common[@]}" --output "$work/dg")
  record "$label" "episodes/h, 2 cameras 640x368" "$(python3 -c "print(4 * 3600 / $s)")"
}

for r in $(seq "$rounds"); do
  echo "round $r of $rounds"
  one_round old "$old"
  one_round new "$new"
done
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"

python3 - "$out" "$old" "$new" "$rounds" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
metrics = []
for r in rows:
    if r["metric"] not in metrics: metrics.append(r["metric"])
units = {"BM_BareMjStep": "steps/s"}
print(f"\nOLD = {sys.argv[2]}\nNEW = {sys.argv[3]}\nmedians of {sys.argv[4]} rounds\n")
print(f"| {'figure':<58} | {'OLD':>12} | {'NEW':>12} | NEW/OLD |")
print(f"|{'-'*60}|{'-'*14}|{'-'*14}|---------|")
for m in metrics:
    vals = {b: [r["value"] for r in rows if r["metric"] == m and r["build"] == b] for b in ("old", "new")}
    if not vals["old"] or not vals["new"]:
        print(f"| {m:<58} | {'-' if not vals['old'] else '%.4g' % statistics.median(vals['old']):>12} | "
              f"{'-' if not vals['new'] else '%.4g' % statistics.median(vals['new']):>12} |         |")
        continue
    o, n = statistics.median(vals["old"]), statistics.median(vals["new"])
    unit = units.get(m, "" if "/" in m or "episodes" in m else "ms")
    name = m + (f" ({unit})" if unit else "")
    print(f"| {name:<58} | {o:>12.4g} | {n:>12.4g} | {n / o:>7.2f} |")
PY
