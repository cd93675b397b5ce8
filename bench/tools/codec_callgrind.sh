#!/bin/sh
# Instructions per full paper-scene snapshot, encoded and decoded, in f64,
# quant and quant+delta: callgrind counts of bench/bandwidth.c --cpu's
# timed calls (cpu_encode, cpu_decode), one dumped part per encoding,
# divided by the calls made. Instruction counts do not depend on the
# machine's load, so they are the codec's CPU figure to compare across
# runs (the bench's times are not, on a shared machine).
#
#   bench/tools/codec_callgrind.sh [OUTDIR]   (default /tmp/codec_callgrind)
#
# Needs cc, valgrind (callgrind_annotate) and python3; about a minute.
# CC and CFLAGS may be set; run it from the repository's top directory.
set -eu
out=${1:-/tmp/codec_callgrind}
cc=${CC:-cc}
mkdir -p "$out"
rm -f "$out"/callgrind.out*
"$cc" -std=c99 -D_POSIX_C_SOURCE=200809L -O2 -g -DNDEBUG ${CFLAGS:-} -I. \
    bench/bandwidth.c -o "$out/bw" -lccd -lm -lpthread
valgrind --tool=callgrind --callgrind-out-file="$out/callgrind.out" \
    --toggle-collect=cpu_encode --toggle-collect=cpu_decode \
    --dump-after=cpu_times "$out/bw" --cpu >"$out/valgrind.log" 2>&1
for part in 1 2 3; do
    f="$out/callgrind.out.$part"
    [ -f "$f" ] || { echo "codec_callgrind: no $f (see $out/valgrind.log)" >&2; exit 1; }
    callgrind_annotate --inclusive=yes "$f" >"$out/annotate.$part.txt"
done
python3 - "$out" <<'PY'
import re, sys
out = sys.argv[1]
names = ["f64", "quant", "quant+delta"]

def part(p):
    # inclusive instructions of the two timed calls, from callgrind_annotate
    inc = {}
    for line in open("%s/annotate.%d.txt" % (out, p)):
        m = re.match(r"\s*([\d,]+)\s.*bandwidth\.c:(cpu_encode|cpu_decode)\b", line)
        if m and m.group(2) not in inc:
            inc[m.group(2)] = int(m.group(1).replace(",", ""))
    # how many times each was called: the calls= line after its cfn=
    ids, calls, want = {}, {}, None
    for line in open("%s/callgrind.out.%d" % (out, p)):
        m = re.match(r"c?fn=\((\d+)\)(?: (\S+))?", line)
        if m:
            if m.group(2): ids[m.group(1)] = m.group(2)
            want = ids.get(m.group(1)) if line.startswith("cfn=") else None
            continue
        m = re.match(r"calls=(\d+)", line)
        if m and want in ("cpu_encode", "cpu_decode"):
            calls[want] = calls.get(want, 0) + int(m.group(1))
            want = None
    return [inc[k] / calls[k] for k in ("cpu_encode", "cpu_decode")]

rows = [part(p) for p in (1, 2, 3)]
base = sum(rows[0])
print("instructions per full paper-scene snapshot (callgrind, bench/bandwidth.c --cpu):")
print("%-12s %10s %10s %10s %8s" % ("encoding", "encode", "decode", "sum", "x f64"))
for n, (e, d) in zip(names, rows):
    print("%-12s %9.1fk %9.1fk %9.1fk %8.2f" % (n, e / 1e3, d / 1e3, (e + d) / 1e3, (e + d) / base))
PY
