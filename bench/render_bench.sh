#!/usr/bin/env bash
# Camera rendering benchmark (issue 33), in one run:
#  1. the speed/quality curve of the render settings on the states of real tutorial episodes
#     (build/bench/datagen_render_quality_bench: ms per camera frame, frames/s, SSIM per camera
#     against the full-quality frame, the per-episode cost of physics, render and encode);
#  2. `mlspaces datagen` on the tutorial with WORKERS workers: successful episodes per hour with
#     cameras at the default settings (one-pass fitted shadows, coarse sides, textures from
#     their nearest mipmap level, object_image_points read from the ids the frames carry),
#     without object_image_points, with MuJoCo's exact shapes in one pass, with MuJoCo's
#     trilinear texture filter in one pass, with MuJoCo's multi-pass
#     shadows at the same maps, without fitted maps (2048², multi-pass), at the original's full
#     quality, and without cameras.
#
#   bench/render_bench.sh [BUILD_DIR]      (default build)
#   GL=egl EPISODES=2 RUN_EPISODES=8 WORKERS=2 bench/render_bench.sh
#   SKIP_CURVE=1 bench/render_bench.sh     (the datagen runs only; SKIP_DATAGEN=1: the curve only)
#   RUNS="default no_cameras" bench/render_bench.sh   (some of the datagen runs: default,
#                               no_points, exact_sides, trilinear, multipass, unfitted, full,
#                               no_cameras)
# GL: osmesa (default) or egl (the EGL device platform: a GPU where one is installed).
# On llvmpipe each worker rasterises on its own thread (LP_NUM_THREADS=0, as datagen sets
# it with one worker per core), so figures are per core.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
GL=${GL:-osmesa}
EPISODES=${EPISODES:-2}
RUN_EPISODES=${RUN_EPISODES:-8}
WORKERS=${WORKERS:-$(nproc)}
RUNS=" ${RUNS:-default no_points exact_sides trilinear multipass unfitted full no_cameras} "
BENCH=$BUILD/bench/datagen_render_quality_bench
CLI=$BUILD/apps/mlspaces/mlspaces
for f in "$BENCH" "$CLI"; do
  [[ -x $f ]] || { echo "render_bench: $f is missing (build it: scripts/build.sh)" >&2; exit 2; }
done
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

if [[ -z ${SKIP_CURVE:-} ]]; then
  echo "== render settings: speed and SSIM against full quality ($GL, $EPISODES episodes)"
  LP_NUM_THREADS=${LP_NUM_THREADS:-0} stdbuf -oL "$BENCH" --gl "$GL" --episodes "$EPISODES"
fi

[[ -z ${SKIP_DATAGEN:-} ]] || exit 0

# run NAME EXTRA...: one datagen run; prints wall time and successful episodes per hour.
run() {
  local name=$1
  shift
  [[ $RUNS == *" $name "* ]] || return 0
  local t0 t1
  t0=$(date +%s.%N)
  "$CLI" datagen examples/custom_assets/datagen.yaml -q --gl "$GL" --seed 1 --workers "$WORKERS" \
    --episodes "$RUN_EPISODES" --output "$TMP/$name" \
    --set task_sampler_config.episodes_per_batch=1 "$@" > "$TMP/$name.log"
  t1=$(date +%s.%N)
  local ok
  ok=$(grep -c '"outcome":"success"' "$TMP/$name"/journal*.jsonl || true)
  awk -v n="$name" -v w="$WORKERS" -v t0="$t0" -v t1="$t1" -v ok="$ok" 'BEGIN {
    d = t1 - t0
    printf "%-12s workers %d  %6.1f s  %d successful  %8.0f successful episodes/h (%.0f per worker)\n",
           n, w, d, ok, 3600 * ok / d, 3600 * ok / d / w }' | tee -a "$TMP/rates"
}

echo "== mlspaces datagen, tutorial, $RUN_EPISODES episodes, $WORKERS workers ($GL)"
run default
run no_points --set camera_config.object_image_points=false
run exact_sides --set camera_config.coarse_sides=false
run trilinear --set camera_config.nearest_mipmap=false
run multipass --set camera_config.one_pass_shadows=false
run unfitted --set camera_config.one_pass_shadows=false --set camera_config.fit_shadows=false \
  --set camera_config.shadow_size=2048
run full --set camera_config.shadow_size=0 --set camera_config.multisamples=-1 \
  --set camera_config.fit_shadows=false --set camera_config.one_pass_shadows=false
run no_cameras --set task_config.enable_rendering=false

# Within one run the machine's speed cancels: each setting's rate against full quality's (the
# original's settings), the figure to compare across machines and hours.
if [[ -s $TMP/rates ]] && grep -q '^full ' "$TMP/rates"; then
  # A rate line: NAME workers W SECONDS s OK successful RATE successful episodes/h (...).
  awk '{ name[NR] = $1; rate[$1] = $8 } END {
    printf "== episodes/h against full quality, in this run:"
    for (i = 1; i <= NR; ++i) {
      if (name[i] != "full" && rate["full"] > 0) printf " %s %.1fx", name[i], rate[name[i]] / rate["full"]
    }
    printf "\n" }' "$TMP/rates"
fi
