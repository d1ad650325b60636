"""Web dashboard benchmark, against a real ``urc run`` (simulator, berkeley profile).

Measures:
* page load to first live position: navigation start to the first WebSocket frame drawn
  on the sky plot, in headless chromium (Debian's /usr/bin/chromium), fresh context each run;
* update rate the page actually sees: WebSocket messages per second over 10 s (the page's
  own counter), plus the spread of the gaps between frames;
* server CPU share of one core (utime + stime from /proc/<pid>/stat) with no dashboard,
  with 10 open dashboards (10 WebSocket clients reading every frame), and with 10 while
  the antenna moves.

Prints a table, writes JSON (default bench/results/web.json). Never gates CI.
Usage: python bench/web_bench.py [--loads 5] [--window-s 10] [--json PATH]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from bench_report import write_json
from urc_process import UrcProcess  # noqa: E402

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
CLK_TCK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK   # utime, stime


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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--loads", type=int, default=5)
    ap.add_argument("--window-s", type=float, default=10.0)
    ap.add_argument("--clients", type=int, default=10)
    ap.add_argument("--profile", default="berkeley")
    ap.add_argument("--json", default=str(ROOT / "bench" / "results" / "web.json"))
    args = ap.parse_args()

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

    result = {"profile": args.profile, "window_s": args.window_s, "clients": args.clients,
              "server_cpu_share": {"no_dashboard": idle, f"{args.clients}_dashboards": ten["cpu_share"],
                                   f"{args.clients}_dashboards_moving": ten_moving["cpu_share"]},
              "server_msgs_per_s_per_client": ten["msgs_per_s_per_client"], "page": page,
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
    write_json(result, args.json)


if __name__ == "__main__":
    main()
