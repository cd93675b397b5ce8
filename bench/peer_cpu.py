#!/usr/bin/env python3
"""peer_cpu - the CPU a ghostpeer host takes per simulated second in a
2-host session on this machine (issue 17: <= 0.5 per host for 128 x 128).

    python3 bench/peer_cpu.py [--quick] [--out FILE.json] [--ghostpeer build/ghostpeer]
        [--cloth 128] [--duration S] [--keep DIR] [DT:SUBSTEPS ...]

For each schedule (default: 0.004:4, the README's recommendation for a 128x128
cloth, and 0.004:3; --quick: 0.004:4 alone, 6 s) two ghostpeer processes
(--integrator xpbd --dt DT --substeps SUBSTEPS) peer on 127.0.0.1; each child's
stdout and stderr go to files, never a pipe: DIR/peer<id>_<dt>x<substeps>.{json,err}
in --keep DIR, else a temporary directory removed at the end. Two figures per host:
- json: its last line's "cpu" (process CPU since the run began, after the
  scene's settle) over its "t" (simulated seconds);
- proc: utime + stime from /proc/<pid>/stat, sampled when the first JSON
  line arrives (the settle is done) and at the last sample before exit,
  over the "t" advanced between them.
Both are CPU time, so a loaded machine inflates them only by what the load
costs a process in caches and migrations; the 1-minute load average before and
after each session is printed beside it. The JSON (bench/README.md's
convention) has a row per host and schedule; its summary says whether the
recommended schedule (the first) keeps each host at <= 0.5 CPU s per simulated
s (issue 17) and whether every host kept pace (simulated time >= 0.95 of the
run's duration). `make bench` runs it (20 s per schedule; --quick 6 s)."""
import argparse
import json
import os
import platform
import shutil
import socket
import subprocess
import sys
import tempfile
import time

TICK = os.sysconf("SC_CLK_TCK")
TARGET = 0.5       # CPU s per simulated s per host (issue 17)
DEFAULT = ["0.004:4", "0.004:3"]


def proc_cpu(pid):
    try:
        with open("/proc/%d/stat" % pid) as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / TICK  # utime, stime
    except (OSError, IndexError, ValueError):
        return None


def free_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def last_json(path):
    lines = []
    with open(path) as f:
        for ln in f:
            try:
                lines.append(json.loads(ln))
            except ValueError:
                pass
    return lines


def session(a, dt, sub):
    ports = [free_port(), free_port()]
    tag = "%gx%d" % (dt, sub)
    procs, outs = [], []
    for i in (0, 1):
        out = os.path.join(a.logs, "peer%d_%s.json" % (i + 1, tag))
        err = os.path.join(a.logs, "peer%d_%s.err" % (i + 1, tag))
        cmd = [a.ghostpeer, "--id", str(i + 1), "--listen", "127.0.0.1:%d" % ports[i],
               "--peer", "%d@127.0.0.1:%d" % (2 - i, ports[1 - i]), "--cloth", str(a.cloth),
               "--integrator", "xpbd", "--dt", repr(dt), "--substeps", str(sub),
               "--duration", str(a.duration), "--stats-every", "1"]
        with open(out, "w") as fo, open(err, "w") as fe:
            procs.append(subprocess.Popen(cmd, stdout=fo, stderr=fe))
        outs.append(out)
    deadline = time.time() + a.duration + 60   # bounded: a peer that hangs is killed
    start = [None, None]   # (cpu, t) at the first JSON line
    last = [None, None]    # cpu at the last sample while alive
    while any(p.poll() is None for p in procs):
        if time.time() > deadline:
            for p in procs:
                if p.poll() is None:
                    p.kill()
            break
        for i, p in enumerate(procs):
            if p.poll() is not None:
                continue
            c = proc_cpu(p.pid)
            if c is None:
                continue
            if start[i] is None:
                lines = last_json(outs[i])
                if lines:
                    start[i] = (c, lines[0]["t"])
            last[i] = (c, time.time())
        time.sleep(0.2)
    rows = []
    for i in (0, 1):
        lines = last_json(outs[i])
        fin = lines[-1] if lines else {}
        t = fin.get("t", float("nan"))
        js = fin.get("cpu", float("nan")) / t if t == t and t > 0 else float("nan")
        pr = float("nan")
        if start[i] and last[i] and t > start[i][1]:
            pr = (last[i][0] - start[i][0]) / (t - start[i][1])
        rows.append({"host": i + 1, "dt": dt, "substeps": sub, "t": t,
                     "cpu_per_sim_s_json": js, "cpu_per_sim_s_proc": pr,
                     "rc": procs[i].wait()})
    return rows


def load1():
    try:
        return os.getloadavg()[0]
    except OSError:
        return float("nan")


def machine():
    cpu = ""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    u = platform.uname()
    return {"sysname": u.system, "release": u.release, "arch": u.machine,
            "nodename": u.node, "cpu": cpu, "cores": os.cpu_count() or 0}


def finite(v):
    if isinstance(v, float) and v != v:
        return None
    if isinstance(v, dict):
        return {k: finite(x) for k, x in v.items()}
    if isinstance(v, list):
        return [finite(x) for x in v]
    return v


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default="bench/results/peer_cpu.json")
    ap.add_argument("--ghostpeer", default=os.environ.get("GHOSTPEER", "build/ghostpeer"))
    ap.add_argument("--cloth", type=int, default=128)
    ap.add_argument("--duration", type=float, default=None)
    ap.add_argument("--keep", default=None, help="keep the peers' output in this directory")
    ap.add_argument("schedules", nargs="*", help="DT:SUBSTEPS, e.g. 0.004:4")
    a = ap.parse_args()
    a.duration = a.duration or (6.0 if a.quick else 20.0)
    schedules = a.schedules or (DEFAULT[:1] if a.quick else DEFAULT)
    a.logs = a.keep or tempfile.mkdtemp(prefix="peer_cpu.")
    os.makedirs(a.logs, exist_ok=True)
    print("%-12s %4s %8s %14s %14s  %s" % ("schedule", "host", "sim s", "CPU/sim s json",
                                           "CPU/sim s proc", "load before/after"))
    ok, rows = True, []
    try:
        for s in schedules:
            dt, sub = s.split(":")
            l0 = load1()
            rs = session(a, float(dt), int(sub))
            l1 = load1()
            for r in rs:
                r["load_before"], r["load_after"] = l0, l1
                ok = ok and r["rc"] == 0
                rows.append(r)
                print("%-12s %4d %8.2f %14.3f %14.3f  %.2f/%.2f" % (
                    "%s x %s" % (dt, sub), r["host"], r["t"], r["cpu_per_sim_s_json"],
                    r["cpu_per_sim_s_proc"], l0, l1))
                sys.stdout.flush()
    finally:
        if not a.keep:
            shutil.rmtree(a.logs, ignore_errors=True)
    first = [r for r in rows if "%g:%d" % (r["dt"], r["substeps"]) ==
             "%g:%d" % (float(schedules[0].split(":")[0]), int(schedules[0].split(":")[1]))]
    worst = max((r["cpu_per_sim_s_json"] for r in first), default=float("nan"))
    paced = all(r["t"] == r["t"] and r["t"] >= 0.95 * a.duration for r in rows)
    summary = {
        "cpu_per_sim_s_worst_host": worst,
        "target": "%dx%d cloth, 2 ghostpeer hosts, XPBD at %s: <= %g CPU s per simulated s "
                  "per host (worst host)" % (a.cloth, a.cloth, schedules[0], TARGET),
        "target_met": worst == worst and worst <= TARGET,
        "target_pace": "every host kept wall-clock pace (simulated >= 0.95 of the duration)",
        "target_met_pace": paced,
    }
    out = {"bench": "peer_cpu", "quick": bool(a.quick), "machine": machine(),
           "method": "two ghostpeer processes on loopback per schedule; CPU per simulated "
                     "second per host from the JSON's cpu over t and from /proc/<pid>/stat",
           "config": {"cloth": a.cloth, "duration_s": a.duration, "schedules": schedules,
                      "integrator": "xpbd", "peer": a.ghostpeer},
           "results": rows, "summary": summary}
    os.makedirs(os.path.dirname(a.out) or ".", exist_ok=True)
    with open(a.out, "w") as f:
        json.dump(finite(out), f, indent=1, allow_nan=False)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
