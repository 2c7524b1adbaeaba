#!/usr/bin/env bash
# The GPU render benchmark in one call on a bare device machine (issue 33, point 2). Pack here
# first (bench/gpu/pack.sh), then, through the device tool:
#   run(command="bash bench/gpu/device.sh", carry=[".gpu", ".gl"], timeout_s=600)
# It prints, and writes to $OUT/render_gpu.txt (or ./render_gpu.txt without $OUT):
#   - the GPU and the EGL devices;
#   - the render curve on the EGL device (ms/frame, frames/s, SSIM against full quality);
#   - `mlspaces datagen` on the tutorial: successful camera episodes/h at the defaults with
#     WORKER_COUNTS workers (default "1 8 16"), and at the largest count MuJoCo's passes,
#     unfitted maps, full quality and no cameras.
# Sizes (env): EPISODES (curve, 2), RUN_EPISODES (datagen at the largest count, 128),
# SECTION_S (each section's time limit, 150 s; twice that at the largest count): about 5 minutes on an H100 in all.
# Locally (no dpkg, Mesa's EGL device): NO_DPKG=1 GL=egl bash bench/gpu/device.sh
set -uo pipefail
cd "$(dirname "$0")/../.."
REPO=$PWD
RESULT=${OUT:-$REPO}/render_gpu.txt
exec > >(tee "$RESULT") 2>&1

if [[ -z ${NO_DPKG:-} ]]; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
nvidia=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
if [[ -f $nvidia && -z ${__EGL_VENDOR_LIBRARY_FILENAMES:-} ]]; then
  export __EGL_VENDOR_LIBRARY_FILENAMES=$nvidia
fi
PKG=$(mktemp -d)
tar -C "$PKG" -xJf .gpu/bundle.tar.xz || { echo "device: cannot unpack .gpu/bundle.tar.xz"; exit 2; }
mkdir -p "$PKG/build/apps/mlspaces" "$PKG/build/bench"
ln -s "$PKG/bin/mlspaces" "$PKG/build/apps/mlspaces/mlspaces"
ln -s "$PKG/bin/datagen_render_quality_bench" "$PKG/build/bench/datagen_render_quality_bench"
export LD_LIBRARY_PATH=$PKG/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export MLSPACES_ROBOTS_DIR=$REPO/assets/robots
export GL=${GL:-egl}
SECTION_S=${SECTION_S:-150}
COUNTS=(${WORKER_COUNTS:-1 8 16})
MAX=${COUNTS[-1]}

echo "== machine: $(nproc) cores; $(date -u +%FT%TZ); commit $(git rev-parse --short HEAD 2>/dev/null || echo ?)"
nvidia-smi -L 2>/dev/null || echo "(no nvidia-smi)"
echo "== EGL devices (an out-of-range device lists them)"
MLSPACES_EGL_DEVICE=99 "$PKG/bin/mlspaces" datagen examples/custom_assets/datagen.yaml -q \
  --gl egl --episodes 1 --workers 1 --output "$PKG/probe" 2>&1 | tail -1

echo "== render curve"
SKIP_DATAGEN=1 EPISODES=${EPISODES:-2} timeout "$SECTION_S" bench/render_bench.sh "$PKG/build" ||
  echo "(curve: rc $?)"
for w in "${COUNTS[@]}"; do
  if [[ $w == "$MAX" ]]; then
    runs="default multipass unfitted full no_cameras" n=${RUN_EPISODES:-128} t=$((2 * SECTION_S))
  else
    runs=default n=$((w * 8)) t=$SECTION_S
  fi
  RUNS=$runs SKIP_CURVE=1 WORKERS=$w RUN_EPISODES=$n timeout "$t" \
    bench/render_bench.sh "$PKG/build" || echo "(datagen with $w workers: rc $?)"
done
echo "device: done; results in $RESULT"
