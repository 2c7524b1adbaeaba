#!/usr/bin/env bash
# A separate venv with LeRobot 0.4.x from PyPI and only what its dataset loader imports
# (LeRobotDataset: datasets, torch, torchvision, PyAV, pandas, ...), for checking exported
# datasets with LeRobot's own loader (bench/lerobot/load_check.py, docs/lerobot.md).
# lerobot goes in with --no-deps: its other dependencies (wandb, diffusers, rerun, opencv,
# pynput, ...) are for training and robots, not for loading. PyPI's torch wheel for Linux
# pulls NVIDIA's CUDA runtime wheels (~3 GB); a CPU-only torch is not on PyPI.
#   bench/lerobot/make_venv.sh [VENV_DIR]      (default: build/lerobot-venv)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
VENV="${1:-$ROOT/build/lerobot-venv}"
PY="${PYTHON:-python3}"
[ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV"
PIP=("$VENV/bin/python" -m pip install -q --disable-pip-version-check)
"${PIP[@]}" --no-deps lerobot==0.4.2
"${PIP[@]}" torch==2.7.1 torchvision==0.22.1 "datasets==4.1.1" "huggingface-hub==0.35.3" \
  "av==15.1.0" "draccus==0.10.0" pandas pillow "numpy<2.3" packaging jsonlines termcolor \
  einops "deepdiff<9" "packaging<26" "accelerate==1.10.1" h5py "pyarrow==22.0.0"
"$VENV/bin/python" -c "import lerobot, torch; print('lerobot', lerobot.__version__ if hasattr(lerobot, '__version__') else '0.4.2', 'torch', torch.__version__)"
