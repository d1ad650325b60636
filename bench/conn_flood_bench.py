"""Idle connection flood under a 1024 file limit (issues 21, 36.1): do the API and
rotctld keep answering, and do new clients and the dashboard get in (within 2 s),
while 1300 idle TCP connections are held?

Each case starts a fresh ``urc run`` (simulator, tartu-urc, rotctld on TCP) under
``prlimit --nofile=N:N`` (default 1024, systemd's usual limit), measures a baseline,
then opens ``--conns`` idle connections (to rotctld, to the HTTP port, or half to each)
and holds them for ``--hold-s`` seconds without sending a byte. Throughout, four probes
run every ``PROBE_PERIOD_S``:

* ``p`` on a rotctld connection opened before the flood (an existing client),
* ``GET /api/status`` on a keep-alive HTTP connection opened before the flood,
* ``p`` on a fresh rotctld connection each time (a client arriving during the flood),
* ``GET /api/status`` on a fresh HTTP connection each time,
* ``GET /`` (the dashboard's page) on a fresh HTTP connection each time.

Reported per probe and phase: answered/asked, the round trip p50/p99 (ms), and the
longest time without an answer during the flood ("gap s": from the flood's start or the
last answer to the next answer; the goal is under 2 s); per case:
flood connections established, how many of them urc had closed by the end of the hold,
the I/O process's open descriptors at the peak, the bytes urc logged during the flood,
and the faults latched.

Prints a table, writes JSON (default bench/results/conn-flood.json). Never gates CI.
Usage: python bench/conn_flood_bench.py [--conns 1300] [--hold-s 30] [--nofile 1024] [--json PATH]
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import resource
import select
import socket
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from bench_report import write_json  # noqa: E402
from urc_process import UrcProcess, free_port, stop_process_group  # noqa: E402

PROBE_PERIOD_S = 0.1
PROBE_TIMEOUT_S = 5.0
BASELINE_S = 5.0
CONNECT_WINDOW_S = 10.0


class Probe(threading.Thread):
    """Runs one kind of request every PROBE_PERIOD_S; records (start, rtt or None)."""

    def __init__(self, name: str, ask):
        super().__init__(daemon=True, name=name)
        self.ask = ask
        self.results: list[tuple[float, float | None]] = []
        self.running = True

    def run(self) -> None:
        while self.running:
            t0 = time.monotonic()
            try:
                self.ask()
                self.results.append((t0, time.monotonic() - t0))
            except Exception:
                self.results.append((t0, None))
            time.sleep(max(0.0, t0 + PROBE_PERIOD_S - time.monotonic()))

    def between(self, t0: float, t1: float) -> dict:
        got = [r for t, r in self.results if t0 <= t < t1]
        ok = sorted(r for r in got if r is not None)

        def q(f: float) -> float:
            return round(1000 * ok[min(len(ok) - 1, int(f * len(ok)))], 2) if ok else math.nan
        return {"asked": len(got), "answered": len(ok), "p50_ms": q(0.5), "p99_ms": q(0.99),
                "max_ms": round(1000 * ok[-1], 2) if ok else math.nan}

    def longest_gap_s(self, t0: float, t1: float) -> float:
        """The longest time within [t0, t1) with no answer: from t0 or an answer's
        arrival to the next answer's arrival (or t1)."""
        arrivals = [t + r for t, r in self.results if r is not None and t0 <= t + r < t1]
        edges = [t0, *arrivals, t1]
        return round(max(b - a for a, b in zip(edges, edges[1:])), 2)


def _rotctld_p(sock: socket.socket) -> None:
    sock.sendall(b"p\n")
    buf = b""
    while buf.count(b"\n") < 2:
        chunk = sock.recv(256)
        if not chunk:
            raise ConnectionError("closed")
        buf += chunk
    if buf.startswith(b"RPRT"):
        raise RuntimeError(buf.decode(errors="replace"))


def _connect(port: int) -> socket.socket:
    s = socket.create_connection(("127.0.0.1", port), timeout=PROBE_TIMEOUT_S)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


def make_probes(http_url: str, rotctld_port: int) -> list[Probe]:
    held_sock = _connect(rotctld_port)
    held_http = httpx.Client(timeout=PROBE_TIMEOUT_S, limits=httpx.Limits(max_keepalive_connections=1))
    held_http.get(http_url + "/api/status").raise_for_status()  # the connection is open now

    def fresh_p() -> None:
        with _connect(rotctld_port) as s:
            _rotctld_p(s)

    def fresh_get(path: str) -> None:  # a bare request: an httpx.Client costs ~0.3 s to make
        with _connect(int(http_url.rsplit(":", 1)[1])) as s:
            s.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n".encode())
            reply = b""
            while chunk := s.recv(65536):
                reply += chunk
            if not reply.startswith(b"HTTP/1.1 200"):
                raise RuntimeError(reply[:40].decode(errors="replace"))

    return [Probe("p (held)", lambda: _rotctld_p(held_sock)),
            Probe("status (held)", lambda: held_http.get(http_url + "/api/status").raise_for_status()),
            Probe("p (new conn)", fresh_p),
            Probe("status (new conn)", lambda: fresh_get("/api/status")),
            Probe("page (new conn)", lambda: fresh_get("/"))]


def open_idle(ports: list[int], n: int) -> list[socket.socket]:
    """``n`` non-blocking connects spread over ``ports``; returns those established
    within CONNECT_WINDOW_S (the rest are closed)."""
    pending: dict[int, socket.socket] = {}
    for i in range(n):
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setblocking(False)
        err = s.connect_ex(("127.0.0.1", ports[i % len(ports)]))
        if err not in (0, errno.EINPROGRESS):
            s.close()
            continue
        pending[s.fileno()] = s
    done: list[socket.socket] = []
    poller = select.poll()
    for fd in pending:
        poller.register(fd, select.POLLOUT)
    deadline = time.monotonic() + CONNECT_WINDOW_S
    while pending and time.monotonic() < deadline:
        for fd, _ in poller.poll(200):
            s = pending.pop(fd)
            poller.unregister(fd)
            if s.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR) == 0:
                done.append(s)
            else:
                s.close()
    for s in pending.values():
        s.close()
    return done


def closed_by_peer(socks: list[socket.socket]) -> int:
    n = 0
    for s in socks:
        try:
            if s.recv(1, socket.MSG_PEEK | socket.MSG_DONTWAIT) == b"":
                n += 1
        except BlockingIOError:
            pass
        except OSError:
            n += 1
    return n


def fd_count(pid: int) -> int:
    try:
        return len(os.listdir(f"/proc/{pid}/fd"))
    except OSError:
        return -1


def run_case(target: str, conns: int, hold_s: float, nofile: int, work: Path) -> dict:
    rotctld_port = free_port()
    urc = UrcProcess(work, serve=[{"protocol": "rotctld", "tcp": f"127.0.0.1:{rotctld_port}"}])
    log_path = work / "urc.log"
    limit = ["prlimit", f"--nofile={nofile}:{nofile}"] if nofile else []
    urc.start_logged(log_path, prefix=limit)
    socks: list[socket.socket] = []
    try:
        probes = make_probes(urc.url, rotctld_port)
        for p in probes:
            p.start()
        t_base = time.monotonic()
        time.sleep(BASELINE_S)
        ports = {"rotctld": [rotctld_port], "http": [urc.port], "both": [rotctld_port, urc.port]}[target]
        log0 = log_path.stat().st_size
        t_flood = time.monotonic()
        socks = open_idle(ports, conns)
        fds_peak = fd_count(urc.proc.pid)
        t_held = time.monotonic()
        while time.monotonic() < t_held + hold_s:
            time.sleep(1.0)
            fds_peak = max(fds_peak, fd_count(urc.proc.pid))
        t_end = time.monotonic()
        log_bytes = log_path.stat().st_size - log0
        closed = closed_by_peer(socks)
        for p in probes:
            p.running = False
        for p in probes:
            p.join(PROBE_TIMEOUT_S + 1)
        try:
            faults = [f["kind"] + ": " + f["reason"] for f in httpx.get(urc.url + "/api/status", timeout=10)
                      .json()["faults"]]
        except (httpx.HTTPError, ValueError, KeyError):
            faults = ["(status not read)"]
        return {"target": target, "conns": conns, "nofile": nofile, "hold_s": hold_s,
                "established": len(socks), "closed_by_urc": closed, "io_fds_peak": fds_peak,
                "log_bytes_flood": log_bytes, "faults": faults,
                "probes": {p.name: {"baseline": p.between(t_base, t_flood),
                                    "flood": p.between(t_flood, t_end),
                                    "flood_longest_gap_s": p.longest_gap_s(t_flood, t_end)} for p in probes}}
    finally:
        for s in socks:
            s.close()
        stop_process_group(urc.proc)



def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--conns", type=int, default=1300)
    ap.add_argument("--hold-s", type=float, default=30.0)
    ap.add_argument("--nofile", type=int, default=1024, help="urc's file limit (0: leave it)")
    ap.add_argument("--targets", default="rotctld,http,both")
    ap.add_argument("--json", default="bench/results/conn-flood.json")
    args = ap.parse_args()
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft < args.conns + 256:  # this process holds the flood
        resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, args.conns + 1024), hard))
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for target in args.targets.split(","):
            work = Path(tmp) / target
            work.mkdir()
            results.append(run_case(target, args.conns, args.hold_s, args.nofile, work))
    print(f"{'flood to':8} {'conns':>5} {'estab':>5} {'closed':>6} {'fds':>5} {'log B':>6}  "
          f"{'probe':18} {'base ok':>9} {'base p50':>8} {'base p99':>8}  {'flood ok':>9} {'p50 ms':>8} "
          f"{'p99 ms':>8} {'max ms':>8} {'gap s':>6}")
    for r in results:
        for i, (name, ph) in enumerate(r["probes"].items()):
            head = (f"{r['target']:8} {r['conns']:5d} {r['established']:5d} {r['closed_by_urc']:6d} "
                    f"{r['io_fds_peak']:5d} {r['log_bytes_flood']:6d}") if i == 0 else " " * 39
            b, f = ph["baseline"], ph["flood"]
            print(f"{head}  {name:18} {b['answered']:4d}/{b['asked']:<4d} {b['p50_ms']:8.2f} {b['p99_ms']:8.2f}  "
                  f"{f['answered']:4d}/{f['asked']:<4d} {f['p50_ms']:8.2f} {f['p99_ms']:8.2f} {f['max_ms']:8.2f} "
                  f"{ph['flood_longest_gap_s']:6.2f}")
        if r["faults"]:
            print(" " * 41 + "faults: " + "; ".join(r["faults"]))
    write_json({"cases": results}, args.json)


if __name__ == "__main__":
    main()
