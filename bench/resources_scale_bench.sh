#!/usr/bin/env bash
# Issue 6's scale benchmark: a generated library of 150,000 assets and 5,000,000 grasps is
# indexed, packed, served as a file:// remote, installed whole, and looked up.
#
#   bench/resources_scale_bench.sh [BUILD_DIR] [WORK_DIR] [ASSETS_PER_ARCHIVE]
#
# WORK_DIR (default $TMPDIR/mlspaces_scale_bench) keeps the generated library between runs;
# the package, cache and install are rebuilt each run. Needs ~6 GB of disk.
# Figures: pack time, install time, and from resources_scale_bench: index open, locate
# p50/p99, annotation, 50-grasp loads, resident memory.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
work="${2:-${TMPDIR:-/tmp}/mlspaces_scale_bench}"
per_archive="${3:-100}"
assets="${ASSETS:-150000}"
grasps="${GRASPS:-5000000}"
cli="$build/apps/mlspaces/mlspaces"
bench="$build/bench/resources_scale_bench"
for exe in "$cli" "$bench"; do
  [[ -x "$exe" ]] || { echo "resources_scale_bench: missing $exe (build it first)" >&2; exit 1; }
done
lib="$work/library"

if [[ ! -f "$lib/.complete-$assets-$grasps" ]]; then
  echo "Generating $lib ($assets assets, $grasps grasps)..."
  rm -rf "$lib"
  mkdir -p "$lib"
  "$root/.venv/bin/python" - "$lib" "$assets" "$grasps" <<'PY'
import io, json, os, sys
import numpy as np
lib, n, total = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rng = np.random.default_rng(6)
base, extra = divmod(total, n)
cats = ["mug", "bowl", "apple", "block", "book", "cup", "plate", "vase"]
for i in range(n):
    uid = f"{i:08x}{(i * 2654435761) % 2**32:08x}{(i * 40503) % 2**32:08x}{i % 65536:08x}"
    d = os.path.join(lib, uid[:2], uid)
    os.makedirs(os.path.join(d, "droid"))
    with open(os.path.join(d, uid + ".xml"), "w") as f:
        f.write(f'<mujoco model="{uid}"><worldbody><body name="{uid}"><freejoint/><geom '
                'type="box" size="0.03 0.03 0.03"/></body></worldbody></mujoco>\n')
    meta = {"assetId": uid, "category": cats[i % len(cats)], "isObjaverse": True,
            "description_short": [f"a {cats[i % len(cats)]}"] * 2,
            "boundingBox": {"x": 0.06, "y": 0.06, "z": 0.06}, "mass": 0.2 + (i % 10) / 10}
    with open(os.path.join(d, uid + ".json"), "w") as f:
        json.dump(meta, f, indent=4)
    k = base + (1 if i < extra else 0)
    g = np.tile(np.eye(4), (k, 1, 1))
    g[:, :3, 3] = rng.uniform(-0.05, 0.05, size=(k, 3))
    np.savez(os.path.join(d, "droid", "grasps.npz"), transforms=g)
PY
  touch "$lib/.complete-$assets-$grasps"
fi

rm -rf "$work/remote" "$work/cache" "$work/assets"
echo "== index =="
/usr/bin/time -f "index-assets: %e s wall, %M kB max RSS" "$cli" index-assets "$lib" --overwrite >/dev/null
/usr/bin/time -f "index-grasps: %e s wall, %M kB max RSS" "$cli" index-grasps "$lib" --overwrite >/dev/null
echo "== pack ($per_archive assets per archive, $(nproc) threads) =="
/usr/bin/time -f "pack: %e s wall, %U s user, %M kB max RSS" \
  "$cli" pack "$lib" "$work/remote" --name scale --version 1 --assets-per-archive "$per_archive" -q
du -sh "$work/remote/objects/scale/1" | sed 's/^/package size: /'
ls -l "$work/remote/objects/scale/1/uid_index.mlsx" "$work/remote/objects/scale/1/metadata.mlsm" \
  | awk '{print "store file: " $9 " " $5 " bytes"}'
echo "== install the whole library from a file:// remote =="
export MLSPACES_CACHE_DIR="$work/cache" MLSPACES_ASSETS_DIR="$work/assets"
export MLSPACES_REMOTE_URL="file://$work/remote" MLSPACES_PINNED_ASSETS_FILE=
/usr/bin/time -f "install --library: %e s wall, %M kB max RSS" "$cli" install --library scale -q
/usr/bin/time -f "verify: %e s wall" "$cli" verify scale | tail -1
echo "== lookups =="
"$bench" "$work/assets" scale
