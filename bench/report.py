#!/usr/bin/env python3
"""Turns bench/results/*.json into bench/results/REPORT.md and PNG plots.

    python3 bench/report.py [RESULTS_DIR]

Every JSON file (the layout is in bench/README.md) becomes one section: its
method, its summary (targets marked met or missed), and a table of its rows.
Every entry of its "plots" becomes NAME_K.png, drawn by gnuplot (Debian
gnuplot-nox) from a NAME_K.gp script left beside it, so a plot can be redrawn
by hand. Python's standard library only. Exits 1 if a file could not be read
or a plot could not be drawn (the report is written anyway).
"""
import json
import math
import os
import shutil
import subprocess
import sys
import time

# The order of the list; anything else follows by name.
ORDER = ["sync_overhead", "blend", "tradeoff", "transport", "physics",
         "scaling", "scheduler"]


def fmt(v):
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return "–"
        if v == 0:
            return "0"
        a = abs(v)
        if a >= 1e6 or a < 1e-3:
            return "%.3g" % v
        if a >= 100:
            return "%.0f" % v
        if a >= 10:
            return "%.1f" % v
        return "%.3g" % v
    if isinstance(v, str):
        return v.replace("|", "\\|").replace("\n", " ")
    return json.dumps(v, separators=(",", ":")).replace("|", "\\|")


def is_target_key(k):
    """target_met, target_met_X, target_X_met, X_target_met."""
    return k.endswith("_met") and "target" in k


def target_text(summary, k):
    """The text that names a target: summary["target"] for target_met,
    summary["target_X"] for target_met_X, else the key in words."""
    if k == "target_met":
        t = summary.get("target")
    elif k.startswith("target_met_"):
        t = summary.get("target_" + k[len("target_met_"):])
    else:
        t = None
    if isinstance(t, str):
        return t
    words = k[:-len("_met")].replace("target", "").strip("_").replace("_", " ")
    return words or k


def table(rows):
    if not rows:
        return ["(no rows)"]
    cols = []
    for r in rows:
        if isinstance(r, dict):
            for k in r:
                if k not in cols:
                    cols.append(k)
    if not cols:
        return ["(rows are not objects)"]
    out = ["| " + " | ".join(cols) + " |",
           "|" + "|".join("---" for _ in cols) + "|"]
    for r in rows:
        if isinstance(r, dict):
            out.append("| " + " | ".join(fmt(r.get(c)) for c in cols) + " |")
    return out


def summary_lines(summary):
    out = []
    if not isinstance(summary, dict):
        return ["- %s" % fmt(summary)]
    for k, v in summary.items():
        if is_target_key(k) and isinstance(v, bool):
            out.append("- **%s: %s**" % (k, "met" if v else "MISSED"))
        elif isinstance(v, dict):
            out.append("- %s: %s" % (k, ", ".join("%s %s" % (kk, fmt(vv))
                                                   for kk, vv in v.items())))
        else:
            out.append("- %s: %s" % (k, fmt(v)))
    return out


def gnuplot_terminal(gp):
    try:
        r = subprocess.run([gp, "-e", "set terminal"], capture_output=True,
                           text=True, timeout=20)
        txt = r.stdout + r.stderr
    except (OSError, subprocess.SubprocessError):
        txt = ""
    for line in txt.splitlines():
        if line.split()[:1] == ["pngcairo"]:
            return "pngcairo size 900,560 font ',10'"
    return "png size 900,560"


def gp_str(s):
    return "'" + str(s).replace("'", "''") + "'"


def num(v):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return "?"
    if not math.isfinite(v):
        return "?"
    return repr(float(v))


def plot(outdir, stem, p, terminal, gp):
    """Writes STEM.gp and runs gnuplot on it; returns an error or None."""
    png = stem + ".png"
    series = [s for s in p.get("series", []) if isinstance(s, dict)]
    log = bool(p.get("log"))
    lines = ["# %s (redraw: gnuplot %s.gp)" % (p.get("title", stem), stem)]
    plotted = []
    for i, s in enumerate(series):
        xs, ys = s.get("x", []) or [], s.get("y", []) or []
        pts = [(x, y) for x, y in zip(xs, ys)
               if num(x) != "?" and num(y) != "?" and (not log or (x > 0 and y > 0))]
        if not pts:
            continue
        lines.append("$D%d << EOD" % i)
        lines += ["%s %s" % (num(x), num(y)) for x, y in pts]
        lines.append("EOD")
        plotted.append((i, s.get("name", "series %d" % i)))
    lines += [
        "set terminal %s" % terminal,
        "set termoption noenhanced",
        "set output %s" % gp_str(png),
        "set title %s" % gp_str(p.get("title", stem)),
        "set xlabel %s" % gp_str(p.get("xlabel", "")),
        "set ylabel %s" % gp_str(p.get("ylabel", "")),
        "set grid",
        "set key outside right top",
    ]
    if log:
        lines.append("set logscale xy")
    h = p.get("hline")
    if isinstance(h, dict) and num(h.get("y")) != "?":
        hy = num(h["y"])
        lines.append("set arrow 1 from graph 0, first %s to graph 1, first %s nohead "
                     "dashtype 2 lw 1.5 lc rgb 'red'" % (hy, hy))
        lines.append("set label 1 %s at graph 0.02, first %s offset 0,0.6 tc rgb 'red'"
                     % (gp_str(h.get("title", "")), hy))
    if plotted:
        lines.append("plot " + ", ".join(
            "$D%d using 1:2 with linespoints lw 2 pt 7 title %s" % (i, gp_str(name))
            for i, name in plotted))
    else:
        lines += ["set label 1 'no data' at graph 0.5, graph 0.5 center",
                  "plot [0:1][0:1] NaN notitle"]
    lines.append("set output")
    with open(os.path.join(outdir, stem + ".gp"), "w") as f:
        f.write("\n".join(lines) + "\n")
    if not gp:
        return "gnuplot not found (Debian: apt-get install gnuplot-nox)"
    try:
        r = subprocess.run([gp, stem + ".gp"], cwd=outdir, capture_output=True,
                           text=True, timeout=60)
    except (OSError, subprocess.SubprocessError) as e:
        return "gnuplot failed: %s" % e
    path = os.path.join(outdir, png)
    if r.returncode != 0 or not os.path.exists(path) or os.path.getsize(path) == 0:
        return "gnuplot failed (status %d): %s" % (r.returncode, r.stderr.strip()[-400:])
    return None


def main():
    outdir = sys.argv[1] if len(sys.argv) > 1 else os.path.join("bench", "results")
    if not os.path.isdir(outdir):
        print("report.py: no directory %s" % outdir, file=sys.stderr)
        return 1
    names = sorted(f[:-5] for f in os.listdir(outdir) if f.endswith(".json"))
    names.sort(key=lambda n: (ORDER.index(n) if n in ORDER else len(ORDER), n))
    gp = shutil.which("gnuplot")
    terminal = gnuplot_terminal(gp) if gp else "png"
    errors = []
    docs = []
    for n in names:
        try:
            with open(os.path.join(outdir, n + ".json")) as f:
                d = json.load(f)
            if not isinstance(d, dict):
                raise ValueError("not a JSON object")
        except (OSError, ValueError) as e:
            errors.append("%s.json: %s" % (n, e))
            docs.append((n, None))
            continue
        docs.append((n, d))

    machine = next((d.get("machine") for _, d in docs if d and d.get("machine")), {})
    quick = any(d.get("quick") for _, d in docs if d)
    md = ["# ghostsim benchmark report", ""]
    md.append("Generated by `make %s` (bench/report.py) on %s." %
              ("bench-quick" if quick else "bench",
               time.strftime("%Y-%m-%d %H:%M:%S %Z")))
    if quick:
        md.append("**Quick mode**: a smoke test with short runs; "
                  "the figures are rough. Run `make bench` for the real ones.")
    if machine:
        md.append("Machine: %s, %s cores, %s %s %s." % (
            machine.get("cpu", "?"), machine.get("cores", "?"),
            machine.get("sysname", ""), machine.get("release", ""),
            machine.get("arch", "")))
    md.append("")

    # Targets first: every summary key that says whether a target is met.
    targets = []
    for n, d in docs:
        if not d:
            continue
        s = d.get("summary", {})
        if isinstance(s, dict):
            for k, v in s.items():
                if is_target_key(k) and isinstance(v, bool):
                    targets.append((n, target_text(s, k), v))
    if targets:
        md += ["## Targets", "", "| benchmark | target | status |", "|---|---|---|"]
        for n, k, v in targets:
            md.append("| %s | %s | %s |" % (n, k, "met" if v else "**missed**"))
        md.append("")

    for n, d in docs:
        md += ["## %s" % n, ""]
        if d is None:
            md += ["Could not read %s.json." % n, ""]
            continue
        if d.get("method"):
            md += ["*Method.* %s" % fmt(d["method"]), ""]
        if "config" in d and isinstance(d["config"], dict):
            md += ["*Config.* " + ", ".join("%s %s" % (k, fmt(v))
                                            for k, v in d["config"].items()), ""]
        md += ["### Summary", ""] + summary_lines(d.get("summary", {})) + [""]
        rows = d.get("results", [])
        md += ["### Results", ""] + table(rows if isinstance(rows, list) else []) + [""]
        plots = d.get("plots", [])
        for i, p in enumerate(plots if isinstance(plots, list) else []):
            if not isinstance(p, dict):
                continue
            stem = "%s_%d" % (n, i + 1)
            err = plot(outdir, stem, p, terminal, gp)
            if err:
                errors.append("%s: %s" % (stem, err))
                md += ["Plot %s: %s" % (stem, err), ""]
            else:
                md += ["![%s](%s.png)" % (fmt(p.get("title", stem)), stem), ""]

    if errors:
        md += ["## Problems", ""] + ["- %s" % fmt(e) for e in errors] + [""]
    with open(os.path.join(outdir, "REPORT.md"), "w") as f:
        f.write("\n".join(md))
    print("report.py: %s/REPORT.md, %d benchmarks, %d plots%s" % (
        outdir, len(docs),
        sum(len(d.get("plots", [])) for _, d in docs if d and isinstance(d.get("plots"), list)),
        "; problems: " + "; ".join(errors) if errors else ""), file=sys.stderr)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
