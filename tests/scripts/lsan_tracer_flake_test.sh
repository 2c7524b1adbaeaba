#!/usr/bin/env bash
# scripts/lsan-tracer-flake.sh: which ctest logs of the ASan run count as only LeakSanitizer's
# tracer crash (rerun once) and which stay failures. Logs shaped as `ctest --output-on-failure -j`
# prints them.
set -euo pipefail
check="$1/scripts/lsan-tracer-flake.sh"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
status=0
expect() {  # expect <0|1> <name>: the log in $dir/<name>.log
  local got=0
  "$check" "$dir/$2.log" || got=$?
  if [[ "$got" != "$1" ]]; then
    echo "FAIL: $2: exit $got, expected $1"
    status=1
  else
    echo "ok: $2 -> $got"
  fi
}
tracer='Tracer caught signal 11: addr=0x4c18 pc=0x7f780bee80f0 sp=0x7f77fb312d10
==28185==LeakSanitizer has encountered a fatal error.
==28185==HINT: For debugging, try setting environment variable LSAN_OPTIONS=verbosity=1:log_threads=1'
passed='        Start 2: B.Two
  1/3 Test #2: B.Two ..........   Passed    0.10 sec'
failed_with() {  # a failed test's block whose output is $2
  printf '        Start %s: %s\n  2/3 Test #%s: %s .......***Failed   44.13 sec\n%s\n' \
    "$1" "T.$1" "$1" "T.$1" "$2"
}
tail_lines() {
  printf '\n67%% tests passed, %s tests failed out of 3\n\nThe following tests FAILED:\n' "$1"
}
{ echo "$passed"; failed_with 3 "trial 5: $tracer"; tail_lines 1; } > "$dir/tracer_only.log"
expect 0 tracer_only
{ failed_with 3 "trial 5: $tracer"; failed_with 4 "$tracer"; tail_lines 2; } > "$dir/two_tracers.log"
expect 0 two_tracers
{ failed_with 3 "$tracer"; failed_with 4 "run_test.cc:428: Failure"; tail_lines 2; } \
  > "$dir/tracer_and_a_failure.log"
expect 1 tracer_and_a_failure
{ failed_with 3 "$tracer
==1==ERROR: LeakSanitizer: detected memory leaks"; tail_lines 1; } > "$dir/leak.log"
expect 1 leak
{ failed_with 3 "$tracer
x.cc:3:5: runtime error: signed integer overflow"; tail_lines 1; } > "$dir/ubsan.log"
expect 1 ubsan
{ failed_with 3 "Tracer caught signal 11: addr=0x0"; tail_lines 1; } > "$dir/half_signature.log"
expect 1 half_signature
{ echo "$passed"; printf '\n100%% tests passed, 0 tests failed out of 3\n'; } > "$dir/all_passed.log"
expect 1 all_passed
exit "$status"
