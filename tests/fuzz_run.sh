#!/bin/sh
# Runs the libFuzzer harness for a while and prints a summary:
#   tests/fuzz_run.sh FUZZER SECONDS LABEL
# One process on one core (no -jobs/-workers: the same as -jobs=1
# -workers=1 without the extra process). Inputs: build/NAME-work (new ones
# go there; NAME is the fuzzer's), build/fuzz-corpus (the seeds of
# tests/fuzz_seeds.c) and tests/fuzz-regressions (inputs that once failed). A crash, hang (10 s),
# leak or out-of-memory writes its input to build/NAME-artifacts/ and the
# script exits 1, printing the report and how to replay it.
fuzzer=$1; seconds=$2; label=$3
build=$(dirname "$fuzzer")
name=$(basename "$fuzzer")
work=$build/$name-work; art=$build/$name-artifacts; log=$build/$name-$label.log
mkdir -p "$work" "$art"
before=$(ls "$art" | wc -l)
ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1} UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1} \
  "$fuzzer" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=12288 \
  -print_final_stats=1 -artifact_prefix="$art/" \
  "$work" "$build/fuzz-corpus" tests/fuzz-regressions >"$log" 2>&1
rc=$?
after=$(ls "$art" | wc -l)
found=$((after - before))
stat() { sed -n "s/^stat::$1: *//p" "$log" | tail -1; }
last=$(grep -E '^#[0-9]+[[:space:]].*cov: ' "$log" | tail -1)
cov=$(echo "$last" | sed -n 's/.*cov: \([0-9]*\).*/\1/p')
ft=$(echo "$last" | sed -n 's/.*ft: \([0-9]*\).*/\1/p')
corp=$(echo "$last" | sed -n 's/.*corp: \([0-9]*\).*/\1/p')
echo "$name ($label): $(stat number_of_executed_units) executions in ${seconds} s" \
     "($(stat average_exec_per_sec)/s), coverage ${cov:-?} edges, ${ft:-?} features," \
     "corpus ${corp:-?} inputs ($(stat new_units_added) new), peak RSS $(stat peak_rss_mb) MB," \
     "crashes: $found"
if [ $rc -ne 0 ] || [ $found -ne 0 ]; then
  tail -n 60 "$log"
  echo "$name ($label): FAILED (exit $rc); inputs in $art/, full log $log;" \
       "replay one with: $fuzzer $art/NAME"
  exit 1
fi
exit 0
