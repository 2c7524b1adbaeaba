#!/usr/bin/env bash
# README command 1: install what is missing, build, and run the main job on the bundled
# example (examples/custom_assets, the seed tutorial): index the asset and grasp libraries,
# validate them, and look the red block's asset, metadata and grasps up.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/install-deps.sh"
"$ROOT/scripts/build.sh"
ML="$ROOT/build/apps/mlspaces/mlspaces"
EX="$ROOT/examples/custom_assets"
OUT="${MLSPACES_DEMO_OUT:-$ROOT/build/demo}"
rm -rf "$OUT" && mkdir -p "$OUT" && cp -r "$EX"/. "$OUT"/
cd "$OUT"
set -x
"$ML" index-assets asset_library --compute-metadata --overwrite
"$ML" index-grasps asset_library --overwrite
"$ML" validate asset_library
"$ML" inspect scene.xml
"$ML" locate red_block --libraries libraries.yaml
"$ML" meta red_block --libraries libraries.yaml
"$ML" grasps red_block --libraries libraries.yaml --robot droid --num 1 --out red_block_grasps.npz
/usr/bin/python3 -c "import numpy as np; print(np.load('red_block_grasps.npz')['transforms'])"
"$ML" config datagen.yaml > resolved_datagen_config.yaml
head -5 resolved_datagen_config.yaml
