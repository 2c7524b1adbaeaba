#!/usr/bin/env bash
# Full-pipeline figures of `mlspaces datagen` on the tutorial config: episodes per hour with
# cameras and videos (both DROID cameras, 640x368, H.264) with 1 and 2 workers, as ratios to
# the physics-only run (no rendering), plus render and encode frames per second from the
# attempt journal (per camera frame, single worker).
#
#   bench/datagen_pipeline_bench.sh [BUILD_DIR] [EPISODES] [QUALITY]
#
# Defaults: build/, 4 episodes (one per work item, so 2 workers can share them), QUALITY
# "full" (shadows and reflections on, as the original) or "fast" (both off).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
episodes="${2:-4}"
quality="${3:-full}"
cli="$build/apps/mlspaces/mlspaces"
[[ -x "$cli" ]] || { echo "datagen_pipeline_bench: missing $cli (build it first)" >&2; exit 1; }
work="$(mktemp -d "${TMPDIR:-/tmp}/mlspaces_pipeline_XXXXXX")"
trap 'rm -rf "$work"' EXIT
common=(datagen "$root/examples/custom_assets/datagen.yaml" -q --seed 11 --episodes "$episodes"
        --set task_sampler_config.episodes_per_batch=1)
if [[ "$quality" == fast ]]; then
  common+=(--set camera_config.shadows=false --set camera_config.reflections=false)
fi

run() {  # name, extra args...; prints wall seconds
  local name="$1"; shift
  local t0 t1
  t0=$(date +%s.%N)
  "$cli" "${common[@]}" --output "$work/$name" "$@" > /dev/null
  t1=$(date +%s.%N)
  "$root/.venv/bin/python" -c "print($t1 - $t0)"
}

physics=$(run physics --set task_config.enable_rendering=false --workers 1)
one=$(run cameras1 --workers 1)
two=$(run cameras2 --workers 2)
printf 'quality %s, %d episodes, %d cores\n' "$quality" "$episodes" "$(nproc)"
printf '%-34s %10s %14s %12s\n' run seconds "episodes/hour" "vs physics"
for row in "physics-only (1 worker):$physics" "cameras + videos, 1 worker:$one" \
           "cameras + videos, 2 workers:$two"; do
  name="${row%%:*}"; secs="${row##*:}"
  printf '%-34s %10.2f %14.0f %11.3fx\n' "$name" "$secs" \
    "$("$root/.venv/bin/python" -c "print($episodes * 3600 / $secs)")" \
    "$("$root/.venv/bin/python" -c "print($physics / $secs)")"
done
"$root/.venv/bin/python" - "$work/cameras1/journal.jsonl" "$work/cameras1/house_0" <<'PY'
import json, sys, glob, h5py
recs = [json.loads(l) for l in open(sys.argv[1])]
frames = 0
for f in glob.glob(sys.argv[2] + "/*.h5"):
    with h5py.File(f, "r") as h:
        for k in h:
            frames += h[k]["success"].shape[0] * len(h[k]["obs/sensor_param"])
render = sum(r["timings"].get("render", 0) for r in recs)
encode = sum(r["timings"].get("encode", 0) for r in recs)
physics = sum(r["timings"].get("physics", 0) for r in recs)
print("camera frames (both cameras): %d" % frames)
print("render: %.1f frames/s (%.1f ms/frame)" % (frames / render, 1000 * render / frames))
print("encode: %.1f frames/s (%.2f ms/frame)" % (frames / encode, 1000 * encode / frames))
print("physics share of the episode time: %.1f%%" % (100 * physics / (physics + render + encode)))
PY
