#!/bin/sh
# Runs every benchmark program, then the report.
#   sh bench/run.sh MODE TIMEOUT PROGRAM...
# MODE is "" (full) or --quick; TIMEOUT is seconds per program. Each program
# (or bench/NAME.py, an executable script) writes bench/results/NAME.json;
# its table goes to the terminal. A program
# that fails or times out does not stop the others, but the run fails.
mode="$1"; limit="$2"; shift 2
out=bench/results
mkdir -p "$out"
rm -f "$out"/*.json "$out"/*.png "$out"/*.dat "$out"/*.gp "$out"/REPORT.md
failed=""
start=$(date +%s)
for prog in "$@"; do
    name=$(basename "$prog" .py)
    echo "== bench: $name $mode" >&2
    t0=$(date +%s)
    if timeout "$limit" "$prog" $mode --out "$out/$name.json"; then
        echo "== bench: $name done in $(( $(date +%s) - t0 )) s" >&2
    else
        rc=$?
        [ "$rc" = 124 ] && echo "== bench: $name timed out after $limit s" >&2
        echo "== bench: $name FAILED (exit $rc)" >&2
        failed="$failed $name"
    fi
done
python3 bench/report.py "$out" || failed="$failed report.py"
echo "== bench: all done in $(( $(date +%s) - start )) s; report in $out/REPORT.md" >&2
if [ -n "$failed" ]; then
    echo "== bench: failed:$failed" >&2
    exit 1
fi
