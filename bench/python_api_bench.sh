#!/usr/bin/env bash
# The mlspaces Python API bench (bench/python_api_bench.py): lookups from Python, side by side
# with the original molmo-spaces when its bench venv exists, and the Python datagen front end
# against the CLI. Run from anywhere:
#
#   bench/python_api_bench.sh [--quick] [--splits] [other python_api_bench.py flags]
#   bench/python_api_bench.sh --setup-molmospaces     # make the original's bench venv, then exit
#
# Interpreter: $MLSPACES_BENCH_PYTHON, else the project venv (.venv/bin/python). mlspaces:
# build/python when it holds the extension (PYTHONPATH), else the interpreter's installed one.
# CLI: $MLSPACES_CLI_PATH, else build/apps/mlspaces/mlspaces, else `mlspaces` on PATH.
#
# The original's venv ($MLSPACES_BENCH_MOLMOSPACES_VENV, default build/bench-venv-molmospaces;
# build/ is git-ignored): molmo-spaces 0.2.9 from PyPI with --no-deps (its full dependency list
# pulls torch 2.7 with its CUDA wheels, torchvision, open_clip, warp-lang, mujoco-warp, wandb,
# tensorboard, boto3, ...: gigabytes none of the measured calls import), plus only what its
# lookup modules import (molmo_spaces.utils.{lazy_loading_utils,object_metadata,
# grasps} and their imports), numpy/scipy/pydantic pinned to the project venv's versions so
# the comparison measures the code, not the libraries.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
py="${MLSPACES_BENCH_PYTHON:-$root/.venv/bin/python}"
venv="${MLSPACES_BENCH_MOLMOSPACES_VENV:-$root/build/bench-venv-molmospaces}"

if [[ "${1:-}" == "--setup-molmospaces" ]]; then
  base="${MLSPACES_BENCH_BASE_PYTHON:-python3}"
  "$base" -c 'import sys; assert sys.version_info >= (3, 11), "molmo-spaces needs Python >= 3.11"'
  "$base" -m venv "$venv"
  pin() { "$py" -c "import importlib.metadata as m; print(m.version('$1'))" 2>/dev/null || true; }
  np_v="$(pin numpy)"; sp_v="$(pin scipy)"; pd_v="$(pin pydantic)"
  "$venv/bin/pip" install -q --no-deps molmo-spaces==0.2.9 molmospaces-resources==0.0.2
  # What `import molmo_spaces.utils.grasps` (and the two other lookup modules) needs, found by
  # importing until nothing was missing. opencv-python-headless provides cv2 (molmo-spaces
  # asks for opencv-python: the same module, without the GUI libraries).
  "$venv/bin/pip" install -q \
    "numpy${np_v:+==$np_v}" "scipy${sp_v:+==$sp_v}" "pydantic${pd_v:+==$pd_v}" \
    "mujoco~=3.5.0" "compress-json>=1.1.1" "packaging~=26.2" filelock "tqdm>=4.65.0" \
    "lmdb~=1.7.5" requests "zstandard~=0.25.0" "lxml>=5.0.0" opencv-python-headless matplotlib
  "$venv/bin/python" -c 'import molmo_spaces.utils.grasps, molmo_spaces.utils.object_metadata'
  echo "molmo-spaces bench venv ready: $venv"
  exit 0
fi

[[ -x "$py" ]] || py="$(command -v python3)"
if compgen -G "$root/build/python/mlspaces/_core*.so" >/dev/null; then
  export PYTHONPATH="$root/build/python${PYTHONPATH:+:$PYTHONPATH}"
fi
if [[ -z "${MLSPACES_BENCH_MOLMOSPACES_PYTHON:-}" && -x "$venv/bin/python" ]]; then
  export MLSPACES_BENCH_MOLMOSPACES_PYTHON="$venv/bin/python"
fi
if [[ -z "${MLSPACES_CLI_PATH:-}" && -x "$root/build/apps/mlspaces/mlspaces" ]]; then
  export MLSPACES_CLI_PATH="$root/build/apps/mlspaces/mlspaces"
fi
exec "$py" "$root/bench/python_api_bench.py" "$@"
