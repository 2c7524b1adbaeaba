#!/usr/bin/env bash
# The tree's style and static checks (clang-format 14 and clang-tidy 14 from Debian).
#   scripts/lint.sh --format          rewrite every C++ file with .clang-format
#   scripts/lint.sh --format-check    list the files that differ from .clang-format; exit 1 if any
#                                     (ctest `format_check` runs this)
#   scripts/lint.sh --tidy [FILE...]  clang-tidy with .clang-tidy over the sources (default: every
#                                     .cc of src/, apps/ and tests/ but the out-of-tree install
#                                     consumer), using build/compile_commands.json; exit 1 on any
#                                     warning
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

cpp_files() { git ls-files --cached --others --exclude-standard -- '*.cc' '*.h' | sort; }

case "${1:-}" in
  --format)
    cpp_files | xargs clang-format -i
    ;;
  --format-check)
    bad=()
    while read -r f; do
      [[ -f "$f" ]] || continue
      clang-format --dry-run -Werror "$f" >/dev/null 2>&1 || bad+=("$f")
    done < <(cpp_files)
    if ((${#bad[@]})); then
      printf 'not formatted (scripts/lint.sh --format): %s\n' "${bad[@]}" >&2
      exit 1
    fi
    echo "format-check: $(cpp_files | wc -l) files follow .clang-format"
    ;;
  --tidy)
    shift
    build="${MLSPACES_BUILD_DIR:-$ROOT/build}"
    [[ -f "$build/compile_commands.json" ]] || {
      echo "lint: no $build/compile_commands.json: run scripts/build.sh first" >&2; exit 2; }
    if (($#)); then
      files=("$@")
    else
      mapfile -t files < <(git ls-files 'src/*.cc' 'apps/*.cc' 'tests/*.cc' ':!tests/install/*')
    fi
    # clang-tidy cannot read GCC's precompiled headers (target_precompile_headers): a copy of
    # the database without them, so each file is also checked for the includes it needs.
    db="$(mktemp -d)"
    trap 'rm -rf "$db"' EXIT
    sed -E 's# -Winvalid-pch##g; s# -include [^ ]*/cmake_pch\.hxx##g' \
      "$build/compile_commands.json" > "$db/compile_commands.json"
    # One process per core; --quiet prints only diagnostics; any warning fails.
    printf '%s\n' "${files[@]}" | xargs -P "$(nproc)" -n 4 \
      clang-tidy --quiet -p "$db" --warnings-as-errors='*' 2>/dev/null
    echo "tidy: ${#files[@]} files pass .clang-tidy"
    ;;
  *)
    sed -n '2,9p' "$0" >&2
    exit 2
    ;;
esac
