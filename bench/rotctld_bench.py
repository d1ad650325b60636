"""rotctld protocol benchmark: urc against Hamlib's own ``rotctld -m 1`` in the same run.

For each server: ``P`` (set_pos) round trip with one client (also for the floor under it:
bench/link_floor.py, two Python processes and nothing else); ``p`` (get_pos) round trip (median, p99) and throughput with 1, 8 and 32
concurrent clients each sending ``p`` and waiting for the reply (C threads:
bench/rotctl_load.c, compiled with the system's cc, so that the generator does not limit
what is measured on 2 cores), and a burst of 64
simultaneous connections (how many were accepted and answered). For urc also the control
loop's tick lateness p99 idle and under the 32-client load (from its status).
Prints a table with urc/Hamlib ratios, writes JSON (default bench/results/rotctld.json).

All the servers run side by side for the whole run and are measured in alternating
rounds (``--rounds``: each round measures every server once, in a rotated order), so a
ratio compares the same minutes of the machine: on a shared VM the floor's own ``P``
median moved 0.10-0.28 ms between runs measured one after the other.

urc runs the simulator with ``--profile`` (default tartu-urc). On a profile whose axes
need a state record ahead of motion (incremental sensors: tartu-urc, satnogs-v3, bigras)
a ``P`` from standing answers only once the next tick has applied it and its first
record is on disk (issue 36.19): up to a tick (20 ms) plus a write; while the antenna
drives with its newest record on disk a ``P`` answers at once. g5500 (potentiometers)
needs no record: its ``P`` is the link's round trip alone.
Usage: python bench/rotctld_bench.py [--seconds 3] [--rounds 3] [--profile NAME] [--json PATH]
"""

from __future__ import annotations

import argparse
import hashlib
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from bench_report import write_json
from urc_process import UrcProcess, free_port  # noqa: E402

CLIENTS = (1, 8, 32)
BURST = 64


def wait_port(port: int, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
            return
        except OSError:
            time.sleep(0.05)
    raise RuntimeError(f"nothing listening on {port}")


def read_reply(sock: socket.socket, buf: bytearray, lines: int) -> None:
    while buf.count(b"\n") < lines:
        chunk = sock.recv(4096)
        if not chunk:
            raise ConnectionError("closed")
        buf.extend(chunk)
    for _ in range(lines):
        del buf[: buf.index(b"\n") + 1]


def load_generator() -> Path:
    """bench/rotctl_load.c compiled (once per source change): the clients of the load
    levels are C threads, so that on 2 cores the generator is not what limits the
    throughput (a Python client thread costs as much CPU per request as the server)."""
    src = Path(__file__).with_name("rotctl_load.c")
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        sys.exit("a C compiler is needed for the load generator (apt-get install gcc)")
    tag = hashlib.sha256(src.read_bytes()).hexdigest()[:12]
    exe = Path(tempfile.gettempdir()) / f"urc-rotctl_load-{tag}"
    if not exe.exists():
        subprocess.run([cc, "-O2", "-pthread", "-o", str(exe), str(src)], check=True)
    return exe


def load(port: int, clients: int, seconds: float) -> dict:
    """``clients`` connections each sending ``p`` and waiting for its reply, for
    ``seconds`` (bench/rotctl_load.c)."""
    out = subprocess.run([str(load_generator()), "127.0.0.1", str(port), str(clients), str(seconds)],
                         capture_output=True, text=True, check=True, timeout=seconds + 60).stdout.split()
    requests, errors, elapsed_s, median_ms, p99_ms = int(out[0]), int(out[1]), *map(float, out[2:5])
    return {"clients": clients, "requests": requests, "throughput_per_s": requests / elapsed_s,
            "median_ms": median_ms if requests else float("nan"), "p99_ms": p99_ms if requests else float("nan"),
            "errors": errors, "generator": "bench/rotctl_load.c"}


def burst(port: int, n: int = BURST) -> dict:
    """n clients connect at the same instant, each sends one p and reads the reply."""
    ok = [0]
    lock = threading.Lock()
    go = threading.Barrier(n)

    def one() -> None:
        go.wait()
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=5) as sock:
                sock.sendall(b"p\n")
                read_reply(sock, bytearray(), 2)
                with lock:
                    ok[0] += 1
        except OSError:
            pass
    threads = [threading.Thread(target=one) for _ in range(n)]
    t0 = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return {"connections": n, "answered": ok[0], "seconds": time.perf_counter() - t0}


def set_round_trip(port: int, n: int = 400) -> list[float]:
    """One client sends ``P`` (set_pos) and waits for its ``RPRT 0``, n times, between
    two nearby poses: on urc every one is a command to the control process and back.
    The round trips in seconds."""
    rtts: list[float] = []
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        buf = bytearray()
        for i in range(n):
            cmd = f"P {100 + (i % 2) * 0.5:.1f} 40.0\n".encode()
            t0 = time.perf_counter()
            sock.sendall(cmd)
            while b"\n" not in buf:
                chunk = sock.recv(4096)
                if not chunk:
                    raise ConnectionError("closed")
                buf.extend(chunk)
            rtts.append(time.perf_counter() - t0)
            reply, _, rest = bytes(buf).partition(b"\n")
            buf = bytearray(rest)
            if reply != b"RPRT 0":
                raise RuntimeError(f"P answered {reply!r}")
    return rtts


def set_round_trips(ports: dict[str, int], rounds: int, n: int = 1200) -> dict[str, dict]:
    """``set_round_trip`` on every server, ``n`` sets each in all, in ``rounds`` rounds
    whose order rotates: their medians compare the same minutes of the machine."""
    rtts: dict[str, list[float]] = {name: [] for name in ports}
    names = list(ports)
    for r in range(rounds):
        for name in names[r % len(names):] + names[:r % len(names)]:
            rtts[name] += set_round_trip(ports[name], max(n // rounds, 50))
    out = {}
    for name, values in rtts.items():
        values.sort()
        out[name] = {"requests": len(values), "median_ms": 1000 * statistics.median(values),
                     "p99_ms": 1000 * values[int(0.99 * (len(values) - 1))]}
    return out


def loads(ports: dict[str, int], clients: int, seconds: float, rounds: int) -> dict[str, dict]:
    """``load`` on every server in ``rounds`` alternating rounds of ``seconds / rounds``;
    throughput over them all, the median of the rounds' medians, their largest p99."""
    runs: dict[str, list[dict]] = {name: [] for name in ports}
    names = list(ports)
    for r in range(rounds):
        for name in names[r % len(names):] + names[:r % len(names)]:
            runs[name].append(load(ports[name], clients, seconds / rounds))
    out = {}
    for name, got in runs.items():
        requests = sum(g["requests"] for g in got)
        out[name] = {"clients": clients, "requests": requests, "rounds": rounds,
                     "throughput_per_s": requests / sum(g["requests"] / g["throughput_per_s"] if g["requests"]
                                                        else seconds / rounds for g in got),
                     "median_ms": statistics.median(g["median_ms"] for g in got),
                     "p99_ms": max(g["p99_ms"] for g in got), "errors": sum(g["errors"] for g in got),
                     "generator": "bench/rotctl_load.c"}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=3.0, help="per load level and server")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds per measurement")
    ap.add_argument("--profile", default="tartu-urc", help="urc's profile (simulated)")
    ap.add_argument("--json", default="bench/results/rotctld.json")
    args = ap.parse_args()
    rotctld = shutil.which("rotctld")
    if rotctld is None:
        sys.exit("Hamlib's rotctld is needed as the reference (apt-get install libhamlib-utils)")
    results: dict = {"profile": args.profile, "rounds": args.rounds}
    ports = {name: free_port() for name in ("hamlib", "floor_thread", "floor_loop", "urc")}
    procs = [subprocess.Popen([rotctld, "-m", "1", "-T", "127.0.0.1", "-t", str(ports["hamlib"])],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    procs += [subprocess.Popen([sys.executable, str(Path(__file__).with_name("link_floor.py")),
                                str(ports[f"floor_{mode}"]), mode]) for mode in ("thread", "loop")]
    with tempfile.TemporaryDirectory() as tmp:
        urc = UrcProcess(Path(tmp), profile=args.profile,
                         serve=[{"protocol": "rotctld", "tcp": f"127.0.0.1:{ports['urc']}"}]).start()
        try:
            for port in ports.values():
                wait_port(port)
            time.sleep(12.0)  # let the lateness window (last 500 ticks = 10 s) fill idle
            idle_late = urc.status()["tick_late_p99_ms"]
            sets = set_round_trips(ports, args.rounds)
            servers = {name: ports[name] for name in ("hamlib", "urc")}
            levels = [loads(servers, c, args.seconds, args.rounds) for c in CLIENTS]
            for name in servers:
                results[name] = {"load": [level[name] for level in levels], "burst": burst(ports[name]),
                                 "set": sets[name]}
            for mode in ("thread", "loop"):
                results[f"floor_{mode}"] = {"set": sets[f"floor_{mode}"]}
            results["urc"]["tick_late_p99_ms_idle"] = idle_late
            load(ports["urc"], 32, 10.0)  # lateness under load: 32 clients hammering
            results["urc"]["tick_late_p99_ms_loaded"] = urc.status()["tick_late_p99_ms"]
        finally:
            urc.stop()
            for proc in procs:
                proc.terminate()
                proc.wait()

    print(f"\nrotctld `p` round trip and throughput (localhost, {args.seconds:g} s per level and server, "
          f"{args.rounds} alternating rounds)")
    print(f"{'clients':>7s} | {'urc med ms':>10s} {'p99 ms':>7s} {'req/s':>8s} | {'hamlib med':>10s} "
          f"{'p99 ms':>7s} {'req/s':>8s} | {'thr ratio':>9s} {'med ratio':>9s}")
    for u, h in zip(results["urc"]["load"], results["hamlib"]["load"]):
        print(f"{u['clients']:7d} | {u['median_ms']:10.3f} {u['p99_ms']:7.3f} {u['throughput_per_s']:8.0f} | "
              f"{h['median_ms']:10.3f} {h['p99_ms']:7.3f} {h['throughput_per_s']:8.0f} | "
              f"{u['throughput_per_s'] / h['throughput_per_s']:9.2f} {u['median_ms'] / h['median_ms']:9.2f}")
    us, hs = results["urc"]["set"], results["hamlib"]["set"]
    print(f"`P` (set) round trip, 1 client: urc ({args.profile}) median {us['median_ms']:.3f} ms p99 {us['p99_ms']:.3f} | hamlib "
          f"median {hs['median_ms']:.3f} ms p99 {hs['p99_ms']:.3f} | ratio {us['median_ms'] / hs['median_ms']:.2f}")
    for mode in ("thread", "loop"):
        fs = results[f"floor_{mode}"]["set"]
        print(f"  floor (two Python processes, reply taken by {mode:6s}): median {fs['median_ms']:.3f} ms "
              f"p99 {fs['p99_ms']:.3f} | ratio to hamlib {fs['median_ms'] / hs['median_ms']:.2f}")
    ub, hb = results["urc"]["burst"], results["hamlib"]["burst"]
    print(f"burst of {BURST}: urc answered {ub['answered']}/{BURST}, hamlib answered {hb['answered']}/{BURST}")
    print(f"urc control tick lateness p99: idle {results['urc']['tick_late_p99_ms_idle']:.2f} ms, "
          f"under 32-client load {results['urc']['tick_late_p99_ms_loaded']:.2f} ms")
    write_json(results, args.json)


if __name__ == "__main__":
    main()
