#!/usr/bin/env bash
# Proof that the test suite does not flake under load: builds (as scripts/test.sh does), then
# runs the whole ctest suite ROUNDS times in a row (default 3) with `-j JOBS` (default 4, twice
# this machine's cores) while CPU hogs (default one per core) spin beside it, and finally the
# ASan + UBSan stage of scripts/test.sh once, under the same hogs. Any failure fails the script;
# each round's ctest summary line and time are printed, and a table at the end.
#
#   scripts/stress-tests.sh [--rounds N] [--jobs J] [--hogs H] [--no-asan]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ROUNDS=3
JOBS=4
HOGS="$(nproc)"
ASAN=1
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) ROUNDS="$2"; shift 2 ;;
    --jobs) JOBS="$2"; shift 2 ;;
    --hogs) HOGS="$2"; shift 2 ;;
    --no-asan) ASAN=0; shift ;;
    *) echo "stress-tests: unknown argument '$1' (see the header of $0)" >&2; exit 2 ;;
  esac
done

"$ROOT/scripts/install-deps.sh"
"$ROOT/scripts/build.sh"
if [ "$ASAN" = 1 ]; then
  MLSPACES_BUILD_DIR="$ROOT/build-asan" "$ROOT/scripts/build.sh" -DMLSPACES_SANITIZE=ON \
    -DMLSPACES_BUILD_BENCH=OFF -DMLSPACES_BUILD_SIM=ON
fi

# The hogs: busy shells at normal priority, stopped however this script ends.
hog_pids=()
stop_hogs() { for p in "${hog_pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap stop_hogs EXIT
for _ in $(seq "$HOGS"); do
  bash -c 'while :; do :; done' &
  hog_pids+=("$!")
done
echo "stress-tests: $HOGS CPU hogs running (pids ${hog_pids[*]}) on $(nproc) cores"

LOGS="$ROOT/build/stress-logs"
mkdir -p "$LOGS"
results=()
failed=0
run_stage() {  # name, log file, command...
  local name="$1" log="$2"
  shift 2
  local t0 rc summary
  t0=$(date +%s)
  set +e
  "$@" >"$log" 2>&1
  rc=$?
  set -e
  summary="$(grep -E '^[0-9]+% tests passed' "$log" | tail -1)"
  results+=("$name: ${summary:-no ctest summary} (exit $rc, $(( $(date +%s) - t0 )) s, log $log)")
  echo "stress-tests: ${results[-1]}"
  if [ "$rc" -ne 0 ]; then
    failed=1
    grep -E '^\s+[0-9]+ - .*\((Failed|Timeout|SEGFAULT|Subprocess aborted|Exception)' "$log" || true
  fi
}

for round in $(seq "$ROUNDS"); do
  run_stage "round $round (ctest -j $JOBS)" "$LOGS/round_$round.log" \
    ctest --test-dir "$ROOT/build" --output-on-failure -j "$JOBS"
done
if [ "$ASAN" = 1 ]; then
  run_stage "ASan + UBSan (ctest -j $(nproc), -L 'core|library|resources|robots|graspgen|datagen')" "$LOGS/asan.log" \
    bash -c 'ROOT=$1 && shift && source "$ROOT/scripts/sanitizer-env.sh" && exec "$@"' - "$ROOT" \
    ctest --test-dir "$ROOT/build-asan" --output-on-failure -j "$(nproc)" -L 'core|library|resources|robots|graspgen|datagen'
fi

echo "== stress-tests: $HOGS hogs on $(nproc) cores =="
printf '%s\n' "${results[@]}"
if [ "$failed" -ne 0 ]; then
  echo "stress-tests: FAILED"
  exit 1
fi
echo "stress-tests: all stages passed"
