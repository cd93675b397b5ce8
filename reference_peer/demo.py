#!/usr/bin/env python3
"""The ghostsim demo: three reference peers on loopback, watched and measured.

    python3 reference_peer/demo.py --peer build/ghostpeer [--viewer build/viewer]
        [--duration 20] [--probe-until 10] [--out demo-results] [--base-port 47400]
        [--sync present|replay]

Starts three ghostpeer processes on 127.0.0.1 (ids 1, 2, 3 on ports BASE,
BASE+1, BASE+2, each listing the other two), reads the JSON line each prints
every 0.1 s and shows one live line per peer: simulation time, and for each
other peer the gap (ms), snapshots received per second and the divergence the
peer reports (mm), after the sync mode the peer says it runs (its JSON
"replay" object's "mode"). --sync passes ghostpeer's --sync: present (the
default, as ghostpeer's: the paper's blend at the present, on each host's
local clock) or replay (the session clock, each snapshot blended at its own
simulation time in a replay to the present; make demo SYNC=replay). Each
peer's stderr goes to OUT/peerN.log.

At the end (all peers exited; SIGTERM after duration + 10 s; or Ctrl-C, which
also sends SIGTERM) it prints and writes to OUT/:

  samples.csv         wall,pair,gap_s,digest_distance_m every 0.1 s of wall time
  summary.json        the numbers printed
  gap_divergence.png  gap (ms) and divergence (m, log) over wall time (gnuplot)
  gap_divergence.gp   the gnuplot script with its data, to redraw the plot
  scene.png           with --viewer: a headless viewer's picture of the scene

Measures. Wall times are sampled on a grid every 0.1 s from the earliest
first line. Each peer's values at a grid time are linearly interpolated
between its two lines around it, provided its nearest line is at most 0.05 s
away (so no sample bridges a hole in the output). The gap of a pair is
t_i - t_j at the same wall time (the paper's Figure 6 measure); the summary
gives median, p95 and max of |t_i - t_j| in ms over all pairs and samples,
and, for reference, the same from plain nearest-line pairing (which also
counts the up to 50 ms the two lines are apart in wall time). The digest
distance is the largest Euclidean distance |a - b| over the digest's xyz
triples (cloth centroid, cloth centre particle, sphere centres), in metres;
its summary covers the samples where both peers' simulation times are past
probe-until + 2 s, plus the final value (the last common sample).

Exit status: 0 when everything ran; 1 when a peer failed, produced no output
or the plot could not be drawn; 2 on a bad command line or a missing
ghostpeer; 130 after Ctrl-C (the summary is still printed).
Standard library only.
"""

import argparse
import bisect
import csv
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import threading
import time

NPEERS = 3
STATS_EVERY = 0.1      # s, the peers' --stats-every and the sampling grid
PAIR_WINDOW = 0.05     # s, nearest line must be this close in wall time
SETTLE_AFTER = 2.0     # s after probe-until before divergence counts
GRACE = 10.0           # s after duration before the peers are terminated
TERM_WAIT = 5.0        # s between SIGTERM and SIGKILL
VIEWER_AT = 5.0        # s into the run when the headless viewer starts
VIEWER_DURATION = 3.0  # s


def die(msg, status=2):
    sys.stderr.write("demo: %s\n" % msg)
    sys.exit(status)


def parse_args(argv):
    ap = argparse.ArgumentParser(
        prog="demo.py",
        description="Run three ghostpeer processes on loopback and measure "
                    "their simulation-time gap and divergence.")
    ap.add_argument("--peer", required=True, help="path to the ghostpeer binary")
    ap.add_argument("--viewer", help="path to the viewer binary (headless scene.png)")
    ap.add_argument("--duration", type=float, default=20.0, help="seconds (default 20)")
    ap.add_argument("--probe-until", type=float, default=10.0,
                    help="simulation time the probes stop (default 10)")
    ap.add_argument("--out", default="demo-results", help="output directory")
    ap.add_argument("--base-port", type=int, default=47400,
                    help="UDP ports BASE..BASE+2 for the peers, BASE+3 for the viewer")
    ap.add_argument("--sync", choices=("present", "replay"), default="present",
                    help="ghostpeer's --sync for every peer (default present)")
    a = ap.parse_args(argv)
    if not (a.duration > 0):
        ap.error("--duration must be > 0")
    if not (a.probe_until >= 0):
        ap.error("--probe-until must be >= 0")
    if not (1024 <= a.base_port <= 65535 - NPEERS - 1):
        ap.error("--base-port must be in [1024, %d]" % (65535 - NPEERS - 1))
    return a


# ---------------------------------------------------------------------------
# Peers and their output
# ---------------------------------------------------------------------------

class Peer:
    def __init__(self, pid, port):
        self.id = pid
        self.port = port
        self.proc = None
        self.log = None
        self.lines = []          # parsed JSON objects, in order
        self.final = None        # the "final": true object
        self.bad_lines = 0
        self.thread = None
        self.status = None


def reader(peer, lock):
    for raw in peer.proc.stdout:
        try:
            obj = json.loads(raw)
            float(obj["wall"])
            float(obj["t"])
        except (ValueError, KeyError, TypeError):
            with lock:
                peer.bad_lines += 1
            continue
        with lock:
            peer.lines.append(obj)
            if obj.get("final"):
                peer.final = obj


def start_peers(a, out, viewer):
    peers = [Peer(i + 1, a.base_port + i) for i in range(NPEERS)]
    lock = threading.Lock()
    for p in peers:
        cmd = [a.peer, "--id", str(p.id), "--listen", "127.0.0.1:%d" % p.port]
        for q in peers:
            if q is not p:
                cmd += ["--peer", "%d@127.0.0.1:%d" % (q.id, q.port)]
        if viewer:
            # the viewer is host NPEERS + 1 from the start, so that the peers
            # send it the scene once it comes (they report it silent until)
            cmd += ["--peer", "%d@127.0.0.1:%d" % (NPEERS + 1, a.base_port + NPEERS)]
        cmd += ["--duration", "%g" % a.duration, "--probe-until", "%g" % a.probe_until,
                "--stats-every", "%g" % STATS_EVERY, "--sync", a.sync]
        p.cmd = cmd
        p.log = open(os.path.join(out, "peer%d.log" % p.id), "w")
        p.log.write("# " + " ".join(cmd) + "\n")
        p.log.flush()
        try:
            # Own session: Ctrl-C reaches only this script, which sends SIGTERM.
            p.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=p.log,
                                      stdin=subprocess.DEVNULL, text=True, bufsize=1,
                                      start_new_session=True)
        except OSError as e:
            for q in peers:
                if q.proc and q.proc.poll() is None:
                    q.proc.kill()
            die("cannot start %s: %s" % (a.peer, e), 2)
        p.thread = threading.Thread(target=reader, args=(p, lock), daemon=True)
        p.thread.start()
    return peers, lock


def stop(procs, sig):
    for pr in procs:
        if pr is not None and pr.poll() is None:
            try:
                pr.send_signal(sig)
            except OSError:
                pass


# ---------------------------------------------------------------------------
# Live display
# ---------------------------------------------------------------------------

class Display:
    def __init__(self, peers):
        self.peers = peers
        self.tty = sys.stdout.isatty()
        self.drawn = 0
        self.last_print = 0.0
        self.last_rows = None
        self.rx_hist = {}        # (host, peer) -> [(wall, rx)]

    def rate(self, host, other, wall, rx):
        h = self.rx_hist.setdefault((host, other), [])
        if not h or h[-1][0] != wall:
            h.append((wall, rx))
        while len(h) > 2 and h[1][0] <= wall - 1.0:
            h.pop(0)
        if len(h) < 2 or h[-1][0] - h[0][0] <= 0:
            return None
        return (h[-1][1] - h[0][1]) / (h[-1][0] - h[0][0])

    def line_for(self, p, last, running):
        if last is None:
            return "peer %d: %s" % (p.id, "starting..." if running else "no output")
        mode = (last.get("replay") or {}).get("mode", "?")
        s = "peer %d  %s  t %6.2f s" % (p.id, mode, float(last["t"]))
        wall = float(last["wall"])
        others = last.get("peers") or {}
        for key in sorted(others, key=lambda k: (len(k), k)):
            o = others[key] if isinstance(others[key], dict) else {}
            try:
                gap_ms = "%+6.1f" % (1e3 * float(o.get("gap", 0.0)))
            except (TypeError, ValueError):
                gap_ms = "     ?"
            try:
                rate = self.rate(p.id, key, wall, float(o.get("rx", 0)))
            except (TypeError, ValueError):
                rate = None
            rate = "%4.0f" % rate if rate is not None else "   ?"
            try:
                div = "%7.2f" % (1e3 * float(o.get("div", 0.0)))
            except (TypeError, ValueError):
                div = "      ?"
            s += " | %s: gap %s ms %s pkt/s div %s mm" % (key, gap_ms, rate, div)
        if not running:
            s += "  (exited)"
        return s

    def update(self, lock, force=False):
        try:
            self._update(lock, force)
        except OSError:          # stdout closed (e.g. piped into head): go quiet
            self.tty = False
            self.last_print = float("inf")

    def _update(self, lock, force):
        with lock:
            lasts = [p.lines[-1] if p.lines else None for p in self.peers]
        running = [p.proc.poll() is None for p in self.peers]
        rows = [self.line_for(p, l, r) for p, l, r in zip(self.peers, lasts, running)]
        now = time.monotonic()
        if self.tty:
            width = shutil.get_terminal_size((200, 24)).columns - 1
            rows = [r[:width] for r in rows]
            if self.drawn:
                sys.stdout.write("\x1b[%dA" % self.drawn)
            for r in rows:
                sys.stdout.write("\r" + r + "\x1b[K\n")
            self.drawn = len(rows)
            sys.stdout.flush()
        elif (force and rows != self.last_rows) or now - self.last_print >= 1.0:
            self.last_print = now
            self.last_rows = rows
            for r in rows:
                sys.stdout.write(r + "\n")
            sys.stdout.flush()


# ---------------------------------------------------------------------------
# Measures
# ---------------------------------------------------------------------------

def series(peer):
    """(walls, ts, digests) of the peer's lines, sorted by wall, deduplicated."""
    pts = []
    for o in peer.lines:
        try:
            d = [float(x) for x in (o.get("digest") or [])]
            pts.append((float(o["wall"]), float(o["t"]), d))
        except (TypeError, ValueError):
            continue
    pts.sort(key=lambda x: x[0])
    out = []
    for p in pts:
        if out and p[0] <= out[-1][0]:
            continue
        out.append(p)
    return out


class Series(list):
    """A peer's (wall, t, digest) lines sorted by wall, with .walls for bisect."""
    def __init__(self, pts):
        list.__init__(self, pts)
        self.walls = [x[0] for x in pts]
        self.ts = [x[1] for x in pts]


def at_t(pts, t):
    """The peer's digest at simulation time t, interpolated, or None when
    its nearest line is more than 0.05 s of simulation time away (assumes t
    grows along the lines, which holds unless a peer's time jumps back)."""
    ts = pts.ts
    k = bisect.bisect_left(ts, t)
    cands = [i for i in (k - 1, k) if 0 <= i < len(pts)]
    if not cands or min(abs(ts[i] - t) for i in cands) > PAIR_WINDOW:
        return None
    if k == 0 or k >= len(pts) or ts[k] == ts[k - 1]:
        return pts[min(cands, key=lambda i: abs(ts[i] - t))][2]
    (_w0, t0, d0), (_w1, t1, d1) = pts[k - 1], pts[k]
    f = (t - t0) / (t1 - t0)
    if len(d0) != len(d1):
        return d0 if f < 0.5 else d1
    return [a + f * (b - a) for a, b in zip(d0, d1)]


def at(pts, w, interpolate=True):
    """The peer's (t, digest) at wall time w (a Series), or None when its
    nearest line is more than 0.05 s away."""
    walls = pts.walls
    k = bisect.bisect_left(walls, w)
    cands = [i for i in (k - 1, k) if 0 <= i < len(pts)]
    if not cands:
        return None
    near = min(cands, key=lambda i: abs(walls[i] - w))
    if abs(walls[near] - w) > PAIR_WINDOW:
        return None
    if not interpolate or k == 0 or k >= len(pts) or walls[k] == w:
        i = k if (k < len(pts) and walls[k] == w) else near
        return pts[i][1], pts[i][2]
    (w0, t0, d0), (w1, t1, d1) = pts[k - 1], pts[k]
    f = (w - w0) / (w1 - w0)
    t = t0 + f * (t1 - t0)
    if len(d0) == len(d1):
        d = [a + f * (b - a) for a, b in zip(d0, d1)]
    else:
        d = (d0 if f < 0.5 else d1)
    return t, d


def digest_distance(a, b):
    n = min(len(a), len(b)) // 3
    if n == 0 or len(a) != len(b):
        return None
    best = 0.0
    for i in range(n):
        dx, dy, dz = a[3 * i] - b[3 * i], a[3 * i + 1] - b[3 * i + 1], a[3 * i + 2] - b[3 * i + 2]
        best = max(best, math.sqrt(dx * dx + dy * dy + dz * dz))
    return best


def quantile(xs, q):
    if not xs:
        return None
    s = sorted(xs)
    pos = q * (len(s) - 1)
    lo = int(math.floor(pos))
    hi = min(lo + 1, len(s) - 1)
    return s[lo] + (pos - lo) * (s[hi] - s[lo])


def stats(xs, scale=1.0):
    if not xs:
        return {"n": 0, "median": None, "p95": None, "max": None}
    return {"n": len(xs), "median": quantile(xs, 0.5) * scale,
            "p95": quantile(xs, 0.95) * scale, "max": max(xs) * scale}


def measure(peers, probe_until):
    ser = {}
    for p in peers:
        s = Series(series(p))
        if s:
            ser[p.id] = s
    if not ser:
        return None
    w_start = min(s[0][0] for s in ser.values())
    w_end = max(s[-1][0] for s in ser.values())
    ids = sorted(ser)
    pairs = [(i, j) for k, i in enumerate(ids) for j in ids[k + 1:]]
    samples = []            # (wall, since, "i-j", gap_s, dist_m or None, t_min)
    nsteps = int(math.floor((w_end - w_start) / STATS_EVERY + 1e-9))
    for k in range(nsteps + 1):
        w = w_start + k * STATS_EVERY
        vals = {i: at(ser[i], w) for i in ids}
        for i, j in pairs:
            if vals[i] is None or vals[j] is None:
                continue
            (ti, di), (tj, dj) = vals[i], vals[j]
            samples.append((w, w - w_start, "%d-%d" % (i, j), ti - tj,
                            digest_distance(di, dj), min(ti, tj)))
    # The literal measure: each line of i with j's nearest line (<= 0.05 s).
    nearest_gaps = []
    for i, j in pairs:
        for (w, t, _d) in ser[i]:
            v = at(ser[j], w, interpolate=False)
            if v is not None:
                nearest_gaps.append(abs(t - v[0]))
    gaps = [abs(s[3]) for s in samples]
    settle = probe_until + SETTLE_AFTER
    # Diagnosis: the same comparison at equal simulation time, which leaves
    # out what the gap alone makes the states differ by.
    same_t = []
    for i, j in pairs:
        for (w, t, d) in ser[i]:
            if t < settle:
                continue
            dj = at_t(ser[j], t)
            dist = digest_distance(d, dj) if dj is not None else None
            if dist is not None:
                same_t.append(dist)
    divs = [s[4] for s in samples if s[5] >= settle and s[4] is not None]
    final = {}
    for i, j in pairs:
        name = "%d-%d" % (i, j)
        last = [s for s in samples if s[2] == name and s[4] is not None]
        if last:
            final[name] = {"wall": last[-1][0], "since_start_s": round(last[-1][1], 3),
                           "t": last[-1][5], "digest_distance_m": last[-1][4]}
    finals = [v["digest_distance_m"] for v in final.values()]
    per_pair = {}
    for i, j in pairs:
        name = "%d-%d" % (i, j)
        g = [abs(s[3]) for s in samples if s[2] == name]
        dv = [s[4] for s in samples if s[2] == name and s[5] >= settle and s[4] is not None]
        per_pair[name] = {"gap_ms": stats(g, 1e3), "digest_distance_m": stats(dv)}
    return {
        "w_start": w_start,
        "samples": samples,
        "summary": {
            "gap_ms": dict(stats(gaps, 1e3),
                           method="|t_i - t_j| at the same wall time, every %.1f s, each "
                                  "peer's t interpolated between its lines (nearest line "
                                  "<= %.2f s away), all pairs" % (STATS_EVERY, PAIR_WINDOW)),
            "gap_ms_nearest_line": dict(stats(nearest_gaps, 1e3),
                                        method="|t_i - t_j| of each line and the other "
                                               "peer's nearest line (<= %.2f s), all pairs"
                                               % PAIR_WINDOW),
            "digest_distance_m": dict(stats(divs),
                                      final=max(finals) if finals else None,
                                      final_per_pair=final,
                                      after_sim_time_s=settle,
                                      method="largest Euclidean |a - b| over the digest's "
                                             "xyz triples, same wall-time samples, where "
                                             "both peers' t >= probe-until + %g s"
                                             % SETTLE_AFTER),
            "digest_distance_same_t_m": dict(stats(same_t),
                                             method="the same distance between each line "
                                                    "of i and j's digest interpolated at "
                                                    "i's t (equal simulation time), t >= "
                                                    "probe-until + %g s, all pairs"
                                                    % SETTLE_AFTER),
            "per_pair": per_pair,
        },
    }


# ---------------------------------------------------------------------------
# Plot
# ---------------------------------------------------------------------------

def gnuplot_terminal(gp):
    try:
        r = subprocess.run([gp, "-e", "set terminal"], capture_output=True, text=True,
                           timeout=20)
        txt = r.stdout + r.stderr
    except (OSError, subprocess.SubprocessError):
        txt = ""
    for line in txt.splitlines():
        if line.split()[:1] == ["pngcairo"]:
            return "pngcairo size 1000,600 font ',10'"
    return "png size 1000,600"


def plot(out, m, probe_until, duration):
    gp = shutil.which("gnuplot")
    png = os.path.join(out, "gap_divergence.png")
    script = os.path.join(out, "gap_divergence.gp")
    if os.path.exists(png):
        os.remove(png)
    w0 = m["w_start"]
    # Time since start at which the probes stopped, on the wall-time axis.
    pairs = sorted(set(s[2] for s in m["samples"]))
    probe_x = probe_until
    for s in m["samples"]:
        if s[5] >= probe_until:
            probe_x = s[1]
            break
    floor = 1e-9
    lines = ["# ghostsim demo: gap and divergence between peers (redraw: gnuplot %s)"
             % os.path.basename(script)]
    for idx, name in enumerate(pairs):
        lines.append("$P%d << EOD" % idx)
        for s in m["samples"]:
            if s[2] == name:
                d = s[4] if s[4] is not None else float("nan")
                lines.append("%.3f %.6f %.6g" % (s[1], 1e3 * s[3], max(d, floor)
                                                  if d == d else d))
        lines.append("EOD")
    lines += [
        "set terminal %s" % (gnuplot_terminal(gp) if gp else "png"),
        "set output '%s'" % os.path.basename(png),
        "set multiplot layout 2,1 title 'ghostsim demo: %d peers on loopback UDP'"
        % NPEERS,
        "set grid",
        "set lmargin 12",
        "set rmargin 3",
        "set key top right",
        "set xrange [0:%g]" % max(duration + 1, 1),
        "set arrow 1 from %g, graph 0 to %g, graph 1 nohead dashtype 2 lc rgb 'gray40'"
        % (probe_x, probe_x),
        "set label 1 'probes stop' at %g, graph 0.92 offset 0.5,0" % probe_x,
        "set ylabel 'gap t_i - t_j (ms)'",
        "set format x ''",
        "plot " + ", ".join("$P%d using 1:2 with lines lw 1.5 title 'hosts %s'"
                            % (i, n) for i, n in enumerate(pairs)),
        "set xlabel 'wall time since start (s)'",
        "set format x '%g'",
        "set ylabel 'divergence (m)'",
        "set logscale y",
        "set format y '10^{%L}'",
        "set label 1 'probes stop' at %g, graph 0.92 offset 0.5,0" % probe_x,
        "plot " + ", ".join("$P%d using 1:3 with lines lw 1.5 title 'hosts %s'"
                            % (i, n) for i, n in enumerate(pairs)),
        "unset multiplot",
        "set output",
    ]
    with open(script, "w") as f:
        f.write("\n".join(lines) + "\n")
    if not gp:
        return "gnuplot not found (Debian: apt-get install gnuplot-nox); " \
               "the script is in %s" % script
    try:
        r = subprocess.run([gp, os.path.basename(script)], cwd=out, capture_output=True,
                           text=True, timeout=60)
    except (OSError, subprocess.SubprocessError) as e:
        return "gnuplot failed: %s" % e
    if r.returncode != 0 or not os.path.exists(png) or os.path.getsize(png) == 0:
        return "gnuplot failed (status %d): %s" % (r.returncode, r.stderr.strip()[-500:])
    return None


# ---------------------------------------------------------------------------
# Main
# ---------------------------------------------------------------------------

def fmt(x, f="%.3f"):
    return "n/a" if x is None else f % x


def main(argv):
    a = parse_args(argv)
    if not os.path.isfile(a.peer) or not os.access(a.peer, os.X_OK):
        die("ghostpeer not found or not executable: '%s' (build it first: make demo)"
            % a.peer, 2)
    peer_bin = a.peer if os.sep in a.peer else os.path.join(".", a.peer)
    a.peer = peer_bin
    os.makedirs(a.out, exist_ok=True)
    for name in ("samples.csv", "summary.json", "gap_divergence.png", "scene.png"):
        try:
            os.remove(os.path.join(a.out, name))
        except OSError:
            pass

    interrupted = [0]

    def on_sigint(_sig, _frame):
        interrupted[0] += 1
    signal.signal(signal.SIGINT, on_sigint)

    sys.stderr.write("demo: %d peers on 127.0.0.1:%d-%d for %g s, probes until %g s; "
                     "logs in %s/\n" % (NPEERS, a.base_port, a.base_port + NPEERS - 1,
                                        a.duration, a.probe_until, a.out))
    peers, lock = start_peers(a, a.out, bool(a.viewer) and os.path.isfile(a.viewer)
                              and os.access(a.viewer, os.X_OK))
    others = []
    try:
        return run(a, peers, lock, interrupted, others)
    finally:
        # Whatever happened, leave no process behind.
        stop([p.proc for p in peers] + others, signal.SIGTERM)


def run(a, peers, lock, interrupted, others):
    t_start = time.monotonic()
    display = Display(peers)

    viewer = None
    viewer_log = None
    viewer_png = os.path.join(a.out, "scene.png")
    want_viewer = bool(a.viewer)
    if want_viewer and not (os.path.isfile(a.viewer) and os.access(a.viewer, os.X_OK)):
        sys.stderr.write("demo: viewer '%s' not found; no scene.png\n" % a.viewer)
        want_viewer = False

    terminated = killed = False
    while True:
        now = time.monotonic() - t_start
        if interrupted[0] and not terminated:
            stop([p.proc for p in peers] + [viewer], signal.SIGTERM)
            terminated, t_term = True, time.monotonic()
        if interrupted[0] > 1 and not killed:
            stop([p.proc for p in peers] + [viewer], signal.SIGKILL)
            killed = True
        if not terminated and now > a.duration + GRACE:
            sys.stderr.write("demo: peers still running %g s after the duration; "
                             "sending SIGTERM\n" % GRACE)
            stop([p.proc for p in peers] + [viewer], signal.SIGTERM)
            terminated, t_term = True, time.monotonic()
        if terminated and not killed and time.monotonic() - t_term > TERM_WAIT:
            sys.stderr.write("demo: peers ignored SIGTERM; sending SIGKILL\n")
            stop([p.proc for p in peers] + [viewer], signal.SIGKILL)
            killed = True
        if want_viewer and viewer is None and now >= VIEWER_AT and not terminated:
            vport = a.base_port + NPEERS
            vcmd = [a.viewer if os.sep in a.viewer else os.path.join(".", a.viewer),
                    "--headless", "--out", viewer_png, "--id", str(NPEERS + 1),
                    "--listen", "127.0.0.1:%d" % vport]
            for p in peers:
                vcmd += ["--peer", "%d@127.0.0.1:%d" % (p.id, p.port)]
            vcmd += ["--duration", "%g" % VIEWER_DURATION, "--sync", a.sync]
            viewer_log = open(os.path.join(a.out, "viewer.log"), "w")
            viewer_log.write("# " + " ".join(vcmd) + "\n")
            viewer_log.flush()
            try:
                viewer = subprocess.Popen(vcmd, stdout=viewer_log, stderr=viewer_log,
                                          stdin=subprocess.DEVNULL, start_new_session=True)
                others.append(viewer)
            except OSError as e:
                sys.stderr.write("demo: cannot start the viewer: %s; no scene.png\n" % e)
                want_viewer = False
        display.update(lock)
        if all(p.proc.poll() is not None for p in peers):
            break
        time.sleep(0.1)

    for p in peers:
        p.status = p.proc.wait()
        p.thread.join(timeout=2.0)
        p.log.close()
    display.update(lock, force=True)

    # The viewer: give it time to finish its picture unless interrupted.
    viewer_msg = None
    if want_viewer:
        if viewer is None:
            viewer_msg = "the viewer was not started (the run ended before %g s)" % VIEWER_AT
        else:
            try:
                vst = viewer.wait(timeout=1.0 if interrupted[0] else VIEWER_DURATION + 20.0)
            except subprocess.TimeoutExpired:
                viewer.kill()
                vst = viewer.wait()
            viewer_log.close()
            if vst != 0 or not os.path.isfile(viewer_png):
                viewer_msg = ("the viewer failed (status %s; see %s/viewer.log); no scene.png"
                              % (vst, a.out))
        if viewer_msg:
            sys.stderr.write("demo: %s\n" % viewer_msg)

    # Measures and files.
    problems = []
    for p in peers:
        if not p.lines:
            problems.append("peer %d printed no output (status %s; see %s/peer%d.log)"
                            % (p.id, p.status, a.out, p.id))
        elif p.status != 0 and not interrupted[0]:
            problems.append("peer %d exited with status %s (see %s/peer%d.log)"
                            % (p.id, p.status, a.out, p.id))
        elif p.final is None and not killed:
            problems.append("peer %d wrote no final line" % p.id)
        if p.bad_lines:
            sys.stderr.write("demo: peer %d: %d stdout line(s) were not JSON; ignored\n"
                             % (p.id, p.bad_lines))
    m = measure(peers, a.probe_until)
    if m is None:
        for msg in problems:
            sys.stderr.write("demo: %s\n" % msg)
        die("no peer produced output; nothing to measure", 1)

    with open(os.path.join(a.out, "samples.csv"), "w", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["wall", "pair", "gap_s", "digest_distance_m"])
        for s in m["samples"]:
            wr.writerow(["%.6f" % s[0], s[2], "%.6f" % s[3],
                         "" if s[4] is None else "%.9g" % s[4]])

    summ = m["summary"]
    summary = {
        "command": [sys.argv[0]] + sys.argv[1:],
        "peers": NPEERS, "duration_s": a.duration, "probe_until_s": a.probe_until,
        "stats_every_s": STATS_EVERY, "base_port": a.base_port, "sync": a.sync,
        "interrupted": bool(interrupted[0]),
        "start_wall": m["w_start"],
        "samples": len(m["samples"]),
        "gap_ms": summ["gap_ms"],
        "gap_ms_nearest_line": summ["gap_ms_nearest_line"],
        "digest_distance_m": summ["digest_distance_m"],
        "digest_distance_same_t_m": summ["digest_distance_same_t_m"],
        "per_pair": summ["per_pair"],
        "hosts": {},
    }
    for p in peers:
        last = p.lines[-1] if p.lines else {}
        summary["hosts"][str(p.id)] = {
            "exit_status": p.status, "lines": len(p.lines),
            "final_t": last.get("t"), "final_line": p.final is not None,
            "totals": (p.final or {}).get("totals"),
            "peers": last.get("peers"),
            "replay": last.get("replay"),
        }
    plot_err = plot(a.out, m, a.probe_until, a.duration)
    summary["plot"] = None if plot_err else "gap_divergence.png"
    summary["scene"] = "scene.png" if (want_viewer and not viewer_msg) else None
    if plot_err:
        problems.append(plot_err)
    summary["problems"] = problems
    with open(os.path.join(a.out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
        f.write("\n")

    g, gn, d = summ["gap_ms"], summ["gap_ms_nearest_line"], summ["digest_distance_m"]
    print()
    modes = sorted(set(str((p.final or (p.lines[-1] if p.lines else {})).get("replay", {})
                           .get("mode", "?")) for p in peers))
    print("Sync mode: %s (asked: --sync %s; %s)" % (
        "/".join(modes), a.sync, "session clock, snapshots blended at their own time in a "
        "replay" if a.sync == "replay" else "each host's local clock, the paper's blend "
        "at the present"))
    print("Simulation-time gap between hosts (Figure 6), every %.1f s of wall time, "
          "all pairs (%d samples):" % (STATS_EVERY, g["n"]))
    print("  |t_i - t_j|  median %s ms   p95 %s ms   max %s ms"
          % (fmt(g["median"]), fmt(g["p95"]), fmt(g["max"])))
    print("  (nearest-line pairing, incl. up to %.0f ms of sampling skew: "
          "median %s, p95 %s, max %s ms)"
          % (PAIR_WINDOW * 1e3, fmt(gn["median"]), fmt(gn["p95"]), fmt(gn["max"])))
    print("Divergence between hosts after the probes stopped (t >= %g s, %d samples):"
          % (a.probe_until + SETTLE_AFTER, d["n"]))
    print("  digest distance  median %s m   p95 %s m   max %s m   final %s m"
          % (fmt(d["median"], "%.3g"), fmt(d["p95"], "%.3g"), fmt(d["max"], "%.3g"),
             fmt(d["final"], "%.3g")))
    ds = summ["digest_distance_same_t_m"]
    print("  (at equal simulation time instead: median %s m   p95 %s m   max %s m)"
          % (fmt(ds["median"], "%.3g"), fmt(ds["p95"], "%.3g"), fmt(ds["max"], "%.3g")))
    for name, v in sorted(d["final_per_pair"].items()):
        print("    hosts %s: final %.3g m at t = %.2f s" % (name, v["digest_distance_m"],
                                                           v["t"]))
    print("Wrote %s: samples.csv, summary.json%s%s, peer1..%d.log"
          % (a.out, "" if plot_err else ", gap_divergence.png",
             ", scene.png" if summary["scene"] else "", NPEERS))
    for msg in problems:
        sys.stderr.write("demo: %s\n" % msg)
    sys.stdout.flush()
    if interrupted[0]:
        sys.stderr.write("demo: interrupted\n")
        return 130
    return 1 if problems else 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        sys.exit(1)
