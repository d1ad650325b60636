"""Junk-input benchmark (issue 13.1): unrecognised bytes on a protocol port while another
client polls the position.

A real ``urc run`` (simulator) serves rotctld, the Tartu command set and SARCNET on TCP.
For each case one client sends a block of junk (64 KiB and 128 KiB of bytes rotctld does
not know; 64 KiB of ``x\\r\\n`` lines to Tartu and SARCNET) while a second client polls
``p`` on rotctld every 20 ms. Measured: the poller's worst round trip during the junk
(the stall every client sees), the bytes urc logged, the bytes it answered to the junk,
how long the junk took to be consumed, and the control loop's lateness (tick lateness
p99 and whether a "deadline missed" fault latched).

Prints a table, writes JSON (default bench/results/junk.json).
Usage: python bench/junk_bench.py [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import socket
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from bench_report import write_json  # noqa: E402
from urc_process import START_TIMEOUT_S, URC, UrcProcess, free_port, stop_process_group  # noqa: E402

POLL_PERIOD_S = 0.02


def _connect(port: int) -> socket.socket:
    deadline = time.monotonic() + 10
    while True:
        try:
            s = socket.create_connection(("127.0.0.1", port), timeout=60)
            s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            return s
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)


class Poller(threading.Thread):
    """Polls ``p`` on rotctld and records each round trip."""

    def __init__(self, port: int):
        super().__init__(daemon=True)
        self.sock = _connect(port)
        self.rtts: list[tuple[float, float]] = []   # (start monotonic, rtt s)
        self.running = True

    def run(self) -> None:
        buf = bytearray()
        while self.running:
            t0 = time.monotonic()
            self.sock.sendall(b"p\n")
            while buf.count(b"\n") < 2:
                buf += self.sock.recv(4096)
            del buf[:]
            self.rtts.append((t0, time.monotonic() - t0))
            time.sleep(POLL_PERIOD_S)


#: a position query sent after the junk: its answer marks the junk as consumed
PROBE = {"rotctld": (b"p\n", b"\n"), "urc": (b"RDAZ\r\n", b"\r\n"), "sarcnet": (b"AZ\r\n", b"\n")}
SILENCE_S = 15.0


def send_junk(port: int, protocol: str, junk: bytes) -> tuple[int, float]:
    """Send the junk and a position query, read everything that comes back until
    SILENCE_S of silence. Returns (bytes answered to the junk, seconds from the first
    junk byte until the query's answer arrived)."""
    probe, probe_end = PROBE[protocol]
    s = _connect(port)
    t0 = time.monotonic()
    data = bytearray()
    last = [t0]

    def reader() -> None:
        s.settimeout(SILENCE_S)
        try:
            while chunk := s.recv(65536):
                data.extend(chunk)
                last[0] = time.monotonic()
        except OSError:
            pass
    r = threading.Thread(target=reader, daemon=True)
    r.start()
    s.sendall(junk + probe)
    r.join(120)
    s.close()
    # the probe's own answer is the last line(s); everything before it answered the junk
    answer_len = len(data) - data.rfind(probe_end, 0, max(len(data) - len(probe_end), 0)) - len(probe_end)
    if protocol == "rotctld":
        answer_len = len(data)  # p answers 2 lines; rotctld answers nothing to junk
    return len(data) - answer_len, last[0] - t0


def run_case(urc: UrcProcess, log_path: Path, ports: dict, protocol: str, junk: bytes) -> dict:
    poller = Poller(ports["rotctld"])
    poller.start()
    time.sleep(0.5)
    log0 = log_path.stat().st_size
    t_start = time.monotonic()
    reply_bytes, consumed_s = send_junk(ports[protocol], protocol, junk)
    t_end = time.monotonic()
    time.sleep(0.3)
    poller.running = False
    poller.join(5)
    during = [rtt for t0, rtt in poller.rtts if t_start - 0.1 <= t0 <= t_end]
    st = urc.status()
    return {
        "protocol": protocol, "junk_bytes": len(junk),
        "poll_worst_rtt_ms": round(1000 * max(during, default=0.0), 1),
        "log_bytes": log_path.stat().st_size - log0,
        "reply_bytes": reply_bytes,
        "consumed_s": round(consumed_s, 3),
        "tick_late_p99_ms": st.get("tick_late_p99_ms"),
        "faults": [f["kind"] + ": " + f["reason"] for f in st["faults"]],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="bench/results/junk.json")
    args = ap.parse_args()
    ports = {"rotctld": free_port(), "urc": free_port(), "sarcnet": free_port()}
    cases = [("rotctld", b"Z" * 65536), ("rotctld", b"Z" * 131072),
             ("urc", b"x\r\n" * (65536 // 3)), ("sarcnet", b"x\r\n" * (65536 // 3))]
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        serve = [{"protocol": p, "tcp": f"127.0.0.1:{port}"} for p, port in ports.items()]
        for protocol, junk in cases:
            # a fresh controller per case: a latched fault from one case must not hide the next
            case_dir = work / f"{protocol}-{len(junk)}"
            case_dir.mkdir()
            urc = UrcProcess(case_dir, serve=serve)
            log_path = urc.workdir / "urc.log"
            _start(urc, log_path)
            try:
                time.sleep(1.0)
                results.append(run_case(urc, log_path, ports, protocol, junk))
            finally:
                stop_process_group(urc.proc)
    print(f"{'protocol':9} {'junk':>7} {'worst p RTT ms':>15} {'log bytes':>10} {'reply bytes':>12} "
          f"{'consumed s':>11} {'late p99 ms':>12}  faults")
    for r in results:
        print(f"{r['protocol']:9} {r['junk_bytes']:7d} {r['poll_worst_rtt_ms']:15.1f} {r['log_bytes']:10d} "
              f"{r['reply_bytes']:12d} {r['consumed_s']:11.3f} {r['tick_late_p99_ms']:12}  "
              f"{'; '.join(r['faults']) or '-'}")
    write_json({"cases": results}, args.json)


def _start(urc: UrcProcess, log_path: Path) -> None:
    """``urc run`` with its log (stderr and stdout) going to a file we can measure, in a
    process group of its own (a stop reaches its control process too); a start that
    fails leaves nothing running."""
    import subprocess
    import httpx

    with open(log_path, "wb") as log:
        urc.proc = subprocess.Popen(URC + ["run", "--config", str(urc.config), "--state-dir", str(urc.state_dir)],
                                    stdout=log, stderr=subprocess.STDOUT, env=dict(os.environ),
                                    start_new_session=True)
    deadline = time.monotonic() + START_TIMEOUT_S   # a loaded machine starts slowly
    while time.monotonic() < deadline and urc.proc.poll() is None:
        try:
            httpx.get(urc.url + "/api/status", timeout=0.5)
            return
        except httpx.HTTPError:
            time.sleep(0.1)
    stop_process_group(urc.proc)
    raise RuntimeError(f"urc did not start: {log_path.read_text()[-2000:]}")


if __name__ == "__main__":
    main()
