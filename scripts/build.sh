#!/usr/bin/env bash
# Configures and builds mlspaces into build/ (-O2 with line tables: -g1 is enough for
# backtraces, and compiles and links a third faster than full -g; configure a Debug build of
# your own for a debugger). Extra args go to cmake.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${MLSPACES_BUILD_DIR:-$ROOT/build}"
cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" "$@" >/dev/null
cmake --build "$BUILD" -j "$(nproc)"
