#!/usr/bin/env bash
# Why nanobind: the call overhead of the library API's call shapes (no-op, str -> tuple,
# str -> small dict) bound with nanobind (the project's pin) and with pybind11, both built at -O2
# into build/binding-bench and timed in one run (medians of 9 rounds). Needs the project venv
# (scripts/install-deps.sh); pybind11 is pip-installed into the bench folder, not the venv.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY="$ROOT/.venv/bin/python"
OUT="$ROOT/build/binding-bench"
SRC="$ROOT/bench/binding_overhead"
mkdir -p "$OUT"
[[ -d "$OUT/pybind11" ]] || "$PY" -m pip install -q --target "$OUT/pybind11" pybind11==3.0.1
PYINC=$("$PY" -c "import sysconfig; print(sysconfig.get_paths()['include'])")
SUFFIX=$("$PY" -c "import sysconfig; print(sysconfig.get_config_var('EXT_SUFFIX'))")
NB=$("$PY" -c "import nanobind, os; print(os.path.dirname(nanobind.__file__))")
FLAGS=(-O2 -DNDEBUG -std=c++17 -shared -fPIC -fvisibility=hidden -I"$PYINC" -I"$SRC")
c++ "${FLAGS[@]}" -I"$NB/include" -I"$NB/ext/robin_map/include" \
  "$SRC/nb_module.cc" "$NB/src/nb_combined.cpp" -o "$OUT/nb_lookup$SUFFIX"
c++ "${FLAGS[@]}" -I"$OUT/pybind11/pybind11/include" "$SRC/pb_module.cc" -o "$OUT/pb_lookup$SUFFIX"
"$PY" "$SRC/measure.py" "$OUT"
