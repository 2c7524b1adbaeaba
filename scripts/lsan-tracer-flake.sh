#!/usr/bin/env bash
# Exit 0 when every test that failed in a `ctest --output-on-failure` log (argument 1) failed
# only because LeakSanitizer's own tracer crashed at a process's exit, and no sanitizer found
# anything; exit 1 otherwise (nothing failed counts as "otherwise": there is nothing to rerun).
# Used by scripts/test.sh to rerun those tests once.
set -euo pipefail
log="$1"
# A sanitizer's finding anywhere in the log is never a flake.
if grep -qE 'ERROR: (AddressSanitizer|LeakSanitizer: detected)|runtime error:' "$log"; then
  exit 1
fi
# Each failed test's block: from its "Test #N: name ... ***Failed" line to the next
# "Start N:" or "N/M Test #" line. It must hold the tracer's signature.
awk '
  function close_block() {
    if (in_block) {
      failed++
      if (!(tracer && fatal)) bad++
    }
    in_block = 0; tracer = 0; fatal = 0
  }
  /^ *[0-9]+\/[0-9]+ Test +#[0-9]+: / || /^ *Start +[0-9]+: / {
    close_block()
    if ($0 ~ /Test +#[0-9]+: / && $0 ~ /\*\*\*(Failed|Exception)/) in_block = 1
    next
  }
  /^The following tests FAILED:/ || /tests passed, [0-9]+ tests failed/ { close_block() }
  in_block && /Tracer caught signal/ { tracer = 1 }
  in_block && /LeakSanitizer has encountered a fatal error/ { fatal = 1 }
  END { close_block(); exit (failed > 0 && bad == 0) ? 0 : 1 }
' "$log"
