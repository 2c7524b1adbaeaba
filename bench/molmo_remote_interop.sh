#!/usr/bin/env bash
# Interop bench (not CI): mlspaces and the original molmospaces-resources 0.0.2 on one
# MolmoSpaces-format remote, both ways (bench/molmo_remote_interop.py says what is checked).
#
#   bench/molmo_remote_interop.sh [--side a|b|both] [--keep]
#
# The remote is tests/fixtures/make_molmo_remote.py's, served by `python -m http.server` on
# 127.0.0.1. The original runs in its bench venv ($MLSPACES_BENCH_RESOURCES_VENV, default
# build/bench-venv-resources, made here on first use): molmospaces-resources from PyPI with
# --no-deps (its datasets / huggingface_hub / tyro serve only the HF remote and the downloader
# script), plus what its modules import: filelock, tqdm, requests, lmdb, zstandard, and numpy for
# the pickled annotation arrays. CLI: $MLSPACES_CLI_PATH, else build-fixture/ or build/
# apps/mlspaces/mlspaces. Prints PASS/FAIL lines; exits 1 if any check failed.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
py="$root/.venv/bin/python"
venv="${MLSPACES_BENCH_RESOURCES_VENV:-$root/build/bench-venv-resources}"
side=both
keep=0
while [[ $# -gt 0 ]]; do
  case "$1" in
    --side) side="$2"; shift 2 ;;
    --keep) keep=1; shift ;;
    *) echo "usage: $0 [--side a|b|both] [--keep]" >&2; exit 2 ;;
  esac
done

ensure_resources_venv() {
  if "$venv/bin/python" -c 'import molmospaces_resources, numpy' 2>/dev/null; then return; fi
  python3 -m venv "$venv"
  pin() { "$py" -c "import importlib.metadata as m; print(m.version('$1'))" 2>/dev/null || true; }
  local np_v; np_v="$(pin numpy)"
  "$venv/bin/pip" install -q --no-deps molmospaces-resources==0.0.2
  "$venv/bin/pip" install -q filelock "tqdm>=4.65" requests "lmdb==1.7.5" "zstandard==0.25.0" \
    "numpy${np_v:+==$np_v}"
  "$venv/bin/python" -c 'import molmospaces_resources.setup_utils'
}
ensure_resources_venv

cli="${MLSPACES_CLI_PATH:-}"
for c in "$root/build-fixture/apps/mlspaces/mlspaces" "$root/build/apps/mlspaces/mlspaces"; do
  [[ -z "$cli" && -x "$c" ]] && cli="$c"
done
[[ -n "$cli" ]] || { echo "no mlspaces CLI: build it or set MLSPACES_CLI_PATH" >&2; exit 2; }

work="$(mktemp -d "${TMPDIR:-/tmp}/molmo_interop.XXXXXX")"
server=""
cleanup() {
  [[ -n "$server" ]] && kill "$server" 2>/dev/null && wait "$server" 2>/dev/null || true
  if [[ $keep == 1 ]]; then echo "kept $work"; else chmod -R u+w "$work" && rm -rf "$work"; fi
}
trap cleanup EXIT

"$py" "$root/tests/fixtures/make_molmo_remote.py" "$work/fx" --objaverse 6
# Port 0: the server picks a free port and prints it; wait for that line (no sleeps).
"$py" -u -m http.server 0 --bind 127.0.0.1 --directory "$work/fx/remote" >"$work/http.log" 2>&1 &
server=$!
port=""
for _ in $(seq 1 600); do
  port="$(sed -n 's/.*port \([0-9]*\).*/\1/p' "$work/http.log" | head -1)"
  [[ -n "$port" ]] && break
  kill -0 "$server" 2>/dev/null || { cat "$work/http.log" >&2; exit 1; }
  sleep 0.1
done
[[ -n "$port" ]] || { echo "http.server did not start" >&2; exit 1; }
export TQDM_DISABLE=1
echo "remote: http://127.0.0.1:$port  cli: $cli  original: $venv"

"$venv/bin/python" "$root/bench/molmo_remote_interop.py" --fixture "$work/fx" \
  --url "http://127.0.0.1:$port" --work "$work" --cli "$cli" --side "$side"
