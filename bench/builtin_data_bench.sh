#!/usr/bin/env bash
# Built-in data bench (issue 28, point 7), one run: objathor annotation lookup (first and warm)
# with mlspaces against the original's LMDB path, install throughput (archives/s) from a local
# MolmoSpaces-format remote against the original's resource manager, and SEARCH's CLIP search
# bench (bench/clip_search_bench.sh) when present. Figures go to stdout and to
# bench/results/builtin_data_bench.txt.
#
#   bench/builtin_data_bench.sh [--quick] [builtin_data_bench.py flags: --annotations N,
#                               --archives N, --skip annotation,install,search, ...]
#
# The original: molmospaces-resources 0.0.2 in build/bench-venv-resources (made by
# bench/molmo_remote_interop.sh's setup; see there). mlspaces: $MLSPACES_CLI_PATH, else
# build-fixture/ or build/ apps/mlspaces/mlspaces; Python package: build-fixture/python or
# build/python, whichever holds the extension.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
py="$root/.venv/bin/python"
venv="${MLSPACES_BENCH_RESOURCES_VENV:-$root/build/bench-venv-resources}"
if ! "$venv/bin/python" -c 'import molmospaces_resources, numpy' 2>/dev/null; then
  echo "no original bench venv at $venv: run bench/molmo_remote_interop.sh once (it makes it)" >&2
  exit 2
fi
cli="${MLSPACES_CLI_PATH:-}"
pypath=""
for b in "$root/build-fixture" "$root/build"; do
  [[ -z "$cli" && -x "$b/apps/mlspaces/mlspaces" ]] && cli="$b/apps/mlspaces/mlspaces"
  if [[ -z "$pypath" ]] && compgen -G "$b/python/mlspaces/_core*.so" >/dev/null; then
    pypath="$b/python"
  fi
done
[[ -n "$cli" ]] || { echo "no mlspaces CLI: build it or set MLSPACES_CLI_PATH" >&2; exit 2; }
work="$(mktemp -d "${TMPDIR:-/tmp}/builtin_bench.XXXXXX")"
out="$root/bench/results/builtin_data_bench.txt"
extra=()
if [[ "${1:-}" == "--quick" ]]; then  # a smoke run: small sizes, results not kept
  shift
  extra=(--annotations 2000 --archives 60 --first-reps 3 --install-reps 1 --rounds 5)
  out="$work/quick.txt"
fi
trap 'chmod -R u+w "$work" 2>/dev/null; rm -rf "$work"' EXIT
export TQDM_DISABLE=1
"$py" "$root/bench/builtin_data_bench.py" --original-python "$venv/bin/python" \
  --mlspaces-python "$py" --mlspaces-pythonpath "$pypath" --cli "$cli" --work "$work/run" \
  --out "$out" "${extra[@]}" "$@"
