#!/bin/sh
# Runs cmocka test binaries, prints each one's own output, then totals:
#   tests/run.sh LABEL BINARY...
# A BINARY may carry arguments in the same word ("build/test_net test_udp*":
# a cmocka glob); it is split on spaces and never glob-expanded here.
# $VALGRIND, if set, prefixes each run. Exits 1 if any test failed or any
# binary exited non-zero.
label=$1; shift
passed=0; failed=0; skipped=0; status=0
for t in "$@"; do
  out=$(mktemp)
  t0=$(date +%s.%N)
  set -f
  $VALGRIND $t >"$out" 2>&1; rc=$?
  set +f
  t1=$(date +%s.%N)
  cat "$out"
  awk -v a="$t0" -v b="$t1" -v t="$t" 'BEGIN { printf "(%s: %.1f s)\n", t, b - a }'
  p=$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test.*/\1/p' "$out" | tail -1)
  f=$(sed -n 's/^\[  FAILED  \] \([0-9]*\) test.*/\1/p' "$out" | tail -1)
  k=$(sed -n 's/^\[  SKIPPED \] \([0-9]*\) test.*/\1/p' "$out" | tail -1)
  passed=$((passed + ${p:-0})); failed=$((failed + ${f:-0})); skipped=$((skipped + ${k:-0}))
  if [ $rc -ne 0 ]; then
    status=1
    [ -z "$f" ] && { echo "$t exited with $rc"; failed=$((failed + 1)); }
  fi
  rm -f "$out"
done
echo "tests ($label): $passed passed, $failed failed, $skipped skipped"
exit $status
