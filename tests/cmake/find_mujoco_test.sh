#!/usr/bin/env bash
# ctest `find_mujoco_versions`: cmake/FindMuJoCo.cmake accepts the pinned MuJoCo 3 of the venv
# and refuses, at configure time and in one line, a MuJoCo 2.x (Debian's 2.2.2 header) or an
# untested major version (4.0, which PyPI serves too), each in a fake MUJOCO_DIR prefix; a
# prefix without MuJoCo is a one-line error too.
#   find_mujoco_test.sh SOURCE_DIR WORK_DIR PYTHON
set -euo pipefail
SOURCE="$(realpath "$1")" WORK="$2" PYTHON="$3"
rm -rf "$WORK" && mkdir -p "$WORK"
fail() { echo "find_mujoco_test: $*" >&2; exit 1; }

probe() {  # probe NAME [cmake args...]: configure the probe project; output in $WORK/NAME.log
  local name="$1"; shift
  cmake -S "$SOURCE/tests/cmake/find_mujoco" -B "$WORK/$name" -DMLSPACES_SOURCE_DIR="$SOURCE" \
    "$@" >"$WORK/$name.log" 2>&1
}
fake_prefix() {  # fake_prefix DIR VERSION_HEADER: include/mujoco/mujoco.h + lib/libmujoco.so
  mkdir -p "$1/include/mujoco" "$1/lib"
  printf '#pragma once\n#define mjVERSION_HEADER %s\n' "$2" >"$1/include/mujoco/mujoco.h"
  : >"$1/lib/libmujoco.so.x"
}
expect_refusal() {  # expect_refusal NAME MESSAGE
  grep -qF -- "$2" "$WORK/$1.log" || { cat "$WORK/$1.log"; fail "$1: no '$2'"; }
}

probe venv -DMLSPACES_PYTHON="$PYTHON" || { cat "$WORK/venv.log"; fail "the venv's MuJoCo is refused"; }
pinned="$(grep -E '^mujoco==' "$SOURCE/requirements.txt" | cut -d= -f3)"
grep -qF "probe: MuJoCo $pinned at " "$WORK/venv.log" || { cat "$WORK/venv.log"; fail "not $pinned"; }

fake_prefix "$WORK/mujoco222" 222
if probe old -DMUJOCO_DIR="$WORK/mujoco222"; then fail "MuJoCo 2.2.2 was accepted"; fi
expect_refusal old "MuJoCo 2.2.2 found in MUJOCO_DIR=$WORK/mujoco222: mlspaces needs MuJoCo 3.x (pinned in requirements.txt)"

fake_prefix "$WORK/mujoco400" 4000000
if probe new -DMUJOCO_DIR="$WORK/mujoco400"; then fail "MuJoCo 4.0.0 was accepted"; fi
expect_refusal new "MuJoCo 4.0.0 found in MUJOCO_DIR=$WORK/mujoco400: mlspaces needs MuJoCo 3.x"

mkdir -p "$WORK/empty"
if probe empty -DMUJOCO_DIR="$WORK/empty"; then fail "an empty prefix was accepted"; fi
expect_refusal empty "MuJoCo: no include/mujoco/mujoco.h or libmujoco.so in MUJOCO_DIR=$WORK/empty"
echo "find_mujoco_test: pinned $pinned accepted; 2.2.2, 4.0.0 and an empty prefix refused"
