#!/usr/bin/env python3
"""The fault suite: real ghostpeer processes behind a UDP proxy that breaks things.

    python3 tests/faults.py build/ghostpeer [--short] [SCENARIO...]
    python3 tests/faults.py build/ghostpeer --soak SECONDS

Every peer listens on its own loopback port but is told the proxy's ports as
its peers' addresses: the proxy holds one socket per ordered pair (x, y),
"x as y sees it", so what y sends to x goes through x's socket for y, and
reaches x from y's socket for x, the address x was given for y. Each
direction of each pair is a Link whose faults can change at any moment:
drop, duplicate, hold back (reorder), delay with jitter, corrupt bytes, cut.
Every port is the kernel's choice (fixed ones collide with other runs on a
shared machine): the peers' as peers.py picks them, the proxy's held open
for the run. Nothing reaches a peer before it prints its first line (at
the start and after a restart): ghostpeer opens its socket before it adds
its peers, and refuses what comes in between as from an unknown sender,
which no fault caused.

A scenario runs two (or three) peers with their probes moving for the whole
run, applies one fault for a while, and then checks (tests/peers.py's
helpers are imported from there):
  - no crash: every peer exits 0 with its final line (a peer the scenario
    SIGKILLs excepted), every line is JSON, no NaN or infinity anywhere;
  - every datagram the proxy corrupted and delivered to a peer is counted
    by that peer as rejected ("rejected_unknown" in its final line: a
    corrupted datagram fails the CRC before its sender is known); in the
    duplication scenario, every duplicate delivered is counted as rejected
    by its receiver ("rejected" of that peer);
  - convergence after the fault: the digests of every pair at the nearest
    simulation time within SHIFT (the ghosts' time band, 26.7 ms: hosts in
    step read clocks that far apart; the other's digest interpolated, and
    instants where the other bent off a straight line by more than 1 mm
    around it skipped, see series()) under 1 mm from some moment after the
    fault to the end of the run, and over the last second; the time from
    the fault's end to that moment is reported.
It prints a line per scenario and a summary table; exit status 1 on any
failure. A failed scenario is not retried: a retry would hide a convergence
that is not reliable (issue 15), and the table says what happened. With
GHOSTPEER_ARGS="--sync replay" in the environment (make faults-replay,
faults-short-replay) every peer runs in replay mode; the short suite then
takes clock-fwd too (SCENARIOS says why only then).

The soak: four peers, every link under rolling faults (a new fault every
few seconds on a random link, a kill and restart of a random peer every
minute or so), for SECONDS; every peer's resident memory (VmRSS) sampled;
all faults lifted for the last 30 s. Checks: memory flat (the last third's
median within 20% + 4 MiB of the first third's, after the first minute or
sixth of the run), divergence bounded (the largest at any moment under
0.5 m, the scene's own size), corrupted datagrams counted as above, no
crash, no NaN, every pair within 1 mm at the end.

Bounded everywhere: each scenario has a time limit, the suite a global
deadline (DEADLINE, or the soak's length + 120 s), every loop a count or a
deadline, and every process started here is killed at the end whatever
happens (finally, atexit, a watchdog).
"""
import heapq
import math
import os
import random
import selectors
import socket
import struct
import sys
import threading
import time
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peers as P  # noqa: E402  (Peer, finish, compare, kill_all, the 1 mm measure)

HOST = P.HOST
TOL = P.TOL
DEADLINE = 420.0            # s for the whole suite (the soak sets its own)
T0 = time.monotonic()
STATS = 0.01                # s between a peer's JSON lines: a line every 2 steps, fine enough
                            # that a sphere bouncing at metres per second bends little between them
HOLD = 1.0                  # s: converged means under TOL to the end, at least this long
SHIFT = P.SHIFT
SESSION = P.SESSION         # the peers run on the session clock (GHOSTPEER_ARGS)


# ---- the proxy ----

def _varint(b, off, end, maxlen, top):
    """An unsigned LEB128 varint at off (at most maxlen bytes before end, at
    most top): (value, next offset), or None."""
    z = 0
    for i in range(maxlen):
        if off >= end:
            return None
        c = b[off]
        off += 1
        z |= (c & 0x7F) << (7 * i)
        if not c & 0x80:
            return (z, off) if z <= top else None
    return None


def _unzig(u):
    return (u >> 1) ^ -(u & 1)


def _bits(b, off, nbits):
    """The nbits bits from byte off on, least significant first, as an int."""
    nbytes = (nbits + 7) // 8
    return int.from_bytes(b[off:off + nbytes], "little") & ((1 << nbits) - 1)


def _quant_len(b, off, end, elements):
    """The length of a quantized payload at off (segments, see >>wire), or None."""
    if off >= end:
        return None
    nseg, p, total = b[off], off + 1, 0
    if not 1 <= nseg <= 4:
        return None
    for _ in range(nseg):
        if p + 3 > end:
            return None
        kind, count = b[p], struct.unpack_from("<H", b, p + 1)[0]
        p += 3
        if kind == 1:                           # scalar: step f64, width u8, base varint
            if p + 9 > end:
                return None
            step, width = struct.unpack_from("<dB", b, p)
            p += 9
            if not (1e-12 <= step <= 1e12) or width > 32:
                return None
            v = _varint(b, p, end, 9, (1 << 63) - 1)
            if v is None:
                return None
            p = v[1]
            need = (count * width + 7) // 8
        elif kind == 2:                         # quaternion: bits u8, then 3 + 3 bits each
            if p + 1 > end:
                return None
            bits = b[p]
            p += 1
            if not 8 <= bits <= 24 or count % 4:
                return None
            need = ((count // 4) * (3 + 3 * bits) + 7) // 8
        else:
            return None
        if p + need > end:
            return None
        p += need
        total += count
    return p - off if total == elements else None


def _delta_len(b, off, end, elements):
    """The length of a delta payload at off (packed, bitmap or Rice), or None."""
    v = _varint(b, off, end, 5, 0x80000000)
    if v is None or v[0] < 1 or v[1] >= end or not 1 <= elements <= 240:
        return None
    p = v[1]
    width, coding = b[p] & 0x3F, b[p] >> 6
    p += 1
    if coding == 0:
        need = (elements * width + 7) // 8
    elif coding == 1:
        bm = (elements + 7) // 8
        if p + bm > end:
            return None
        nz = sum(bin(x).count("1") for x in b[p:p + bm])
        need = bm + (nz * width + 7) // 8
    elif coding == 2:                           # Rice: unary z >> k, k bits; 16 zeros escape
        if width > 24:
            return None
        stream = int.from_bytes(b[p:end], "little")
        pos, avail = 0, 8 * (end - p)
        for _ in range(elements):
            q = 0
            while q < 16 and not (stream >> (pos + q)) & 1:
                q += 1
            pos += q + (0 if q == 16 else 1) + (32 if q == 16 else width)
            if pos > avail:
                return None
        need = (pos + 7) // 8
    else:
        return None
    if width > 32 or p + need > end:
        return None
    return p + need - off


def _ack_len(b, off, end, entries):
    p = off
    for _ in range(entries):
        for top in ((1 << 33) - 1, (1 << 32) - 1):
            v = _varint(b, p, end, 5, top)
            if v is None:
                return None
            p = v[1]
    return p - off


def wire_check(b, src=None, dst=None):
    """Why gs_net_deliver at host dst would refuse datagram b before it knows
    the sender (gs_wire_decode, the header's >>wire section), or None: size,
    magic, version, CRC, layout, finite numbers, chunk times >= 0, the
    session (1) and the sender (src, not dst). The proxy runs it on what it forwards unchanged, so
    that a datagram a peer sends and its receiver must refuse is told apart
    from one the proxy broke. Wire format v3: chunk headers coded against the
    chunk before them, payload lengths implied by their contents."""
    if len(b) < 52:
        return "short"
    if len(b) > 1200:
        return "layout"
    if b[:4] != b"GSIM":
        return "magic"
    if b[4] != 3:                   # wire format v3 (v1 and v2 are refused as old)
        return "version"
    end = len(b) - 4
    if zlib.crc32(b[:end]) != struct.unpack_from("<I", b, end)[0]:
        return "checksum"
    n = struct.unpack_from("<H", b, 6)[0]
    if not 1 <= n <= 255:
        return "layout"
    if not all(math.isfinite(v) for v in struct.unpack_from("<3d", b, 24)):
        return "not finite"
    session, sender = struct.unpack_from("<II", b, 8)
    off, t, have_t = 48, 0.0, False
    for _ in range(n):
        if off >= end:
            return "short"
        kind = b[off]
        off += 1
        typ, enc = kind & 3, kind >> 3 & 3   # 0 values, 1 delta, 2 heartbeat, 3 acks
        if kind & 0xC0 or enc == 0 or (typ in (1, 3) and enc != 3):
            return "layout"
        if typ == 3:                         # acks: the host they are for, entries
            if kind & 0x24:
                return "layout"
            v = _varint(b, off, end, 5, 0xFFFFFFFF)
            e = v and _varint(b, v[1], end, 2, 100)
            if not e or e[0] < 1:
                return "layout"
            off = e[1]
            length = _ack_len(b, off, end, e[0])
            if length is None:
                return "layout"
            off += length
            continue
        for _field in range(2):              # object id, sequence: zigzag from the last chunk's
            v = _varint(b, off, end, 5, (1 << 33) - 1)
            if v is None:
                return "layout"
            off = v[1]
        if kind & 4:                         # a time of its own
            if off + 8 > end:
                return "short"
            t, have_t = struct.unpack_from("<d", b, off)[0], True
            off += 8
        elif not have_t:
            return "layout"
        index = 0
        if kind & 0x20:                      # split: index, count, first
            iv = _varint(b, off, end, 3, 0xFFFF)
            cv = iv and _varint(b, iv[1], end, 3, 0xFFFF)
            fv = cv and _varint(b, cv[1], end, 5, 0xFFFFFFFF)
            if not fv or iv[0] >= cv[0] or (iv[0] == 0 and cv[0] == 1 and fv[0] == 0):
                return "layout"
            index, off = iv[0], fv[1]
        elements = 0
        if typ != 2:
            v = _varint(b, off, end, 2, 0xFFFF)
            if v is None:
                return "layout"
            elements, off = v
        if typ == 2 and index:
            return "layout"
        if not math.isfinite(t) or t < 0.0:
            return "time %.3g" % t
        if typ == 2:
            length = 0
        elif typ == 1:
            length = _delta_len(b, off, end, elements)
        elif enc == 3:
            length = _quant_len(b, off, end, elements)
        else:
            length = (8 if enc == 1 else 4) * elements
            if off + length > end:
                return "short"
            vals = struct.unpack_from("<%d%s" % (elements, "d" if enc == 1 else "f"), b, off)
            if not all(math.isfinite(v) for v in vals):
                return "not finite"
        if length is None:
            return "layout"
        off += length
    if off != end:
        return "layout"
    if session != 1:
        return "session %d" % session
    if src is not None and sender != src or sender == dst:
        return "sender %d (from %s to %s)" % (sender, src, dst)
    return None


class Link:
    """One direction of one pair: its faults (changed at any time by the
    scenario) and its counts (kept by the proxy thread)."""
    FAULTS = ("drop", "dup", "reorder", "delay", "jitter", "corrupt", "cut")

    def __init__(self):
        self.clear()
        self.n = dict(got=0, sent=0, dropped=0, cut=0, duplicated=0, reordered=0,
                      corrupted=0, errors=0)

    def clear(self):
        self.drop = 0.0      # probability a datagram is lost
        self.dup = 0.0       # probability it is sent twice
        self.reorder = 0.0   # probability it is held back by `hold` s
        self.hold = 0.030
        self.delay = 0.0     # s added to every datagram
        self.jitter = 0.0    # s, uniform on top of delay (reorders too)
        self.corrupt = 0.0   # probability 1 to 4 of its bytes are changed
        self.cut = False     # nothing passes

    def set(self, **kw):
        for k, v in kw.items():
            if k not in self.FAULTS and k != "hold":
                raise ValueError("no fault %r" % k)
            setattr(self, k, v)

    def describe(self):
        f = []
        if self.cut:
            return "cut"
        for k in ("drop", "dup", "reorder", "corrupt"):
            if getattr(self, k):
                f.append("%s %.0f%%" % (k, 100 * getattr(self, k)))
        if self.delay or self.jitter:
            f.append("delay %.0f+-%.0f ms" % (1e3 * self.delay, 1e3 * self.jitter / 2))
        return ", ".join(f) or "clean"


class Proxy(threading.Thread):
    """Sits between peers `real` ({id: port}); one thread, non-blocking
    sockets, a heap of datagrams to send later."""

    MAX_QUEUE = 20000        # datagrams held at once; more are dropped (counted)

    def __init__(self, real, seed):
        super().__init__(daemon=True)
        self.real = dict(real)
        self.rng = random.Random(seed)
        self.sock, self.port = {}, {}
        self.links = {}
        self.stop_ev = threading.Event()
        self.to = {i: self._zero() for i in real}   # per receiver: corrupted, dup copies sent
        self.lock = threading.Lock()
        self.error = None
        for x in real:
            for y in real:
                if x == y:
                    continue
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 21)
                s.bind((HOST, 0))     # the kernel's choice, held for the run
                s.setblocking(False)
                self.sock[(x, y)], self.port[(x, y)] = s, s.getsockname()[1]
                self.links[(y, x)] = Link()
        self.heap, self.seq = [], 0
        self.down = set()    # peers being restarted: nothing reaches them (counted as cut)

    @staticmethod
    def _zero():
        return dict(corrupted=0, dup=0, sent=0, invalid=0, why={})

    def peer_list(self, y):
        """What peer y is told: (x, port of x's socket for y) for every other x."""
        return [(x, self.port[(x, y)]) for x in self.real if x != y]

    def link(self, src, dst):
        return self.links[(src, dst)]

    def set_all(self, **kw):
        for ln in self.links.values():
            ln.set(**kw)

    def clear_all(self):
        for ln in self.links.values():
            ln.clear()

    def reset_counts(self, dst):
        """Counts of datagrams delivered to dst start again (a restarted peer)."""
        with self.lock:
            self.to[dst] = self._zero()

    def counts(self, dst):
        with self.lock:
            c = dict(self.to[dst])
            c["why"] = dict(c["why"])
            return c

    def totals(self):
        t = {}
        for ln in self.links.values():
            for k, v in ln.n.items():
                t[k] = t.get(k, 0) + v
        return t

    def _corrupt(self, data):
        b = bytearray(data)
        for _ in range(self.rng.randint(1, 4)):
            i = self.rng.randrange(len(b))
            b[i] ^= self.rng.randint(1, 255)        # never 0: always a change
        return bytes(b)

    def _route(self, src, dst, data, now):
        ln = self.links[(src, dst)]
        ln.n["got"] += 1
        if ln.cut or dst in self.down:
            ln.n["cut"] += 1
            return
        r = self.rng.random
        if ln.drop and r() < ln.drop:
            ln.n["dropped"] += 1
            return
        copies = 2 if ln.dup and r() < ln.dup else 1
        for c in range(copies):
            delay = ln.delay + (r() * ln.jitter if ln.jitter else 0.0)
            if ln.reorder and r() < ln.reorder:
                delay += ln.hold
                ln.n["reordered"] += 1
            d, bad = data, False
            if ln.corrupt and len(data) and r() < ln.corrupt:
                d, bad = self._corrupt(data), True
            if len(self.heap) >= self.MAX_QUEUE:
                ln.n["dropped"] += 1
                continue
            self.seq += 1
            heapq.heappush(self.heap, (now + delay, self.seq, src, dst, d, bad, c == 1))

    def _send(self, item):
        _, _, src, dst, d, bad, dup = item
        ln = self.links[(src, dst)]
        if dst in self.down:                         # held back past a kill: never delivered
            ln.n["cut"] += 1
            return
        try:
            self.sock[(src, dst)].sendto(d, (HOST, self.real[dst]))
        except OSError:                              # nobody there (a killed peer), a full buffer
            ln.n["errors"] += 1
            return
        ln.n["sent"] += 1
        why = None if bad else wire_check(d, src, dst)
        with self.lock:
            t = self.to[dst]
            t["sent"] += 1
            if why:                                  # sent as the peer made it, refused all the same
                t["invalid"] += 1
                t["why"][why] = t["why"].get(why, 0) + 1
            if bad:
                ln.n["corrupted"] += 1
                t["corrupted"] += 1
            elif dup:
                ln.n["duplicated"] += 1
                t["dup"] += 1

    def run(self):
        sel = selectors.DefaultSelector()
        try:
            for (x, y), s in self.sock.items():
                sel.register(s, selectors.EVENT_READ, (y, x))   # what arrives here goes y -> x
            while not self.stop_ev.is_set():
                now = time.monotonic()
                timeout = 0.005
                if self.heap:
                    timeout = max(0.0, min(timeout, self.heap[0][0] - now))
                for key, _ in sel.select(timeout):
                    src, dst = key.data
                    for _ in range(256):              # bounded drain per socket
                        try:
                            data = key.fileobj.recv(4096)
                        except (BlockingIOError, InterruptedError):
                            break
                        except OSError:
                            continue                   # an ICMP error from a dead port
                        self._route(src, dst, data, time.monotonic())
                now = time.monotonic()
                n = 0
                while self.heap and self.heap[0][0] <= now and n < 4096:
                    self._send(heapq.heappop(self.heap))
                    n += 1
        except Exception as e:  # a bug here must fail the scenario, not hang it
            self.error = "%s: %s" % (type(e).__name__, e)
        finally:
            sel.close()

    def close(self):
        self.stop_ev.set()
        self.join(timeout=5)
        for s in self.sock.values():
            s.close()


# ---- measuring (series, final_figure: tests/peers.py) ----

series, final_figure = P.series, P.final_figure


def settle_time(ser, since):
    """(the first wall after which every figure is under TOL, the peak from
    `since` on); None when the last second is not under TOL."""
    after = [(w, d) for w, d in ser if w >= since]
    if not after:
        return None, float("nan")
    peak = max(d for _, d in after)
    last_bad = None
    for k, (w, d) in enumerate(after):
        if not d < TOL:
            last_bad = k
    if last_bad is None:
        return after[0][0], peak
    if last_bad + 1 >= len(after):
        return None, peak
    at = after[last_bad + 1][0]
    if after[-1][0] - at < HOLD:
        return None, peak
    return at, peak


def udp_drops(ports):
    """{port: datagrams the kernel dropped at that UDP socket} from /proc/net/udp."""
    out = {}
    try:
        with open("/proc/net/udp") as f:
            next(f)
            for line in f:
                c = line.split()
                port = int(c[1].split(":")[1], 16)
                if port in ports:
                    out[port] = out.get(port, 0) + int(c[-1])
    except (OSError, ValueError, IndexError, StopIteration):
        pass
    return out


def rss_kib(pid):
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    return None


def non_finite(p):
    """Problems of one peer's output: lines that are not JSON (printf's "nan"
    is not), and numbers that are not finite anywhere in a line."""
    bad = []
    if p.bad:
        bad.append("peer %d printed %d non-JSON lines, first %r" % (p.id, len(p.bad), p.bad[0][:100]))

    def walk(o):
        if isinstance(o, dict):
            return any(walk(v) for v in o.values())
        if isinstance(o, list):
            return any(walk(v) for v in o)
        return isinstance(o, float) and not math.isfinite(o)
    n = sum(1 for o in p.lines if walk(o))
    if n:
        bad.append("peer %d: %d lines with a NaN or infinity" % (p.id, n))
    return bad


def first_wall(p, t_at_least=None):
    """The wall time of p's first line (whose t >= t_at_least), or None."""
    for w, t, _ in p.samples():
        if t_at_least is None or t >= t_at_least:
            return w
    return None


class Failed(Exception):
    pass


# ---- a scenario's run ----

class Run:
    """Peers `ids` behind a proxy; the scenario drives it with at(), kill(),
    restart(); check() judges it."""

    def __init__(self, exe, name, ids, duration, probe_until, extra=None, seed=1,
                 direct=False, stats_every=STATS):
        self.exe, self.name, self.ids = exe, name, list(ids)
        self.direct, self.stats_every = direct, stats_every
        self.duration, self.probe_until = duration, probe_until
        self.extra = extra or {}
        self.real = dict(zip(ids, P.free_ports(len(ids))))
        self.proxy = Proxy(self.real, seed)
        self.proxy.start()
        self.peers = {}
        self.retired = []          # peers killed on purpose
        self.fault = None          # (start wall, end wall)
        self.what = ""             # the fault, for the table
        self.notes = []
        self.drops = {}            # port: kernel drops seen (the largest)
        self.t_start = time.monotonic()
        # Nothing reaches a peer before its first line: ghostpeer opens its
        # socket (and the gather thread) before it adds its peers, and what
        # arrives between the two is refused as "unknown sender" (README).
        self.proxy.down.update(ids)
        for i in self.ids:
            self.peers[i] = self._peer(i, duration)
        self.w0 = self._wait_first(list(self.peers.values()))

    def _peer(self, i, duration):
        args = ["--probe-until", "%g" % self.probe_until] + list(self.extra.get(i, []))
        links = [(k, self.real[k]) for k in self.ids if k != i] if self.direct \
            else self.proxy.peer_list(i)
        return P.Peer(self.exe, i, self.real[i], links, duration, args, self.stats_every)

    def _wait_first(self, peers, limit=15.0):
        """Waits for every peer's first line (each is let through the proxy
        when it has printed it); the latest one's wall time."""
        end = time.monotonic() + limit
        while time.monotonic() < end:
            ws = [first_wall(p) for p in peers]
            for p, w in zip(peers, ws):
                if w is not None:
                    self.proxy.down.discard(p.id)
            if all(w is not None for w in ws):
                return max(ws)
            if any(p.proc.poll() is not None for p in peers):
                break
            time.sleep(0.02)
        raise Failed("peers not up after %g s: %s" % (limit, "; ".join(p.describe() for p in peers)))

    def at(self, s):
        """Sleeps until s seconds after the peers' first lines (bounded)."""
        left = self.w0 + s - time.time()
        while left > 0:
            if remaining() < 5:
                raise Failed("the global deadline")
            time.sleep(min(left, 0.2))
            self.sample()
            left = self.w0 + s - time.time()

    def sample(self):
        for port, n in udp_drops(set(self.real.values())).items():
            self.drops[port] = max(self.drops.get(port, 0), n)

    def kill(self, i):
        p = self.peers.pop(i)
        self.proxy.down.add(i)
        p.proc.kill()                                # SIGKILL
        p.wait(5)
        p.save(self.name)
        self.retired.append(p)
        return time.time()

    def restart(self, i):
        """Starts peer i again for the rest of the run; until its first line
        nothing reaches it (as at the start), so the proxy's counts of what it
        delivered to it match what the new process can count."""
        left = self.duration - (time.time() - self.w0)
        self.proxy.down.add(i)
        self.proxy.reset_counts(i)
        p = self._peer(i, max(left, 4.0))
        self.peers[i] = p
        try:
            return self._wait_first([p])
        finally:
            self.proxy.down.discard(i)

    def close(self):
        try:
            self.proxy.close()
        finally:
            P.kill_all()

    # -- judging --

    def finish(self):
        """Waits for the peers; every problem of the run, as a list."""
        problems = []
        try:
            P.finish(list(self.peers.values()), self.duration + 10)
        except P.TestFailure as e:
            problems.append(str(e))
        self.sample()
        self.proxy.stop_ev.set()
        self.proxy.join(timeout=5)
        if self.proxy.error:
            problems.append("proxy: " + self.proxy.error)
        for p in self.retired + list(self.peers.values()):
            problems += non_finite(p)
        return problems

    def counted(self):
        """(text, problems): corrupted and duplicated datagrams against what
        each receiver counted."""
        text, short, problems = [], [], []
        for i, p in sorted(self.peers.items()):
            fin = p.final()
            if not fin:
                continue
            c = self.proxy.counts(i)
            unknown = int(fin.get("totals", {}).get("rejected_unknown", -1))
            per_peer = sum(int(v.get("rejected", 0)) for v in fin.get("peers", {}).values())
            drops = self.drops.get(self.real[i], 0)
            want = c["corrupted"] + c["invalid"]
            text.append("to %d: corrupted %d%s/rejected %d, dups %d/rejected %d%s"
                        % (i, c["corrupted"],
                           " + %d invalid as sent (%s)" % (c["invalid"], ", ".join(
                               "%s: %d" % kv for kv in sorted(c["why"].items())))
                           if c["invalid"] else "", unknown, c["dup"], per_peer,
                           ", kernel drops %d" % drops if drops else ""))
            short.append("%d: %d/%d, %d/%d" % (i, want, unknown, c["dup"], per_peer))
            if not self.direct and not (want - drops <= unknown <= want):
                problems.append("peer %d counted %d datagrams rejected before knowing the sender, "
                                "the proxy corrupted %d sent to it, and %d more were invalid as "
                                "sent (kernel drops %d)" % (i, unknown, c["corrupted"],
                                                            c["invalid"], drops))
            if self.check_dups and not (c["dup"] - drops <= per_peer <= c["dup"]):
                problems.append("peer %d counted %d datagrams of its peers rejected, the proxy "
                                "delivered %d duplicates to it (kernel drops %d)"
                                % (i, per_peer, c["dup"], drops))
        self.counts_short = "; ".join(short)
        return "; ".join(text), problems

    check_dups = False
    counts_short = "-"

    def converged(self, since):
        """(seconds from `since` to convergence or None, peak during the fault,
        peak after, final figure, problems): every pair of live peers."""
        peers = [self.peers[i] for i in sorted(self.peers)]
        conv, peak_in, peak_after, final, problems = 0.0, 0.0, 0.0, 0.0, []
        f0 = self.fault[0] if self.fault else since
        for a in range(len(peers)):
            for b in range(a + 1, len(peers)):
                pa, pb = peers[a], peers[b]
                ser, raw = series(pa, pb), series(pa, pb, resolvable=False)
                peak_in = max([peak_in] + [d for w, d in raw if f0 <= w < since])
                at, _ = settle_time(ser, since)
                peak = max([d for w, d in raw if w >= since] or [float("nan")])
                peak_after = max(peak_after, peak if math.isfinite(peak) else 0.0)
                try:
                    fig, n = final_figure(pa, pb)
                    if fig is None:
                        problems.append("peers %d-%d: no line of the last second can be judged "
                                        "(the scene moved more than %g m between lines)"
                                        % (pa.id, pb.id, TOL))
                        final = float("nan")
                    else:
                        final = max(final, fig)
                        if not fig < TOL:
                            problems.append("peers %d-%d %.3g m apart over the last second "
                                            "(%d lines judged)" % (pa.id, pb.id, fig, n))
                except (P.TestFailure, IndexError) as e:
                    problems.append(str(e))
                    final = float("nan")
                if at is None:
                    problems.append("peers %d-%d never stayed within %g m after the fault (peak %.3g m)"
                                    % (pa.id, pb.id, TOL, peak))
                    conv = None
                if at is None or problems:
                    problems.append("peers %d-%d: %s" % (pa.id, pb.id, diagnose(pa, pb)))
                elif conv is not None:
                    conv = max(conv, at - since)
        return conv, peak_in, peak_after, final, problems

    def probes_stopped(self):
        """The wall time by which every live peer's t passed --probe-until."""
        ws = [first_wall(p, self.probe_until) for p in self.peers.values()]
        return max(ws) if ws and all(w is not None for w in ws) else None


def diagnose(pa, pb):
    """For a failed convergence: what peers.py prints, and the clocks."""
    try:
        r = P.compare(pa, pb)
        S = [o for o in pa.lines if not o.get("final")]
        gaps = sorted(float(o["peers"][str(pb.id)]["gap"]) for o in S[len(S) // 2:]
                      if str(pb.id) in o.get("peers", {}))
        return ("over the last second nearest-line %.3g m, at equal t %.3g m, t offset %+.3f s, "
                "fastest entry %.3g/%.3g m/s; gap of %d seen by %d over the second half: "
                "median %+.4f s" % (r["nearest"], r["same_t"], P.t_offset(pa, pb), P.speed(pa),
                                    P.speed(pb), pb.id, pa.id,
                                    gaps[len(gaps) // 2] if gaps else float("nan")))
    except (P.TestFailure, IndexError, KeyError, ValueError, ZeroDivisionError) as e:
        return "no diagnosis (%s)" % e


def remaining():
    return DEADLINE - (time.monotonic() - T0)


# ---- the scenarios ----

class Timing:
    def __init__(self, duration, f0, f1):
        self.duration, self.f0, self.f1 = duration, f0, f1


FULL = Timing(14.0, 2.0, 5.0)    # s: run, fault from f0 to f1 after the first lines
SHORT = Timing(10.0, 1.5, 3.5)   # the probes move until f1 (simulation time)


def judge(run, since=None):
    """The scenario's verdict: a row for the table."""
    problems = run.finish()
    counts, cp = run.counted()
    problems += cp
    stopped = run.probes_stopped()
    if since is None:
        since = run.fault[1]
    if stopped is not None:
        since = max(since, stopped)
    conv, peak_in, peak_after, final, vp = run.converged(since)
    problems += vp
    return dict(name=run.name, what=run.what, ok=not problems, problems=problems,
                conv=conv, peak_in=peak_in, peak_after=peak_after, final=final, counts=counts,
                counts_short=run.counts_short, notes=run.notes, proxy=run.proxy.totals())


def link_fault(what, ids=(1, 2), check_dups=False, **faults):
    def scenario(exe, name, tm):
        run = Run(exe, name, ids, tm.duration, tm.f1)
        try:
            run.check_dups = check_dups
            run.what = what
            run.at(tm.f0)
            run.proxy.set_all(**faults)
            a = time.time()
            run.at(tm.f1)
            run.proxy.clear_all()
            run.fault = (a, time.time())
            t = run.proxy.totals()
            run.notes.append("proxy: %d datagrams, %d dropped, %d cut, %d duplicated, %d held back, "
                             "%d corrupted" % (t["got"], t["dropped"], t["cut"], t["duplicated"],
                                               t["reordered"], t["corrupted"]))
            return judge(run)
        finally:
            run.close()
    return scenario


def sc_control(exe, name, tm):
    run = Run(exe, name, [1, 2], tm.duration, tm.f1)
    try:
        run.what = "none (the same timeline, no fault)"
        run.at(tm.f1)
        run.fault = (run.w0 + tm.f0, time.time())
        return judge(run)
    finally:
        run.close()


def sc_control_direct(exe, name, tm):
    run = Run(exe, name, [1, 2], tm.duration, tm.f1, direct=True)
    try:
        run.what = "none, and no proxy: the peers talk directly"
        run.notes.append("counts not judged without the proxy (a peer may refuse its peer's "
                         "first datagrams as from an unknown sender: README)")
        run.at(tm.f1)
        run.fault = (run.w0 + tm.f0, time.time())
        return judge(run)
    finally:
        run.close()


def sc_kill(exe, name, tm):
    run = Run(exe, name, [1, 2], tm.duration, tm.f1)
    try:
        down = 1.5
        run.what = "peer 2 SIGKILLed, restarted %.1f s later" % down
        run.at(tm.f0)
        a = run.kill(2)
        run.at(tm.f0 + down)
        up = run.restart(2)
        run.fault = (a, up)
        run.notes.append("peer 2 up again %.2f s after the kill" % (up - a))
        return judge(run)
    finally:
        run.close()


def sc_clock(step):
    def scenario(exe, name, tm):
        # On the local clock the scene can take 10 s and more after a +2 s
        # step to come within 1 mm: while the stepped host catches up, the
        # other follows it in jumps and the probes' catch-up can throw a
        # sphere off the cloth, which then rolls on the ground for seconds.
        # A 10 s run would judge it before it settled, so it always gets
        # the full suite's timing (on the session clock it converges within
        # 0.6 s and the longer run costs 4 s).
        tm = FULL
        run = Run(exe, name, [1, 2], tm.duration, tm.f1,
                  extra={2: ["--clock-step", "%g:%g" % (tm.f0, step)]})
        try:
            run.what = "peer 2's pacing clock steps %+g s at %g s" % (step, tm.f0)
            run.at(tm.f1)
            a = run.w0 + tm.f0
            run.fault = (a, a)
            res = judge(run, since=a)
            said = [e for e in run.peers[2].err if "stepped" in e or "advance" in e]
            res["notes"].append("peer 2 said: " + " | ".join(said[:3]) if said else
                                "peer 2 said nothing of the step")
            return res
        finally:
            run.close()
    return scenario


def sc_wild(speed, seconds=1.0):
    def scenario(exe, name, tm):
        at = tm.f1 - seconds
        run = Run(exe, name, [1, 2], tm.duration, tm.f1,
                  extra={2: ["--probe-wild", "%g:%g:%g" % (at, seconds, speed)]})
        try:
            run.what = "peer 2's probe at %g m/s (set by hand) for %g s" % (speed, seconds)
            run.at(tm.f1)
            run.at(tm.f1 + 1.0)
            p2 = run.peers[2]
            a, b = first_wall(p2, at), first_wall(p2, at + seconds)
            run.fault = (a or run.w0 + at, b or time.time())
            return judge(run)
        finally:
            run.close()
    return scenario


SCENARIOS = [
    # name, full, short, function
    ("control", True, False, sc_control),
    ("control-direct", True, False, sc_control_direct),
    ("drop", True, False, link_fault("30% of datagrams dropped both ways", drop=0.3)),
    ("duplicate", True, False, link_fault("30% duplicated both ways", check_dups=True, dup=0.3)),
    ("reorder", True, False, link_fault("30% held back 30 ms both ways", reorder=0.3)),
    ("delay", True, False, link_fault("150 ms + 0..100 ms jitter both ways", delay=0.15, jitter=0.1)),
    ("corrupt", True, False, link_fault("10% with 1-4 bytes changed both ways", corrupt=0.1)),
    ("cut", True, True, link_fault("link cut both ways", cut=True)),
    ("bad-link", False, True, link_fault("drop 20%, dup 10%, reorder 10%, 50+-25 ms, corrupt 5%",
                                          drop=0.2, dup=0.1, reorder=0.1, delay=0.05, jitter=0.05,
                                          corrupt=0.05)),
    ("bad-link-3", True, False, link_fault("3 peers: drop 20%, dup 10%, reorder 10%, 50+-25 ms, "
                                            "corrupt 5%", ids=(1, 2, 3), drop=0.2, dup=0.1,
                                            reorder=0.1, delay=0.05, jitter=0.05, corrupt=0.05)),
    ("kill", True, True, sc_kill),
    # clock-fwd is in the short suite on the session clock only (SESSION:
    # GHOSTPEER_ARGS has --sync replay or --clock session). On the local
    # clock a +2 s step is 2 s the world is told to run at once, and the
    # other host follows it in jumps that can throw a sphere off the cloth:
    # it can take 10 s and more to converge (README, Faults and soak). The session
    # clock reads the world's own clock and absorbs the step.
    ("clock-fwd", True, "session", sc_clock(2.0)),
    ("clock-back", True, True, sc_clock(-2.0)),
    ("wild-probe", True, True, sc_wild(200.0)),
]


def mm(x):
    return "-" if x is None or not math.isfinite(x) else "%.3g" % (1e3 * x)


def table(rows):
    head = ("scenario", "result", "fault", "peak during", "peak after", "converged",
            "final", "to peer: bad sent/refused, dups sent/refused", "time")
    body = []
    for r in rows:
        body.append((r["name"], "ok" if r["ok"] else "FAILED", r["what"][:48],
                     mm(r.get("peak_in")) + " mm", mm(r.get("peak_after")) + " mm",
                     "-" if r.get("conv") is None else "%.2f s" % r["conv"],
                     mm(r.get("final")) + " mm", r.get("counts_short", "-"), "%.0f s" % r["secs"]))
    widths = [max(len(str(x[k])) for x in [head] + body) for k in range(len(head))]
    lines = ["  ".join(str(x[k]).ljust(widths[k]) for k in range(len(head))).rstrip()
             for x in [head] + body]
    lines.insert(1, "  ".join("-" * w for w in widths))
    lines.append("peak during: the largest digest difference of any pair (series(): at the nearest "
                 "t within %.1f ms) from the fault's start to its end;" % (1e3 * SHIFT))
    lines.append("peak after / converged: from the fault's end (and the probes' stop) on; "
                 "converged: the time until under 1 mm for good;")
    lines.append("final: over the last second; bad sent: corrupted by the proxy (+ invalid as "
                 "sent), refused: the receiver's rejected_unknown;")
    lines.append("dups: copies the proxy delivered, and the receiver's rejected from its peers "
                 "(a late datagram of a restarted sender's previous run counts too).")
    return "\n".join(lines)


def in_short(sh):
    """Is a scenario whose short field is sh in this run's short suite?"""
    return sh is True or (sh == "session" and SESSION)


def run_scenarios(exe, short, want):
    tm = SHORT if short else FULL
    todo = [(n, f) for n, full, sh, f in SCENARIOS
            if ((n in want) if want else (in_short(sh) if short else full))]
    return [run_one(exe, name, fn, tm) for name, fn in todo]


def run_one(exe, name, fn, tm):
    P._current[0] = "faults-" + name
    t = time.monotonic()
    if remaining() < tm.duration + 20:
        r = dict(name=name, what="not run: %.0f s left of the deadline" % remaining(),
                 ok=False, problems=["not run"], counts="")
    else:
        try:
            r = fn(exe, name, tm)
        except Failed as e:
            r = dict(name=name, what="", ok=False, problems=[str(e)], counts="")
        except Exception as e:  # a bug here: the scenario fails, the suite goes on
            r = dict(name=name, what="", ok=False, counts="",
                     problems=["%s: %s" % (type(e).__name__, e)])
        finally:
            P.kill_all()
    r["secs"] = time.monotonic() - t
    conv = r.get("conv")
    verdict = "ok" if r["ok"] else "FAILED"
    print("faults: %s ... %s (%s; peak %s mm during, converged %s after the fault; "
          "final %s mm; %s%s) %.1f s%s" % (
              name, verdict, r["what"], mm(r.get("peak_in")),
              "-" if conv is None else "%.2f s" % conv, mm(r.get("final")),
              r.get("counts") or "no counts",
              "; " + "; ".join(r.get("notes", [])) if r.get("notes") else "", r["secs"],
              "\n    " + "\n    ".join(r["problems"]) if r["problems"] else ""))
    sys.stdout.flush()
    return r


# ---- the soak ----

SOAK_FAULTS = ("drop", "dup", "reorder", "delay", "corrupt", "cut")


def soak_fault(rng, kind):
    """One fault's settings, drawn at random."""
    if kind == "drop":
        return dict(drop=rng.uniform(0.1, 0.5))
    if kind == "dup":
        return dict(dup=rng.uniform(0.1, 0.4))
    if kind == "reorder":
        return dict(reorder=rng.uniform(0.1, 0.4), hold=rng.uniform(0.01, 0.06))
    if kind == "delay":
        return dict(delay=rng.uniform(0.02, 0.2), jitter=rng.uniform(0.0, 0.1))
    if kind == "corrupt":
        return dict(corrupt=rng.uniform(0.02, 0.2))
    return dict(cut=True)


def median(xs):
    xs = sorted(xs)
    return xs[len(xs) // 2] if xs else float("nan")


def run_soak(exe, seconds):
    """Four peers, rolling faults on every link, kills and restarts; memory,
    divergence, counts and the end state judged. Returns True when all hold."""
    ids = [1, 2, 3, 4]
    quiet = min(30.0, seconds / 4)      # s at the end: no faults, probes parked
    faulty = seconds - quiet
    kill_every = max(20.0, min(60.0, faulty / 4))
    rng = random.Random(8)
    print("soak: 4 peers for %.0f s: a new fault every 3 s on a random link for 2-8 s (%s), "
          "a SIGKILL and restart every %.0f s (never peer 1); the last %.0f s quiet, probes parked"
          % (seconds, ", ".join(SOAK_FAULTS), kill_every, quiet))
    sys.stdout.flush()
    run = Run(exe, "soak", ids, seconds, faulty, stats_every=0.1)
    active = {k: [] for k in run.proxy.links}   # link: [(end wall, settings)]
    rss = {}                                      # (id, incarnation): [(s into the run, KiB)]
    incarnation = {i: 0 for i in ids}
    kinds = {k: 0 for k in SOAK_FAULTS}
    kills = []
    ok = True
    problems = []

    def apply(key):
        ln = run.proxy.links[key]
        ln.clear()
        for _, kw in active[key]:
            ln.set(**kw)

    try:
        now = time.time()
        next_fault, next_kill, next_rss = now + 2.0, now + kill_every, now
        n_loop = 0
        while time.time() < run.w0 + seconds - 0.5 and n_loop < 100000:
            n_loop += 1
            if remaining() < 20:
                raise Failed("the global deadline")
            now = time.time()
            for key in active:                    # faults that ended
                if any(end <= now for end, _ in active[key]):
                    active[key] = [(e, kw) for e, kw in active[key] if e > now]
                    apply(key)
            if now < run.w0 + faulty:
                if now >= next_fault:
                    kind = rng.choice(SOAK_FAULTS)
                    src, dst = rng.sample(ids, 2)
                    both = rng.random() < 0.5
                    kw = soak_fault(rng, kind)
                    end = now + rng.uniform(2.0, 8.0)
                    for key in [(src, dst)] + ([(dst, src)] if both else []):
                        active[key].append((min(end, run.w0 + faulty), kw))
                        apply(key)
                    kinds[kind] += 1
                    next_fault = now + 3.0
                if now >= next_kill and now + 15 < run.w0 + faulty:
                    victim = rng.choice(ids[1:])
                    a = run.kill(victim)
                    run.at(now - run.w0 + rng.uniform(1.0, 2.5))
                    up = run.restart(victim)
                    incarnation[victim] += 1
                    kills.append((victim, a - run.w0, up - a))
                    next_kill = time.time() + kill_every
            else:
                for key in active:
                    if active[key]:
                        active[key] = []
                        apply(key)
            if now >= next_rss:
                for i, p in run.peers.items():
                    kib = rss_kib(p.proc.pid)
                    if kib is not None and p.proc.poll() is None:
                        rss.setdefault((i, incarnation[i]), []).append((now - run.w0, kib))
                run.sample()
                next_rss = now + 1.0
            time.sleep(0.1)
        run.proxy.clear_all()

        problems += run.finish()
        counts, cp = run.counted()
        problems += cp

        # memory: each incarnation that lived long enough, after its first minute or sixth
        mem_rows = []
        for (i, inc), xs in sorted(rss.items()):
            span = xs[-1][0] - xs[0][0] if xs else 0.0
            if span < 60.0:
                continue
            warm = xs[0][0] + max(min(60.0, span / 6), 10.0)
            xs = [x for x in xs if x[0] >= warm]
            third = max(1, len(xs) // 3)
            first, last = median([k for _, k in xs[:third]]), median([k for _, k in xs[-third:]])
            grew = last - first
            flat = grew <= 0.2 * first + 4096
            mem_rows.append("peer %d%s: %d -> %d KiB over %.0f s (%+d KiB) %s"
                            % (i, "" if inc == 0 else " (restart %d)" % inc, first, last, span,
                               grew, "flat" if flat else "GROWING"))
            if not flat:
                problems.append("peer %d's resident memory grew from %d to %d KiB" % (i, first, last))
        if not mem_rows:
            problems.append("no peer lived 60 s to judge its memory")

        # divergence over the run: every pair of processes alive at once,
        # leaving out the 3 s after a (re)start (a joining peer takes the state)
        procs = run.retired + list(run.peers.values())
        by_time = {}
        for a in range(len(procs)):
            for b in range(a + 1, len(procs)):
                pa, pb = procs[a], procs[b]
                if pa.id == pb.id:
                    continue
                sa, sb = first_wall(pa), first_wall(pb)
                if sa is None or sb is None:
                    continue
                for w, d in series(pa, pb, start=max(sa, sb) + 3.0, resolvable=False):
                    k = min(int((w - run.w0) / 30.0), max(0, int(seconds / 30.0) - 1))
                    by_time.setdefault(k, []).append(d)
        win = []
        for k in sorted(by_time):
            ds = sorted(by_time[k])
            win.append((k * 30, median(ds), ds[int(0.95 * (len(ds) - 1))], ds[-1]))
        peak = max((w[3] for w in win), default=float("nan"))
        faulted = [w for w in win if w[0] + 30 <= faulty]
        if not math.isfinite(peak) or peak > 1.5:
            problems.append("divergence not bounded: %.3g m at worst (the scene spans 1.5 m)" % peak)
        if len(faulted) >= 3:
            third = max(1, len(faulted) // 3)
            m0 = median([w[1] for w in faulted[:third]])
            m1 = median([w[1] for w in faulted[-third:]])
            if m1 > 2 * m0 + 1e-3:
                problems.append("divergence grows: window medians %.3g m in the first third, %.3g m "
                                "in the last" % (m0, m1))

        # the end: every pair of live peers within 1 mm over the last second
        live = [run.peers[i] for i in sorted(run.peers)]
        end_worst, end_txt = 0.0, []
        for a in range(len(live)):
            for b in range(a + 1, len(live)):
                fig, n = final_figure(live[a], live[b])
                if fig is None:
                    problems.append("peers %d-%d: no line of the last second can be judged"
                                    % (live[a].id, live[b].id))
                    end_worst = float("nan")
                    continue
                end_worst = max(end_worst, fig)
                if not fig < TOL:
                    problems.append("peers %d-%d %.3g m apart at the end (%d lines at the same "
                                    "t); %s" % (live[a].id, live[b].id, fig, n,
                                                diagnose(live[a], live[b])))
        conv = []
        for a in range(len(live)):
            for b in range(a + 1, len(live)):
                at, _ = settle_time(series(live[a], live[b]), run.w0 + faulty)
                conv.append(None if at is None else at - (run.w0 + faulty))
        t = run.proxy.totals()
        print()
        print("soak summary (%.0f s, 4 peers)" % seconds)
        print("  faults started: %s; proxy: %d datagrams, %d dropped, %d cut, %d duplicated, "
              "%d held back, %d corrupted" % (", ".join("%s %d" % kv for kv in kinds.items()),
                                             t["got"], t["dropped"], t["cut"], t["duplicated"],
                                             t["reordered"], t["corrupted"]))
        print("  kills: %s" % (", ".join("peer %d at %.0f s (up %.2f s later)" % k for k in kills)
                               or "none"))
        print("  counts at the end (this incarnation): %s" % counts)
        print("  resident memory: %s" % "; ".join(mem_rows))
        print("  divergence, every pair at the nearest t within the time band, per 30 s (start: median / p95 / max, mm):")
        for w0, med, p95, mx in win:
            print("    %4d s  %8.3f %8.3f %8.3f%s" % (w0, 1e3 * med, 1e3 * p95, 1e3 * mx,
                                                   "   (quiet)" if w0 + 30 > faulty else ""))
        print("  end: worst pair %s mm over the last second; converged %s after the faults "
              "and probes stopped" % (mm(end_worst), "never (some pair)" if None in conv else
                                      "%.2f s" % max(conv) if conv else "-"))
    except Failed as e:
        problems.append(str(e))
    finally:
        run.close()
    for pr in problems:
        print("  FAILED: " + pr)
    ok = not problems
    print("soak: %s (%.1f s)" % ("ok" if ok else "FAILED", time.monotonic() - T0))
    return ok


# ---- main ----

def _watchdog(limit):
    time.sleep(max(0.0, limit - (time.monotonic() - T0)))
    sys.stdout.write("FAILED: faults: the global deadline of %g s passed; killing every peer\n" % limit)
    sys.stdout.flush()
    P.kill_all()
    os._exit(1)


def main(argv):
    global DEADLINE
    args = argv[1:]
    if not args or args[0].startswith("-"):
        sys.stderr.write("usage: python3 tests/faults.py PATH/TO/ghostpeer [--short] [SCENARIO...]\n"
                         "       python3 tests/faults.py PATH/TO/ghostpeer --soak SECONDS\n")
        return 2
    exe, rest = args[0], args[1:]
    short = "--short" in rest
    rest = [a for a in rest if a != "--short"]
    soak = None
    if rest[:1] == ["--soak"]:
        try:
            soak = float(rest[1])
            if not 30 <= soak <= 3600:
                raise ValueError
        except (IndexError, ValueError):
            sys.stderr.write("faults.py: --soak SECONDS, 30 to 3600\n")
            return 2
        rest = rest[2:]
    names = [n for n, _, _, _ in SCENARIOS]
    unknown = [w for w in rest if w not in names]
    if unknown:
        sys.stderr.write("faults.py: unknown scenario(s) %s; scenarios: %s\n"
                         % (", ".join(unknown), ", ".join(names)))
        return 2
    if not (os.path.isfile(exe) and os.access(exe, os.X_OK)):
        print("FAILED: faults: %s is not an executable (make build/ghostpeer)" % exe)
        return 1
    if soak is not None:
        DEADLINE = soak + 150.0
    elif short:
        DEADLINE = 150.0
    P.DEADLINE, P.T0 = DEADLINE, T0        # Peer.wait() bounds itself by peers.py's deadline
    threading.Thread(target=_watchdog, args=(DEADLINE,), daemon=True).start()
    try:
        if soak is not None:
            ok = run_soak(exe, soak)
        else:
            rows = run_scenarios(exe, short, rest)
            print()
            print(table(rows))
            failed = [r["name"] for r in rows if not r["ok"]]
            label = (["short"] if short else []) + ([" ".join(P.EXTRA)] if P.EXTRA else [])
            print("faults%s: %d scenarios, %d passed, %d failed%s (%.1f s)"
                  % (" (%s)" % ", ".join(label) if label else "",
                     len(rows), len(rows) - len(failed), len(failed),
                     ": " + ", ".join(failed) if failed else "", time.monotonic() - T0))
            ok = not failed
    finally:
        P.kill_all()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
