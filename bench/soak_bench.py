"""RSS soak with clients (issue 21): does either urc process grow while clients use it?

A real ``urc run`` (simulator, tartu-urc, rotctld on TCP) runs for ``--minutes``. One
asyncio loop in this process drives every client, so the load generator stays cheap:
8 rotctld pollers (``p`` at ~2 Hz each), one setter (``P`` to a new pose every ~10 s)
and 2 viewers of the dashboard's live WebSocket feed (``/api/ws``). Every 60 s the
VmRSS of the I/O process (``urc run``) and of the control process is sampled, with
their open file descriptors and threads, and the clients' round trips of that minute.

Summary: RSS at the start, the middle and the end, and the slope (MB/h, least squares)
of each half of the run (with ``--minutes 120``: the first and the second hour; the
dashboard's one-hour history fills during the first). The JSON is rewritten after every
sample, so a run cut short still leaves its data.

Prints a table, writes JSON (default bench/results/soak.json). Never gates CI.
Usage: python bench/soak_bench.py [--minutes 120] [--out-dir DIR] [--json PATH]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import os
import random
import statistics
import sys
import time
from pathlib import Path

import websockets

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from bench_report import write_json  # noqa: E402
from urc_process import UrcProcess, free_port, stop_process_group  # noqa: E402

POLLERS = 8
POLL_PERIOD_S = 0.5
SET_PERIOD_S = 10.0
VIEWERS = 2
SAMPLE_PERIOD_S = 60.0


def proc_mem(pid: int) -> dict:
    """VmRSS (MB), open descriptors and threads of one process."""
    out = {"rss_mb": math.nan, "fds": -1, "threads": -1}
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                out["rss_mb"] = round(int(line.split()[1]) / 1024.0, 2)
            elif line.startswith("Threads:"):
                out["threads"] = int(line.split()[1])
        out["fds"] = len(os.listdir(f"/proc/{pid}/fd"))
    except (FileNotFoundError, ProcessLookupError):
        pass
    return out


class Load:
    """Counters the clients share; the sampler reads and resets the round trips."""

    def __init__(self) -> None:
        self.rtts_s: list[float] = []
        self.polls = 0
        self.sets = 0
        self.frames = 0
        self.errors: dict[str, int] = {}
        self.stop = asyncio.Event()

    def error(self, what: str, exc: BaseException) -> None:
        key = f"{what}: {type(exc).__name__}"
        self.errors[key] = self.errors.get(key, 0) + 1


async def _pause(load: Load, seconds: float) -> None:
    try:
        await asyncio.wait_for(load.stop.wait(), seconds)
    except asyncio.TimeoutError:
        pass


async def poller(load: Load, port: int, offset_s: float) -> None:
    await _pause(load, offset_s)            # spread the pollers over the period
    while not load.stop.is_set():
        try:
            reader, writer = await asyncio.open_connection("127.0.0.1", port)
            try:
                while not load.stop.is_set():
                    t0 = time.monotonic()
                    writer.write(b"p\n")
                    await writer.drain()
                    for _ in range(2):      # az line, el line
                        await asyncio.wait_for(reader.readline(), 30)
                    load.rtts_s.append(time.monotonic() - t0)
                    load.polls += 1
                    await _pause(load, POLL_PERIOD_S)
            finally:
                writer.close()
        except (OSError, asyncio.TimeoutError) as exc:
            load.error("poll", exc)
            await _pause(load, 1.0)


async def setter(load: Load, port: int) -> None:
    rng = random.Random(21)
    while not load.stop.is_set():
        try:
            reader, writer = await asyncio.open_connection("127.0.0.1", port)
            try:
                while not load.stop.is_set():
                    az_deg, el_deg = rng.uniform(10.0, 350.0), rng.uniform(5.0, 80.0)
                    writer.write(f"P {az_deg:.1f} {el_deg:.1f}\n".encode())
                    await writer.drain()
                    line = await asyncio.wait_for(reader.readline(), 30)
                    if not line.startswith(b"RPRT 0"):
                        load.error(f"set answered {line[:40]!r}", RuntimeError())
                    load.sets += 1
                    await _pause(load, SET_PERIOD_S)
            finally:
                writer.close()
        except (OSError, asyncio.TimeoutError) as exc:
            load.error("set", exc)
            await _pause(load, 1.0)


async def viewer(load: Load, http_port: int) -> None:
    while not load.stop.is_set():
        try:
            async with websockets.connect(f"ws://127.0.0.1:{http_port}/api/ws", max_size=None) as ws:
                while not load.stop.is_set():
                    try:
                        await asyncio.wait_for(ws.recv(), 1.0)
                        load.frames += 1
                    except asyncio.TimeoutError:
                        continue
        except (OSError, websockets.WebSocketException) as exc:
            load.error("ws", exc)
            await _pause(load, 1.0)


def _q(values: list[float], q: float) -> float:
    if not values:
        return math.nan
    v = sorted(values)
    return v[min(len(v) - 1, int(q * len(v)))]


def slope_mb_per_h(samples: list[dict], key: str, t0_min: float, t1_min: float) -> float:
    """Least-squares slope of ``key``'s RSS over samples with t0 <= minute <= t1."""
    pts = [(s["minute"], s[key]["rss_mb"]) for s in samples if t0_min <= s["minute"] <= t1_min]
    if len(pts) < 2:
        return math.nan
    return round(statistics.linear_regression([p[0] for p in pts], [p[1] for p in pts]).slope * 60.0, 2)


def at_minute(samples: list[dict], key: str, minute: float) -> float:
    s = min(samples, key=lambda s: abs(s["minute"] - minute))
    return s[key]["rss_mb"]


def summary(samples: list[dict], minutes: float) -> dict:
    half = minutes / 2.0
    out: dict = {"minutes": minutes, "samples": len(samples)}
    for key in ("io", "control"):
        out[key] = {
            "rss_mb_at": {f"{m:g}": at_minute(samples, key, m) for m in (0.0, half, minutes)},
            "slope_first_half_mb_per_h": slope_mb_per_h(samples, key, 0.0, half),
            "slope_second_half_mb_per_h": slope_mb_per_h(samples, key, half, minutes),
        }
    return out


async def soak(urc: UrcProcess, io_pid: int, control_pid: int, rotctld_port: int,
               minutes: float, json_path: str, log_path: Path) -> dict:
    load = Load()
    clients = [asyncio.create_task(poller(load, rotctld_port, i * POLL_PERIOD_S / POLLERS))
               for i in range(POLLERS)]
    clients.append(asyncio.create_task(setter(load, rotctld_port)))
    clients += [asyncio.create_task(viewer(load, urc.port)) for _ in range(VIEWERS)]
    samples: list[dict] = []
    t_start = time.monotonic()
    n_samples = int(round(minutes * 60.0 / SAMPLE_PERIOD_S))
    result: dict = {}
    try:
        for i in range(n_samples + 1):
            await asyncio.sleep(max(0.0, t_start + i * SAMPLE_PERIOD_S - time.monotonic()))
            rtts, load.rtts_s = load.rtts_s, []
            sample = {"minute": round((time.monotonic() - t_start) / 60.0, 2),
                      "io": proc_mem(io_pid), "control": proc_mem(control_pid),
                      "polls": load.polls, "sets": load.sets, "ws_frames": load.frames,
                      "p_rtt_p50_ms": round(1000 * _q(rtts, 0.5), 2),
                      "p_rtt_p99_ms": round(1000 * _q(rtts, 0.99), 2),
                      "p_rtt_max_ms": round(1000 * max(rtts, default=math.nan), 2),
                      "log_bytes": log_path.stat().st_size,
                      "client_errors": dict(load.errors)}
            samples.append(sample)
            print(f"{sample['minute']:7.2f} min  io {sample['io']['rss_mb']:8.2f} MB "
                  f"({sample['io']['fds']} fds)  control {sample['control']['rss_mb']:8.2f} MB  "
                  f"p p99 {sample['p_rtt_p99_ms']:7.2f} ms  polls {load.polls}  sets {load.sets}  "
                  f"frames {load.frames}", flush=True)
            result = {"done": i == n_samples, "io_pid": io_pid, "control_pid": control_pid,
                      "summary": summary(samples, minutes), "samples": samples}
            Path(json_path).parent.mkdir(parents=True, exist_ok=True)
            Path(json_path).write_text(json.dumps(result, indent=2))
            if urc.proc.poll() is not None:
                raise RuntimeError(f"urc run exited with {urc.proc.returncode}")
    finally:
        load.stop.set()
        await asyncio.gather(*clients, return_exceptions=True)
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=120.0)
    ap.add_argument("--out-dir", default=None, help="work dir for urc's config, state and log "
                    "(default: a fresh directory under bench/results/)")
    ap.add_argument("--json", default="bench/results/soak.json")
    args = ap.parse_args()

    work = Path(args.out_dir or ROOT / "bench" / "results" / f"soak-{os.getpid()}")
    work.mkdir(parents=True, exist_ok=True)
    rotctld_port = free_port()
    urc = UrcProcess(work, serve=[{"protocol": "rotctld", "tcp": f"127.0.0.1:{rotctld_port}"}])
    log_path = work / "urc.log"
    urc.start_logged(log_path)
    try:
        io_pid, control_pid = urc.proc.pid, urc.control_pid()
        print(f"urc run pid {io_pid}, control process pid {control_pid}; log {log_path}; "
              f"JSON {args.json}", flush=True)
        result = asyncio.run(soak(urc, io_pid, control_pid, rotctld_port, args.minutes, args.json, log_path))
    finally:
        stop_process_group(urc.proc)

    s = result["summary"]
    marks = list(s["io"]["rss_mb_at"])
    print(f"\n{'process':8} " + " ".join(f"{'RSS@' + m + ' min':>14}" for m in marks)
          + f" {'slope 1st half':>15} {'slope 2nd half':>15}")
    for key in ("io", "control"):
        row = s[key]
        print(f"{key:8} " + " ".join(f"{row['rss_mb_at'][m]:11.2f} MB" for m in marks)
              + f" {row['slope_first_half_mb_per_h']:10.2f} MB/h {row['slope_second_half_mb_per_h']:10.2f} MB/h")
    last = result["samples"][-1]
    print(f"\npolls {last['polls']}, sets {last['sets']}, ws frames {last['ws_frames']}, "
          f"log bytes {last['log_bytes']}, client errors {last['client_errors'] or '-'}")
    write_json(result, args.json)



if __name__ == "__main__":
    main()
