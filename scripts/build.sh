#!/usr/bin/env bash
# Configures and builds mlspaces into build/ (-O2 with line tables: -g1 is enough for
# backtraces, and compiles and links a third faster than full -g; configure a Debug build of
# your own for a debugger). Extra args go to cmake.
#   MLSPACES_BUILD_DIR=DIR           another build folder
#   MLSPACES_BUILD_TARGETS='REGEX'   build only the targets whose names match (grep -E, whole
#                                    name) and what they depend on, e.g. the test executables
#                                    of some layers (scripts/test.sh's sanitizer stage)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${MLSPACES_BUILD_DIR:-$ROOT/build}"
cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" "$@" >/dev/null
targets=()
if [[ -n "${MLSPACES_BUILD_TARGETS:-}" ]]; then
  mapfile -t targets < <(ninja -C "$BUILD" -t targets all |
    sed -n -E 's/^([A-Za-z0-9_.+-]+): phony$/\1/p' | grep -E -x -- "$MLSPACES_BUILD_TARGETS" | sort -u)
  if ((${#targets[@]} == 0)); then
    echo "build: no target matches MLSPACES_BUILD_TARGETS='$MLSPACES_BUILD_TARGETS'" >&2
    exit 2
  fi
  cmake --build "$BUILD" -j "$(nproc)" --target "${targets[@]}"
else
  cmake --build "$BUILD" -j "$(nproc)"
fi
