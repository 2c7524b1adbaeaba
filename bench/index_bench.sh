#!/usr/bin/env bash
# Whole-process timings of `mlspaces index-assets` and `mlspaces index-grasps` on a generated
# library of 10,000 assets (<uid>/<uid>.xml + .json, every 10th with .npz) and 10,000 grasp
# files (<uid>/droid/grasps.npz). Target: median < 0.3 s each.
#
#   bench/index_bench.sh [BUILD_DIR] [LIBRARY_DIR]
#
# BUILD_DIR defaults to build/ (needs apps/mlspaces/mlspaces and
# examples/make_example_grasps); LIBRARY_DIR defaults to $TMPDIR/mlspaces_index_bench and is
# generated only when absent. Uses hyperfine when installed, else a timed loop.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
lib="${2:-${TMPDIR:-/tmp}/mlspaces_index_bench}"
cli="$build/apps/mlspaces/mlspaces"
make_grasps="$build/examples/make_example_grasps"
runs="${RUNS:-15}"
for exe in "$cli" "$make_grasps"; do
  [[ -x "$exe" ]] || { echo "index_bench: missing $exe (build it first)" >&2; exit 1; }
done

if [[ ! -f "$lib/.complete" ]]; then
  echo "Generating $lib (10,000 assets, 10,000 grasp files)..."
  rm -rf "$lib"
  mkdir -p "$lib"
  "$make_grasps" "$lib/.grasp_template.npz" >/dev/null
  python3 - "$lib" <<'PY'
import os, sys
lib = sys.argv[1]
grasp = open(os.path.join(lib, ".grasp_template.npz"), "rb").read()
for i in range(10000):
    uid = f"asset_{i:05d}"
    d = os.path.join(lib, uid)
    os.makedirs(os.path.join(d, "droid"))
    with open(os.path.join(d, uid + ".xml"), "w") as f:
        f.write(f'<mujoco model="{uid}"><worldbody><body name="{uid}"><geom type="box" '
                'size="0.02 0.02 0.02"/></body></worldbody></mujoco>\n')
    with open(os.path.join(d, uid + ".json"), "w") as f:
        f.write('{\n    "assetId": "%s",\n    "category": "block",\n'
                '    "synset": "block.n.01"\n}' % uid)
    if i % 10 == 0:
        with open(os.path.join(d, uid + ".npz"), "wb") as f:
            f.write(grasp)
    with open(os.path.join(d, "droid", "grasps.npz"), "wb") as f:
        f.write(grasp)
os.remove(os.path.join(lib, ".grasp_template.npz"))
PY
  touch "$lib/.complete"
fi

# Sanity check (and warm the page cache) before timing.
"$cli" index-assets "$lib" --overwrite
"$cli" index-grasps "$lib" --overwrite

if command -v hyperfine >/dev/null; then
  hyperfine --warmup 2 --runs "$runs" --style basic --export-json "$lib/.hyperfine.json" \
    -n index-assets "'$cli' index-assets '$lib' --overwrite" \
    -n index-grasps "'$cli' index-grasps '$lib' --overwrite" >/dev/null
  python3 - "$lib/.hyperfine.json" <<'PY'
import json, sys
for r in json.load(open(sys.argv[1]))["results"]:
    print(f"{r['command']}: median {r['median']:.3f} s "
          f"(min {r['min']:.3f}, max {r['max']:.3f}, {len(r['times'])} runs)")
PY
else
  for cmd in index-assets index-grasps; do
    times=()
    for ((i = 0; i < runs; ++i)); do
      start=$(date +%s.%N)
      "$cli" "$cmd" "$lib" --overwrite >/dev/null
      end=$(date +%s.%N)
      times+=("$(echo "$end - $start" | bc)")
    done
    median=$(printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}')
    echo "$cmd: median $median s ($runs runs, timed loop)"
  done
fi
