"""What an exposed, unauthenticated client can do to ``urc run`` (issue 12, item 16).

Against a real ``urc run`` (simulator, a station and a catalog of 60 LEO satellites):
* a flood of pass searches: ``--clients`` unauthenticated clients asking
  /api/passes with random look-aheads and elevations for ``--window-s`` seconds;
* then a 40 MB POST from a foreign Origin (``--big-mb``).
Meanwhile /api/status is polled every 50 ms. Reported: status latency (p50/p99/max),
the control loop's own late-tick p99 (``tick_late_p99_ms``), faults latched, the
server's resident memory before/after, how the searches were answered, how long
the big POST took to be refused, and the bytes urc logged during each of the two.

Prints a table, writes JSON (default bench/results/web-abuse.json). Never gates CI.
Compare trees by running it with PYTHONPATH set to each ``src``.
Usage: python bench/web_abuse_bench.py [--clients 20] [--window-s 20] [--json PATH]
"""

from __future__ import annotations

import argparse
import asyncio
import math
import random
import subprocess
import sys
import tempfile
import time
from collections import Counter
from datetime import datetime, timezone
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "bench"))
from bench_report import write_json  # noqa: E402
from urc_process import UrcProcess, stop_process_group  # noqa: E402
from web_bench import STATION, synthetic_tle  # noqa: E402


def leo_catalog(n: int, epoch: datetime) -> str:
    """``n`` LEO element sets of today's epoch, spread in plane and phase."""
    return "".join(synthetic_tle(f"SAT-{i:03d}", 90000 + i, epoch, inc_deg=50.0 + (i * 7) % 50,
                                 raan_deg=(i * 47) % 360, argp_deg=90.0, ma_deg=(i * 61) % 360,
                                 rev_per_day=14.2 + (i % 10) * 0.15) for i in range(n))


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return math.nan


async def flood(url: str, clients: int, window_s: float, big_mb: int, log_path: Path) -> dict:
    stop = asyncio.Event()          # the status poller's
    stop_search = asyncio.Event()   # the searchers'
    log_bytes: dict[str, int] = {}
    log0 = log_path.stat().st_size
    latencies: list[float] = []
    answers: Counter = Counter()
    big: dict = {}

    async def poll(http: httpx.AsyncClient) -> None:
        while not stop.is_set():
            t0 = time.monotonic()
            try:
                await http.get(url + "/api/status", timeout=30)
                latencies.append(time.monotonic() - t0)
            except httpx.HTTPError:
                latencies.append(math.inf)
            await asyncio.sleep(0.05)

    async def searcher(http: httpx.AsyncClient, rng: random.Random) -> None:
        while not stop_search.is_set():
            q = f"/api/passes?hours={rng.uniform(1, 72):.3f}&min_el={rng.uniform(0, 60):.3f}"
            try:
                r = await http.get(url + q, timeout=120)
                answers[r.status_code] += 1
            except httpx.HTTPError as exc:
                answers[type(exc).__name__] += 1

    async def big_post(http: httpx.AsyncClient) -> None:
        body = b'{"az_deg": 1, "el_deg": 1, "pad": "' + b"x" * (big_mb * 2**20) + b'"}'
        t0 = time.monotonic()
        try:
            r = await http.post(url + "/api/goto", content=body, timeout=60,
                                headers={"Origin": "http://evil.example", "Content-Type": "application/json"})
            big.update(status=r.status_code)
        except httpx.HTTPError as exc:
            big.update(status=type(exc).__name__)
        big["seconds"] = time.monotonic() - t0

    limits = httpx.Limits(max_connections=clients + 4)
    async with httpx.AsyncClient(limits=limits) as http:
        rng = random.Random(1)
        poller = asyncio.create_task(poll(http))
        # one scenario after the other, so each one's log bytes are its own
        tasks = [asyncio.create_task(searcher(http, random.Random(rng.random()))) for _ in range(clients)]
        await asyncio.sleep(window_s)
        stop_search.set()
        await asyncio.wait(tasks, timeout=130)
        for t in tasks:
            t.cancel()
        log_bytes["pass_search_flood"] = log_path.stat().st_size - log0
        log1 = log_path.stat().st_size
        await big_post(http)
        await asyncio.sleep(1.0)  # what the refusal logs after the answer
        log_bytes["big_post"] = log_path.stat().st_size - log1
        stop.set()
        await asyncio.wait([poller], timeout=60)
        poller.cancel()
    lat = sorted(latencies)
    return {"status_latency_ms": {"p50": 1000 * lat[len(lat) // 2], "p99": 1000 * lat[int(0.99 * (len(lat) - 1))],
                                  "max": 1000 * lat[-1], "n": len(lat)},
            "pass_answers": {str(k): v for k, v in answers.items()}, "big_post": big, "log_bytes": log_bytes}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--clients", type=int, default=20)
    ap.add_argument("--window-s", type=float, default=20.0)
    ap.add_argument("--satellites", type=int, default=60)
    ap.add_argument("--big-mb", type=int, default=40)
    ap.add_argument("--json", default=str(ROOT / "bench" / "results" / "web-abuse.json"))
    args = ap.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        tle = work / "leo.tle"
        tle.write_text(leo_catalog(args.satellites, datetime.now(timezone.utc)))
        urc = UrcProcess(work, profile="berkeley", extra=STATION + f"[tracking]\ncatalog_dir = '{work / 'cat'}'\n")
        subprocess.run([sys.executable, "-m", "urc", "tle", "import", str(tle), "--config", str(urc.config)],
                       check=True, capture_output=True)
        log_path = work / "urc.log"
        urc.start_logged(log_path)  # urc's log in a file, to count its bytes
        try:
            time.sleep(2.0)
            before = {"rss_mb": rss_mb(urc.proc.pid), "tick_late_p99_ms": urc.status().get("tick_late_p99_ms")}
            result = asyncio.run(flood(urc.url, args.clients, args.window_s, args.big_mb, log_path))
            s = urc.status()
            after = {"rss_mb": rss_mb(urc.proc.pid), "tick_late_p99_ms": s.get("tick_late_p99_ms"),
                     "faults": [f"{f['kind']}: {f['reason']}" for f in s["faults"]]}
        finally:
            stop_process_group(urc.proc)
    result.update(before=before, after=after, clients=args.clients, window_s=args.window_s,
                  satellites=args.satellites)
    lat = result["status_latency_ms"]
    rows = [("/api/status latency during the flood", f"p50 {lat['p50']:.0f} ms, p99 {lat['p99']:.0f} ms, "
                                                     f"max {lat['max']:.0f} ms ({lat['n']} polls)"),
            ("control loop late-tick p99", f"{before['tick_late_p99_ms']:.1f} ms before, "
                                           f"{after['tick_late_p99_ms']:.1f} ms after"),
            ("faults latched", "; ".join(after["faults"]) or "none"),
            ("server memory (RSS)", f"{before['rss_mb']:.0f} MB before, {after['rss_mb']:.0f} MB after"),
            ("pass search answers", ", ".join(f"{k}: {v}" for k, v in sorted(result["pass_answers"].items()))),
            (f"{args.big_mb} MB POST, foreign Origin", f"{result['big_post'].get('status')} after "
                                                        f"{result['big_post'].get('seconds', math.nan):.2f} s"),
            ("log bytes written", f"{result['log_bytes']['pass_search_flood']} during the search flood, "
                                  f"{result['log_bytes']['big_post']} for the big POST")]
    width = max(len(r[0]) for r in rows)
    print(f"abuse of an exposed urc run ({args.clients} unauthenticated pass-search clients, "
          f"{args.satellites} satellites, {args.window_s:g} s)")
    for name, value in rows:
        print(f"  {name:<{width}}  {value}")
    write_json(result, args.json)



if __name__ == "__main__":
    main()
