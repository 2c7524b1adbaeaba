#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/) with clang into build-fuzz/ and runs each for a bounded
# time: scripts/fuzz.sh [SECONDS]  (per target; default 60). Seeds: what fuzz/make_corpus
# writes with the project's own writers, plus every .npy/.npz under tests/ and examples/.
# The growing corpus is kept in build-fuzz/corpus/<target>; a crash, leak, timeout or
# out-of-memory fails the script and leaves the input in build-fuzz/artifacts/<target>/.
# Needs Debian's clang and libclang-rt-14-dev (scripts/install-deps.sh installs them).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECONDS_EACH="${1:-60}"
BUILD="${MLSPACES_FUZZ_BUILD_DIR:-$ROOT/build-fuzz}"
TARGETS=(npy npz msgpack uid_index tries pickle)

if ! command -v clang++ >/dev/null; then
  echo "fuzz: clang++ not found (apt-get install clang libclang-rt-14-dev)" >&2
  exit 1
fi
CC=clang CXX=clang++ cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DMLSPACES_BUILD_FUZZ=ON -DMLSPACES_BUILD_TESTS=OFF -DMLSPACES_BUILD_BENCH=OFF \
  -DMLSPACES_BUILD_SIM=OFF >/dev/null
cmake --build "$BUILD" -j "$(nproc)" --target make_corpus "${TARGETS[@]/%/_fuzz}"

SEEDS="$BUILD/seeds"
rm -rf "$SEEDS"
ASAN_OPTIONS=detect_leaks=0 "$BUILD/fuzz/make_corpus" "$SEEDS" "$ROOT/examples"
while IFS= read -r -d '' f; do
  case "$f" in
    *.npy) dest=npy ;;
    *) dest=npz ;;
  esac
  cp "$f" "$SEEDS/$dest/fixture_$(echo "$f" | sha256sum | cut -c1-12)_$(basename "$f")"
done < <(find "$ROOT/tests" "$ROOT/examples" \( -name '*.npy' -o -name '*.npz' \) -print0)

# Pickle seeds: what the project's Python writes (every value kind, protocols 2-5, hostile).
mkdir -p "$SEEDS/pickle"
if "$ROOT/.venv/bin/python" "$ROOT/tests/core/testdata/make_pickles.py" "$SEEDS/pickle_py" \
    >/dev/null 2>&1; then
  cp "$SEEDS"/pickle_py/*.pkl "$SEEDS/pickle/"
else
  printf '\x80\x04N.' > "$SEEDS/pickle/none.pkl"  # no project venv: one minimal seed
fi

status=0
for t in "${TARGETS[@]}"; do
  corpus="$BUILD/corpus/$t" artifacts="$BUILD/artifacts/$t/"
  mkdir -p "$corpus" "$artifacts"
  echo "== fuzz: ${t}_fuzz for ${SECONDS_EACH}s (corpus $corpus) =="
  if ! "$BUILD/fuzz/${t}_fuzz" -max_total_time="$SECONDS_EACH" -timeout=10 -rss_limit_mb=2048 \
      -print_final_stats=1 -artifact_prefix="$artifacts" "$corpus" "$SEEDS/$t" \
      > "$BUILD/${t}_fuzz.log" 2>&1; then
    echo "fuzz: ${t}_fuzz FAILED; log $BUILD/${t}_fuzz.log, inputs in $artifacts" >&2
    tail -n 40 "$BUILD/${t}_fuzz.log" >&2
    status=1
  else
    grep -E "^stat::number_of_executed_units|^stat::peak_rss_mb" "$BUILD/${t}_fuzz.log" || true
  fi
done
exit $status
