#!/usr/bin/env bash
# ctest `python_wheel`: builds the mlspaces wheel with pip (scikit-build-core, pyproject.toml),
# installs it into a fresh venv with nothing else of this checkout, and uses it there: the
# library API on the tutorial library, the real `mujoco` module beside it (one libmujoco, the
# fresh venv's), and the `mlspaces` command.
#
# To not compile the layers a second time, the wheel's extension is built against this build
# installed into a temporary prefix (-DMLSPACES_PYTHON_PREBUILT, python/CMakeLists.txt); a plain
# `pip install .` builds everything. The fresh venv installs offline, from the wheelhouse
# scripts/install-deps.sh fills with the package's pinned runtime dependencies.
#   wheel_test.sh BUILD_DIR SOURCE_DIR WORK_DIR PYTHON (the project venv's python)
set -euo pipefail
BUILD="$(realpath "$1")" SOURCE="$(realpath "$2")" WORK="$3" PYTHON="$4"
rm -rf "$WORK" && mkdir -p "$WORK"
WORK="$(realpath "$WORK")"
WHEELHOUSE="$(dirname "$PYTHON")/../wheelhouse"
fail() { echo "wheel_test: $*" >&2; exit 1; }
[[ -d "$WHEELHOUSE" ]] || fail "no wheelhouse at $WHEELHOUSE: run scripts/install-deps.sh"

cmake --install "$BUILD" --prefix "$WORK/prefix" >"$WORK/install.log" || {
  cat "$WORK/install.log"; fail "cmake --install failed"; }
"$PYTHON" -m pip wheel "$SOURCE" --no-build-isolation --no-deps -q -w "$WORK/dist" \
  -C "cmake.define.MLSPACES_PYTHON_PREBUILT=$WORK/prefix" -C "build-dir=$WORK/wheel-build" \
  >"$WORK/wheel.log" 2>&1 || { tail -50 "$WORK/wheel.log"; fail "pip wheel failed"; }
wheel=$(ls "$WORK"/dist/mlspaces-*.whl) || fail "no wheel in $WORK/dist"
"$PYTHON" - "$wheel" <<'PY' || fail "the wheel lacks the extension or the CLI"
import sys, zipfile
names = zipfile.ZipFile(sys.argv[1]).namelist()
assert any(n.startswith("mlspaces/_core") for n in names), names
assert "mlspaces/bin/mlspaces" in names, names
PY

base=$("$PYTHON" -c "import sys; print(sys._base_executable)")
"$base" -m venv "$WORK/venv"
"$WORK/venv/bin/pip" install -q --disable-pip-version-check --no-index \
  --find-links "$WHEELHOUSE" "$wheel" >"$WORK/pip.log" 2>&1 || {
  cat "$WORK/pip.log"; fail "pip install of the wheel into a fresh venv failed"; }

cd "$WORK"  # not the source tree: the installed package only
"$WORK/venv/bin/python" - "$SOURCE/examples/custom_assets/asset_library" "$WORK/venv" <<'PY'
import sys
from pathlib import Path

import mujoco
import numpy as np
import mlspaces
from mlspaces.molmo_spaces_constants import (register_user_asset_library,
                                             register_user_grasp_library)
from mlspaces.utils.grasps import load_pickup_grasps

lib, venv = Path(sys.argv[1]), Path(sys.argv[2]).resolve()
assert Path(mlspaces.__file__).resolve().is_relative_to(venv), mlspaces.__file__
register_user_asset_library("custom_assets", lib)
register_user_grasp_library("custom_grasps", lib, "custom_assets")
grasps = load_pickup_grasps("red_block")
np.testing.assert_array_equal(grasps, np.load(lib / "red_block/droid/grasps.npz")["transforms"])
xml = mlspaces.locate_uid_package("red_block")[2]
model = mujoco.MjModel.from_xml_path(str(xml))
assert model.nbody == 2
maps = {line.split()[-1] for line in open("/proc/self/maps") if "libmujoco" in line}
assert len(maps) == 1 and Path(maps.pop()).resolve().is_relative_to(venv), maps
print("wheel_test: import, lookups and mujoco OK in", venv)
PY
out=$("$WORK/venv/bin/mlspaces" --version) || fail "the mlspaces command does not run"
echo "wheel_test: mlspaces --version: $out"
grep -q "libmujoco" <(ldd "$WORK"/venv/lib/python3*/site-packages/mlspaces/bin/mlspaces |
  grep "$WORK/venv") || fail "the installed CLI does not use the venv's libmujoco"
