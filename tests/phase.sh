#!/bin/sh
# Runs one phase of `make test` and says how long it took, so the note and
# the README can give make test's time part by part:
#   tests/phase.sh LABEL COMMAND...
label=$1; shift
t0=$(date +%s.%N)
"$@"; rc=$?
t1=$(date +%s.%N)
awk -v a="$t0" -v b="$t1" -v l="$label" -v rc="$rc" \
  'BEGIN { printf "make test: %s took %.0f s%s\n", l, b - a, rc ? " (failed)" : "" }'
exit $rc
