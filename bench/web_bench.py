"""Web dashboard benchmark, against a real ``urc run`` (simulator, berkeley profile).

Measures:
* page load to first live position: navigation start to the first WebSocket frame drawn
  on the sky plot, in headless chromium (Debian's /usr/bin/chromium), fresh context each run;
* update rate the page actually sees: WebSocket messages per second over 10 s (the page's
  own counter), plus the spread of the gaps between frames;
* server CPU share of one core (utime + stime from /proc/<pid>/stat) with no dashboard,
  with 10 open dashboards (10 WebSocket clients reading every frame), and with 10 while
  the antenna moves;
* the live feed while a satellite pass is planned and flown (station and an ISS-like
  element set of today's epoch): messages and bytes per second one dashboard receives,
  status frame size, and how often the plan/ground track is sent (``--tracking-only``
  measures just this; run it with PYTHONPATH set to an older tree to compare).

Prints a table, writes JSON (default bench/results/web.json). Never gates CI.
Usage: python bench/web_bench.py [--loads 5] [--window-s 10] [--tracking-only] [--json PATH]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from bench_report import cpu_s, write_json  # noqa: E402
from urc_process import UrcProcess  # noqa: E402

from urc.testing.synthetic import STATION_TOML, synthetic_tle  # noqa: E402

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
def cpu_share(pid: int, window_s: float) -> float:
    c0, t0 = cpu_s(pid), time.monotonic()
    time.sleep(window_s)
    return (cpu_s(pid) - c0) / (time.monotonic() - t0)


def page_metrics(url: str, loads: int, window_s: float) -> dict:
    from playwright.sync_api import sync_playwright

    first_ms = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        for i in range(loads + 1):
            ctx = browser.new_context()
            page = ctx.new_page()
            page.goto(url)
            page.wait_for_selector("body[data-first-position-ms]", timeout=15_000)
            if i > 0:  # the first load warms the server's and the browser's caches
                first_ms.append(float(page.locator("body").get_attribute("data-first-position-ms")))
            ctx.close()
        ctx = browser.new_context()
        page = ctx.new_page()
        arrivals: list[float] = []
        page.on("websocket", lambda ws: ws.on("framereceived", lambda _f: arrivals.append(time.monotonic())))
        page.goto(url)
        page.wait_for_selector("#conn.live", timeout=15_000)
        page.wait_for_timeout(1000)
        arrivals.clear()
        n0, t0 = int(page.locator("#conn").get_attribute("data-frames")), time.monotonic()
        page.wait_for_timeout(window_s * 1000)   # (not sleep: frame events are delivered meanwhile)
        n1, t1 = int(page.locator("#conn").get_attribute("data-frames")), time.monotonic()
        ctx.close()
        browser.close()
    gaps_ms = sorted((b - a) * 1000 for a, b in zip(arrivals, arrivals[1:]))
    return {"first_position_ms": {"median": statistics.median(first_ms), "min": min(first_ms),
                                  "max": max(first_ms), "runs": first_ms},
            "page_rate_msgs_per_s": (n1 - n0) / (t1 - t0),
            "frame_gap_ms": {"p50": gaps_ms[len(gaps_ms) // 2], "p99": gaps_ms[int(0.99 * (len(gaps_ms) - 1))],
                             "max": gaps_ms[-1]} if gaps_ms else None}


async def _clients(url: str, n: int, window_s: float, pid: int, move_url: str | None) -> dict:
    import websockets

    counts = [0] * n
    stop = asyncio.Event()

    async def client(i: int) -> None:
        async with websockets.connect(url, max_size=2**22) as ws:
            while not stop.is_set():
                try:
                    await asyncio.wait_for(ws.recv(), 1.0)
                    counts[i] += 1
                except asyncio.TimeoutError:
                    pass

    async def mover() -> None:
        async with httpx.AsyncClient() as http:
            goal = 300.0
            while not stop.is_set():
                await http.post(move_url, json={"az_deg": goal, "el_deg": 60.0 if goal > 100 else 10.0})
                goal = 60.0 if goal > 100 else 300.0
                await asyncio.sleep(6.0)

    tasks = [asyncio.create_task(client(i)) for i in range(n)]
    if move_url:
        tasks.append(asyncio.create_task(mover()))
    await asyncio.sleep(1.5)           # all connected and receiving
    c0, n0, t0 = cpu_s(pid), sum(counts), time.monotonic()
    await asyncio.sleep(window_s)
    c1, n1, t1 = cpu_s(pid), sum(counts), time.monotonic()
    stop.set()
    await asyncio.gather(*tasks, return_exceptions=True)
    return {"cpu_share": (c1 - c0) / (t1 - t0), "msgs_per_s_per_client": (n1 - n0) / (t1 - t0) / n}


STATION = STATION_TOML


def iss_like_tle(epoch: datetime) -> str:
    return synthetic_tle("ISS (ZARYA)", 25544, epoch, inc_deg=51.6416, raan_deg=247.4627, argp_deg=130.536,
                         ma_deg=325.0288, rev_per_day=15.50103472, ecc=0.0006703)


def tracking_feed(workdir: Path, profile: str, window_s: float) -> dict:
    """Plan the next pass of an ISS-like satellite and record what one dashboard gets."""
    import websockets

    workdir.mkdir(parents=True, exist_ok=True)
    tle = workdir / "iss.tle"
    tle.write_text(iss_like_tle(datetime.now(timezone.utc)))
    urc = UrcProcess(workdir, profile=profile,
                     extra=STATION + f"[tracking]\ncatalog_dir = '{workdir / 'cat'}'\n")
    subprocess.run([sys.executable, "-m", "urc", "tle", "import", str(tle), "--config", str(urc.config)],
                   check=True, capture_output=True)
    urc.start()
    try:
        passes = httpx.get(urc.url + "/api/passes?hours=24&min_el=10", timeout=60).json()
        first = passes[0]
        r = urc.post("/api/track/pass", {"norad": first["norad"], "aos": first["aos"]})
        assert r.status_code == 200, r.text

        async def record() -> list[tuple[float, str]]:
            got: list[tuple[float, str]] = []
            async with websockets.connect(urc.url.replace("http://", "ws://") + "/api/ws", max_size=2**22) as ws:
                await asyncio.sleep(1.5)         # the tracker's status is in the frames by now
                while True:
                    try:
                        await asyncio.wait_for(ws.recv(), 0.05)
                    except asyncio.TimeoutError:
                        break                    # drained what queued meanwhile
                t_end = time.monotonic() + window_s
                while time.monotonic() < t_end:
                    try:
                        msg = await asyncio.wait_for(ws.recv(), 1.0)
                    except asyncio.TimeoutError:
                        continue
                    got.append((time.monotonic(), msg))
            return got
        got = asyncio.run(record())
    finally:
        urc.stop()
    kinds = [json.loads(m).get("type") for _, m in got]
    frames = [len(m.encode()) for (_, m), k in zip(got, kinds) if k == "status"]
    total = sum(len(m.encode()) for _, m in got)
    return {"pass": {"aos": first["aos"], "max_el_deg": first["max_el_deg"]},
            "msgs_per_s": len(got) / window_s, "status_frames_per_s": len(frames) / window_s,
            "bytes_per_s": total / window_s, "status_frame_bytes_mean": statistics.mean(frames),
            "status_frame_bytes_max": max(frames),
            "other_messages": {k: kinds.count(k) for k in set(kinds) if k != "status"}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--loads", type=int, default=5)
    ap.add_argument("--window-s", type=float, default=10.0)
    ap.add_argument("--clients", type=int, default=10)
    ap.add_argument("--profile", default="berkeley")
    ap.add_argument("--tracking-only", action="store_true", help="measure only the live feed while tracking")
    ap.add_argument("--json", default=None, help="default bench/results/web.json (web-tracking.json)")
    args = ap.parse_args()
    if args.tracking_only:
        with tempfile.TemporaryDirectory() as tmp:
            feed = tracking_feed(Path(tmp), args.profile, args.window_s)
        print_feed(feed, args.window_s)
        write_json({"profile": args.profile, "window_s": args.window_s, "tracking_feed": feed},
                   args.json or str(ROOT / "bench" / "results" / "web-tracking.json"))
        return

    with tempfile.TemporaryDirectory() as tmp:
        urc = UrcProcess(Path(tmp), profile=args.profile).start()
        try:
            pid = urc.proc.pid
            time.sleep(1.0)
            idle = cpu_share(pid, args.window_s)
            ws_url = urc.url.replace("http://", "ws://") + "/api/ws"
            ten = asyncio.run(_clients(ws_url, args.clients, args.window_s, pid, None))
            ten_moving = asyncio.run(_clients(ws_url, args.clients, args.window_s, pid, urc.url + "/api/goto"))
            urc.post("/api/stop", {})
            page = page_metrics(urc.url + "/", args.loads, args.window_s) if Path(CHROMIUM).exists() else None
        finally:
            urc.stop()
        feed = tracking_feed(Path(tmp) / "tracking", args.profile, args.window_s)

    result = {"profile": args.profile, "window_s": args.window_s, "clients": args.clients,
              "server_cpu_share": {"no_dashboard": idle, f"{args.clients}_dashboards": ten["cpu_share"],
                                   f"{args.clients}_dashboards_moving": ten_moving["cpu_share"]},
              "server_msgs_per_s_per_client": ten["msgs_per_s_per_client"], "page": page,
              "tracking_feed": feed,
              "host": {"cpus": os.cpu_count(), "python": sys.version.split()[0]}}
    rows = []
    if page:
        fp = page["first_position_ms"]
        rows.append(("page load to first live position", f"{fp['median']:.0f} ms median "
                     f"({fp['min']:.0f}..{fp['max']:.0f}, {len(fp['runs'])} loads)"))
        rows.append((f"updates seen by the page ({args.window_s:g} s)", f"{page['page_rate_msgs_per_s']:.2f} msgs/s"))
        if page["frame_gap_ms"]:
            g = page["frame_gap_ms"]
            rows.append(("gap between frames", f"p50 {g['p50']:.0f} ms, p99 {g['p99']:.0f} ms, max {g['max']:.0f} ms"))
    else:
        rows.append(("page metrics", f"skipped: no {CHROMIUM}"))
    rows.append(("server CPU, no dashboard", f"{idle * 100:.1f} % of one core"))
    rows.append((f"server CPU, {args.clients} dashboards", f"{ten['cpu_share'] * 100:.1f} % of one core "
                 f"({ten['msgs_per_s_per_client']:.1f} msgs/s each)"))
    rows.append((f"server CPU, {args.clients} dashboards, moving", f"{ten_moving['cpu_share'] * 100:.1f} % of one core"))
    width = max(len(r[0]) for r in rows)
    print(f"web dashboard benchmark (profile {args.profile}, urc run on the simulator)")
    for name, value in rows:
        print(f"  {name:<{width}}  {value}")
    print_feed(feed, args.window_s)
    write_json(result, args.json or str(ROOT / "bench" / "results" / "web.json"))


def print_feed(feed: dict, window_s: float) -> None:
    print(f"live feed to one dashboard while tracking (pass at {feed['pass']['aos']}, {window_s:g} s)")
    print(f"  status frames    {feed['status_frames_per_s']:.1f}/s, {feed['status_frame_bytes_mean'] / 1024:.2f} KiB "
          f"mean, {feed['status_frame_bytes_max'] / 1024:.2f} KiB max")
    print(f"  all messages     {feed['msgs_per_s']:.1f}/s, {feed['bytes_per_s'] / 1024:.1f} KiB/s")
    print(f"  sent apart       {feed['other_messages'] or 'nothing'}")


if __name__ == "__main__":
    main()
