#!/usr/bin/env bash
# README command 1: install what is missing, build, and run the main job on the bundled
# example (examples/custom_assets, the seed tutorial): index the asset and grasp libraries,
# validate them, look the red block's asset, metadata and grasps up, publish the library as a
# package and install the red block from it (file:// remote), then generate pick
# demonstrations with camera videos from the tutorial's datagen config, validate the dataset
# and load it with h5py; then run the tutorial's datagen.py with `python -m mlspaces.datagen`,
# generate grasps for the red block and the example cabinet's joints, open and close the
# cabinet's drawer and door (examples/open_close), pick and place the block into a receptacle
# and next to the bowl (examples/pick_and_place), and show a broken grasp file stopping a run
# before it simulates.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/install-deps.sh"
"$ROOT/scripts/build.sh"
ML="$ROOT/build/apps/mlspaces/mlspaces"
PY="$ROOT/.venv/bin/python"   # the project venv (numpy, h5py), made by install-deps.sh
EX="$ROOT/examples/custom_assets"
OUT="${MLSPACES_DEMO_OUT:-$ROOT/build/demo}"
rm -rf "$OUT" && mkdir -p "$OUT" && cp -r "$EX"/. "$OUT"/
cd "$OUT"
set -x
"$ML" index-assets asset_library --compute-metadata --overwrite
"$ML" index-grasps asset_library --overwrite
"$ML" validate asset_library
# The same two steps as the tutorial writes them (MolmoSpaces' module names, the import renamed):
# the same code as index-assets / index-grasps.
PYTHONPATH="$ROOT/build/python" "$PY" -m mlspaces.resources.generate_user_asset_library_index \
  asset_library --compute-metadata --overwrite
PYTHONPATH="$ROOT/build/python" "$PY" -m mlspaces.resources.generate_user_grasp_library_index \
  asset_library --overwrite
"$ML" inspect scene.xml
"$ML" locate red_block --libraries libraries.yaml
"$ML" meta red_block --libraries libraries.yaml
"$ML" grasps red_block --libraries libraries.yaml --robot droid --num 1 --out red_block_grasps.npz
"$PY" -c "import numpy as np; print(np.load('red_block_grasps.npz')['transforms'])"
# Publish the library as a versioned package, serve it as a file:// remote, install the red
# block (and its grasps) into a private cache and assets dir, and look it up from there.
"$ML" pack asset_library remote --name custom_assets --version 1 -q
export MLSPACES_CACHE_DIR="$OUT/cache" MLSPACES_ASSETS_DIR="$OUT/assets"
export MLSPACES_REMOTE_URL="file://$OUT/remote" MLSPACES_PINNED_ASSETS_FILE=
"$ML" install red_block -q
"$ML" verify custom_assets
"$ML" locate red_block
"$ML" grasps red_block --num 1
unset MLSPACES_CACHE_DIR MLSPACES_ASSETS_DIR MLSPACES_REMOTE_URL MLSPACES_PINNED_ASSETS_FILE
"$ML" config datagen.yaml > resolved_datagen_config.yaml
head -5 resolved_datagen_config.yaml
# Pictures (docs/render.md): a contact sheet of the example library, the red block's grasps
# drawn as gripper outlines, the scene as the data engine composes it.
"$ML" render assets --libraries libraries.yaml --out pictures/assets.png -q
"$ML" render grasps red_block --libraries libraries.yaml --out pictures/grasps.png -q
"$ML" render scene datagen.yaml --out pictures/scene.png -q
# The tutorial's last step: pick demonstrations of the Franka DROID robot, with the wrist and
# exo camera videos, then a full check of the dataset (schema, videos, metadata).
"$ML" datagen datagen.yaml --output experiment_output --seed 0 --episodes 3
"$ML" validate-dataset experiment_output
"$ML" render episode experiment_output --episode 0 --out pictures/episode_0.png -q
"$PY" - <<'PY'
import h5py, json
f = h5py.File("experiment_output/house_0/trajectories_batch_1_of_1.h5", "r")
for k in sorted(f):
    t = f[k]
    videos = [bytes(t["obs/sensor_data"][c][:]).rstrip(b"\0").decode() for c in t["obs/sensor_data"]]
    print(k, "steps", t["success"].shape[0], "success", bool(t["success"][-1]),
          "lift %.3f m" % t["rewards"][-1], "videos", videos)
PY
# The same dataset as a LeRobot v3 dataset (docs/lerobot.md): parquet + the camera videos
# re-muxed, many episodes per file; LeRobotDataset(repo_id, root=...) loads it.
"$ML" export-lerobot experiment_output experiment_lerobot -q
"$PY" -c "import json, pyarrow.parquet as pq; i = json.load(open('experiment_lerobot/meta/info.json')); t = pq.read_table('experiment_lerobot/data/chunk-000/file-000.parquet'); print(i['codebase_version'], i['total_episodes'], 'episodes', i['total_frames'], 'frames', t.num_rows, 'rows', sorted(k for k in i['features'] if k.startswith(('observation', 'action'))))"
# The data engine writes the same LeRobot dataset directly (no HDF5 run in between): the
# same bytes as the export, but for the run's own timings under meta/mlspaces/run.
"$ML" datagen datagen.yaml --format lerobot --output experiment_lerobot_direct --seed 0 \
  --episodes 3 -q
diff -r -x run experiment_lerobot experiment_lerobot_direct
# Robots are data (docs/robots.md): check and measure the second robot, a UFactory xArm7 built
# from its published DH table, then run the same tutorial config with it, changing only the
# robot's name (its aliases map the DROID camera names to its own).
"$ML" inspect-robot xarm7
"$ML" datagen datagen.yaml --set robot_config.name=xarm7 --output xarm7_output --seed 0 --episodes 2
"$ML" validate-dataset xarm7_output
"$PY" -c "import h5py, json; f = h5py.File('xarm7_output/house_0/trajectories_batch_1_of_1.h5'); print({k: (json.loads(f[k].attrs['provenance'])['robot'], bool(f[k]['success'][-1])) for k in sorted(f)})"
# Grasps for any mesh (docs/graspgen.md): generate the red block's grasps with the
# franka_droid gripper (candidates on its collision geometry, each tested in MuJoCo: approach,
# close, twist and shake, no slip), replacing the tutorial's hand-written one, and pick with
# only those; then joint grasps for the example cabinet's drawer and door.
mkdir -p generated && cp -r asset_library scene.xml scene_metadata.json datagen.yaml generated/
"$ML" generate-grasps generated/asset_library --uid red_block --max-grasps 50 --overwrite -q
"$ML" datagen generated/datagen.yaml --output generated/run --seed 0 --episodes 2 -q \
  --set task_config.enable_rendering=false
"$ML" validate-dataset generated/run
# The xArm7's own gripper (read off its robot.yaml and MJCF): its grasps go to red_block/xarm7/,
# and the xArm7 picks with only those (the grasp library "<name>/<robot>").
"$ML" generate-grasps generated/asset_library --uid red_block --robot xarm7 --max-grasps 50 -q
"$ML" datagen generated/datagen.yaml --output generated/xarm7_run --seed 0 --episodes 2 -q \
  --set robot_config.name=xarm7 --set 'policy_config.grasp_libraries=[custom_grasps/xarm7]' \
  --set task_config.enable_rendering=false
"$ML" validate-dataset generated/xarm7_run
"$ML" generate-grasps "$ROOT/examples/objects" --joints --max-grasps 10 -o cabinet_grasps
"$PY" -c "import numpy as np, glob; [print(f, np.load(f)['transforms'].shape) for f in sorted(glob.glob('cabinet_grasps/*/droid/*.npz'))]"
# Open and close the example cabinet's drawer or door with its joint grasps (docs/tasks.md):
# two episodes of each task (seed 3: the drawer, then the door), cameras off, then the dataset
# check and the recorded joint.
"$ML" datagen "$ROOT/examples/open_close/datagen_open.yaml" --output open_output --seed 3 \
  --episodes 2 -q --set task_config.enable_rendering=false
"$ML" datagen "$ROOT/examples/open_close/datagen_close.yaml" --output close_output --seed 3 \
  --episodes 2 -q --set task_config.enable_rendering=false
"$ML" validate-dataset open_output
"$ML" validate-dataset close_output
"$PY" - <<'PY'
import h5py, json
for run in ("open_output", "close_output"):
    f = h5py.File(run + "/house_0/trajectories_batch_1_of_1.h5", "r")
    for k in sorted(f):
        scene = json.loads(f[k]["obs_scene"][()])
        print(run, k, repr(scene["task_description"]), scene["joint"]["joint_name"],
              "opened %.2f" % f[k]["obs/extra/joint_opened_fraction"][-1],
              "success", bool(f[k]["success"][-1]))
PY
# Pick up the block and place it into or onto a receptacle (tray, bowl: examples/objects),
# then next to the bowl (docs/tasks.md): two episodes each, cameras off, the dataset check and
# the recorded descriptions.
"$ML" datagen "$ROOT/examples/pick_and_place/datagen.yaml" --output place_output --seed 1 \
  --episodes 2 -q --set task_config.enable_rendering=false
"$ML" datagen "$ROOT/examples/pick_and_place/datagen_next_to.yaml" --output next_to_output \
  --seed 1 --episodes 2 -q --set task_config.enable_rendering=false
"$ML" validate-dataset place_output
"$ML" validate-dataset next_to_output
"$PY" - <<'PY'
import h5py, json
for run in ("place_output", "next_to_output"):
    f = h5py.File(run + "/house_0/trajectories_batch_1_of_1.h5", "r")
    for k in sorted(f):
        scene = json.loads(f[k]["obs_scene"][()])
        print(run, k, repr(scene["task_description"]), scene["place_receptacle_name"],
              "success", bool(f[k]["success"][-1]))
PY
# The same tutorial step as MolmoSpaces users run it: datagen.py (the seed tutorial's code,
# imports renamed to mlspaces) through the Python package the build made (build/python).
PYTHONPATH="$ROOT/build/python" "$PY" -m mlspaces.datagen datagen:CustomAssetsDataGenConfig \
  --output python_output --seed 0 -q
"$ML" validate-dataset python_output
# Broken input is never a "successful" run: a NaN in the grasp file stops datagen before it
# simulates anything, with one line naming the file and the field (exit 1).
mkdir -p broken && cp -r asset_library scene.xml scene_metadata.json datagen.yaml broken/
"$PY" -c "import numpy as np; g = np.load('broken/asset_library/red_block/droid/grasps.npz')['transforms'].copy(); g[0, 0, 3] = np.nan; np.savez('broken/asset_library/red_block/droid/grasps.npz', transforms=g)"
if "$ML" datagen broken/datagen.yaml --output broken/run -q; then
  echo "demo: datagen accepted a grasp file with a NaN" >&2
  exit 1
fi
# MolmoSpaces' own data (built-in remotes, objathor metadata, CLIP search, licences). The
# public bucket is not reachable from here, so the test generator writes a small remote in the
# same format (objects, grasps, scenes, robots, benchmarks, objathor metadata with CLIP
# features) and it is installed over file:// as from the real one: a scene archive, then the
# objects and grasps it references; then lookups, the objathor annotation, a "more like this"
# CLIP search, a word search and licences, from the CLI and from Python.
"$PY" "$ROOT/tests/fixtures/make_molmo_remote.py" builtin --objaverse 20 > /dev/null
export MLSPACES_CACHE_DIR="$OUT/builtin/cache" MLSPACES_ASSETS_DIR="$OUT/builtin/assets"
export MLSPACES_REMOTE_URL="file://$OUT/builtin/remote" MLSPACES_PINNED_ASSETS_FILE="$OUT/builtin/pins.json"
"$ML" install --scene 1 -q
"$ML" verify
MUG="$("$PY" -c "import json; print(json.load(open('builtin/fixture.json'))['scenes']['ithor']['FloorPlan1']['references'][3]['path'].split('/')[0])")"
"$ML" locate "$MUG"
"$ML" meta "$MUG" > builtin/meta.json && head -12 builtin/meta.json
"$ML" search --uid "$MUG" --top-k 5
"$ML" search --text "bowl" --top-k 3
"$ML" license "$MUG" Bowl_1
"$ML" grasps Fridge_1 --joint door_hinge --num 1
PYTHONPATH="$ROOT/build/python" "$PY" - "$MUG" <<'PY'
import sys
from mlspaces.utils.object_metadata import ObjectMeta
from mlspaces.utils.object_retriever import ObjectRetriever
from mlspaces.utils.license_utils import resolve_license
uid = sys.argv[1]
print(uid, ObjectMeta.short_descriptions(uid), ObjectMeta.img_features([uid]).shape)
query = ObjectMeta.description_text_features([uid])[0]
uids, sims = ObjectRetriever(max_results=3).query(query)
print("more like this:", list(zip(uids, [round(float(s), 3) for s in sims])))
print("licence:", resolve_license("objects", "objaverse", uid)["license"])
PY
unset MLSPACES_CACHE_DIR MLSPACES_ASSETS_DIR MLSPACES_REMOTE_URL MLSPACES_PINNED_ASSETS_FILE
set +x
echo
echo "Pick demonstrations: $OUT/experiment_output (CLI) and $OUT/python_output (datagen.py)"
echo "  house_0/trajectories_batch_1_of_1.h5 (h5py), house_0/episode_*.mp4, journal.jsonl, summary.txt"
echo "Pictures (mlspaces render): $OUT/pictures/{assets,grasps,scene,episode_0}.png"
