#!/usr/bin/env bash
# export-lerobot figures (docs/lerobot.md): export throughput (frames/s, episodes/s) with
# --codec copy (re-mux), h264 and av1 (re-encode), and the size on disk of the LeRobot dataset
# against the HDF5 + MP4 dataset it came from.
#
#   bench/lerobot_bench.sh [BUILD_DIR] [EPISODES] [RUN_DIR]
#
# Defaults: build/, 12 episodes of the tutorial config with both DROID cameras at 640x368
# (shadows and reflections off, to keep the datagen part short), written to a temp folder;
# RUN_DIR: export that existing run folder instead. Each export runs 3 times; the median counts.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
episodes="${2:-12}"
cli="$build/apps/mlspaces/mlspaces"
[[ -x "$cli" ]] || { echo "lerobot_bench: missing $cli (build it first)" >&2; exit 1; }
"$cli" export-lerobot --help > /dev/null 2>&1 ||
  { echo "lerobot_bench: $cli has no export-lerobot (built without Arrow C++)" >&2; exit 1; }
work="$(mktemp -d "${TMPDIR:-/tmp}/mlspaces_lerobot_XXXXXX")"
trap 'rm -rf "$work"' EXIT
run="${3:-}"
if [[ -z "$run" ]]; then
  run="$work/run"
  "$cli" datagen "$root/examples/custom_assets/datagen.yaml" -q --seed 5 --episodes "$episodes" \
    --set camera_config.shadows=false --set camera_config.reflections=false --output "$run" \
    > /dev/null
fi

py="$root/.venv/bin/python"
export_secs() {  # codec -> median wall seconds of 3 exports
  local codec="$1" times=()
  for i in 1 2 3; do
    rm -rf "$work/out_$codec"
    local t0 t1
    t0=$(date +%s.%N)
    "$cli" export-lerobot "$run" "$work/out_$codec" --codec "$codec" -q > /dev/null
    t1=$(date +%s.%N)
    times+=("$("$py" -c "print($t1 - $t0)")")
  done
  "$py" -c "import statistics, sys; print(statistics.median(map(float, sys.argv[1:])))" "${times[@]}"
}
copy=$(export_secs copy)
h264=$(export_secs h264)
av1=$(export_secs av1)
info="$work/out_copy/meta/info.json"
read -r eps frames < <("$py" -c "import json,sys; i=json.load(open(sys.argv[1])); print(i['total_episodes'], i['total_frames'])" "$info")
cams=$("$py" -c "import json,sys; f=json.load(open(sys.argv[1]))['features']; print(','.join(k for k in f if f[k]['dtype']=='video'))" "$info")
size() { du -sb "$@" | awk '{s+=$1} END {print s}'; }
h5=$(size "$run"/house_*/*.h5)
mp4=$(size "$run"/house_*/*.mp4)
side=$(size "$work/out_copy/meta/mlspaces")  # import-lerobot's copy of the HDF5 episodes
pq=$(( $(size "$work/out_copy/data" "$work/out_copy/meta") - side ))
vid=$(size "$work/out_copy/videos")
vid264=$(size "$work/out_h264/videos")
vidav1=$(size "$work/out_av1/videos")
printf 'export-lerobot, %d episodes, %d frames, cameras %s, %d cores\n' "$eps" "$frames" "$cams" "$(nproc)"
"$py" - "$copy" "$h264" "$av1" "$eps" "$frames" "$h5" "$mp4" "$pq" "$vid" "$vid264" "$vidav1" "$side" <<'PY'
import sys
copy, h264, av1 = map(float, sys.argv[1:4])
eps, frames, h5, mp4, pq, vid, vid264, vidav1, side = map(int, sys.argv[4:])
mb = lambda b: b / 1e6  # noqa: E731
print(f"{'codec':<8} {'seconds':>8} {'frames/s':>10} {'episodes/s':>11}")
for name, s in (("copy", copy), ("h264", h264), ("av1", av1)):
    print(f"{name:<8} {s:8.2f} {frames / s:10.0f} {eps / s:11.1f}")
print(f"size on disk (MB): mlspaces HDF5 {mb(h5):.2f} + MP4 {mb(mp4):.2f} = {mb(h5 + mp4):.2f}; "
      f"LeRobot parquet+meta {mb(pq):.2f} + videos {mb(vid):.2f} = {mb(pq + vid):.2f} "
      f"({(pq + vid) / (h5 + mp4):.2f}x); videos with --codec h264 {mb(vid264):.2f}, "
      f"--codec av1 {mb(vidav1):.2f}; meta/mlspaces (for import-lerobot; "
      f"--no-mlspaces-meta leaves it out) {mb(side):.2f}")
PY
