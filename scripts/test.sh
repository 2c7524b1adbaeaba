#!/usr/bin/env bash
# README command 2: install what is missing, build, and run every test.
#   1. the full build and all ctest suites;
#   2. the core (parser) and datagen (planner, runner, recorder) suites again under
#      AddressSanitizer + UndefinedBehaviorSanitizer;
#   3. the libFuzzer targets of the binary parsers (NPY/NPZ, MessagePack, packed UID index, the tries and the restricted pickle reader),
#      MLSPACES_FUZZ_SECONDS (default 20) each (scripts/fuzz.sh).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/install-deps.sh"
"$ROOT/scripts/build.sh"
ctest --test-dir "$ROOT/build" --output-on-failure -j "$(nproc)"

echo "== core, robots, graspgen and datagen suites under ASan + UBSan =="
# Only the test executables of the suites run below (and what they need: the CLI, the example
# sampler); the sim and CLI suites are not built here.
MLSPACES_BUILD_DIR="$ROOT/build-asan" \
  MLSPACES_BUILD_TARGETS='(core|library|resources|robots|graspgen|datagen)_[a-z0-9_]+_test' \
  "$ROOT/scripts/build.sh" -DMLSPACES_SANITIZE=ON \
  -DMLSPACES_BUILD_BENCH=OFF -DMLSPACES_BUILD_SIM=ON
(
  # shellcheck source=scripts/sanitizer-env.sh
  source "$ROOT/scripts/sanitizer-env.sh"
  ctest --test-dir "$ROOT/build-asan" --output-on-failure -j "$(nproc)" \
    -L 'core|library|resources|robots|graspgen|datagen'
)

echo "== fuzz targets of the binary parsers =="
"$ROOT/scripts/fuzz.sh" "${MLSPACES_FUZZ_SECONDS:-20}"
