#!/usr/bin/env python3
"""peer_cpu - the CPU a ghostpeer host takes per simulated second in a
2-host session on this machine (issue 17: <= 0.5 per host for 128 x 128).

    python3 bench/peer_cpu.py [--ghostpeer build/ghostpeer] [--cloth 128]
        [--duration 20] [--out DIR] DT:SUBSTEPS ...

For each schedule two ghostpeer processes (--integrator xpbd --dt DT
--substeps SUBSTEPS) peer on 127.0.0.1; each child's stdout and stderr go to
DIR/peer<id>_<dt>x<substeps>.{json,err}. Two figures per host:
- json: its last line's "cpu" (process CPU since the run began, after the
  scene's settle) over its "t" (simulated seconds);
- proc: utime + stime from /proc/<pid>/stat, sampled when the first JSON
  line arrives (the settle is done) and at the last sample before exit,
  over the "t" advanced between them.
Not run by `make bench` (a session takes DURATION wall seconds per
schedule and measures the machine's load with it)."""
import argparse
import json
import os
import socket
import subprocess
import sys
import time

TICK = os.sysconf("SC_CLK_TCK")


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
        out = os.path.join(a.out, "peer%d_%s.json" % (i + 1, tag))
        err = os.path.join(a.out, "peer%d_%s.err" % (i + 1, tag))
        cmd = [a.ghostpeer, "--id", str(i + 1), "--listen", "127.0.0.1:%d" % ports[i],
               "--peer", "%d@127.0.0.1:%d" % (2 - i, ports[1 - i]), "--cloth", str(a.cloth),
               "--integrator", "xpbd", "--dt", repr(dt), "--substeps", str(sub),
               "--duration", str(a.duration), "--stats-every", "1"]
        procs.append(subprocess.Popen(cmd, stdout=open(out, "w"), stderr=open(err, "w")))
        outs.append(out)
    start = [None, None]   # (cpu, t) at the first JSON line
    last = [None, None]    # cpu at the last sample while alive
    while any(p.poll() is None for p in procs):
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
                     "rc": procs[i].returncode})
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ghostpeer", default=os.environ.get("GHOSTPEER", "build/ghostpeer"))
    ap.add_argument("--cloth", type=int, default=128)
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--out", default="build/peer_cpu")
    ap.add_argument("schedules", nargs="+", help="DT:SUBSTEPS, e.g. 0.004:4")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    print("%-12s %4s %8s %14s %14s" % ("schedule", "host", "sim s", "CPU/sim s json", "CPU/sim s proc"))
    ok = True
    for s in a.schedules:
        dt, sub = s.split(":")
        for r in session(a, float(dt), int(sub)):
            ok = ok and r["rc"] == 0
            print("%-12s %4d %8.2f %14.3f %14.3f" % ("%s x %s" % (dt, sub), r["host"], r["t"],
                                                    r["cpu_per_sim_s_json"], r["cpu_per_sim_s_proc"]))
            sys.stdout.flush()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
