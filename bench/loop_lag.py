"""How late urc run's event loop runs a 0.1 s timer while it reads a big element
catalog, plans a pass asked for over the API and answers its first requests (issue 33).

A real ``urc run`` (simulator, a [station], a schedule of one satellite, a catalog of
``--sets`` synthetic LEO sets plus an ISS-like one, imported with ``urc tle import``)
goes through phases:

* start-up: from the loop's first timer until the API answers (urc's own imports of
  its web stack: nothing is served yet, and the control process is not yet pinged);
* first requests: those a dashboard makes when the API answers (/, /api/status,
  /api/info, /api/passes, /api/history, a Sun track), and 3 s more (the catalog read
  at start, the warm-up imports);
* idle;
* pass planned: the next ISS pass flown by POST /api/track/pass, and ISS tracked by
  name (POST /api/track), with /api/status read meanwhile;
* catalog reload, twice: ``urc tle import`` of the whole catalog again with newer
  epochs (the file replaced on disk), until urc says it read it again, and 2 s more;
* idle after.

The lag is measured inside urc's own loop by urc.servers.loop_lag (every sample logged
to a file by URC_LOOP_LAG_LOG). urc run is started through a launcher that starts the
probe first thing in app._serve (what app.py is to do itself; harmless once it does).
Reference, same run: the same timer in a bare asyncio process beside it (what the host
adds: the machine is shared). Also per phase: the I/O process's RSS (VmRSS) and every
"I/O process ... silent" stop the control process announced.

``--src DIR`` runs urc from another source tree (the code before the change, for a
before/after table); the probe module is then loaded from this tree's file.
Prints a table, writes JSON (default bench/results/loop_lag.json). Never gates CI.
Usage: python bench/loop_lag.py [--sets 30000] [--src DIR] [--json PATH]
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timedelta, timezone
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "bench"))
from bench_report import pct, write_json  # noqa: E402
from urc_process import HTTP, UrcProcess  # noqa: E402
from web_abuse_bench import rss_mb  # noqa: E402
from web_bench import STATION, iss_like_tle  # noqa: E402

PROBE_FILE = ROOT / "src" / "urc" / "servers" / "loop_lag.py"

# (guarded: the pass-search worker, started with "spawn", imports this file again)
LAUNCHER = """\
import importlib.util


async def serve_with_probe(*args, **kw):
    try:
        from urc.servers import loop_lag
    except ImportError:  # (a tree from before the probe: this tree's file)
        spec = importlib.util.spec_from_file_location("loop_lag", {probe!r})
        loop_lag = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(loop_lag)
    loop_lag.start()
    return await _serve(*args, **kw)


if __name__ == "__main__":
    import urc.app as app
    _serve = app._serve
    app._serve = serve_with_probe
    from urc.cli import main
    main(prog_name="urc")
"""

REFERENCE = """\
import asyncio, sys, time
async def main():
    loop = asyncio.get_running_loop()
    with open(sys.argv[1], "a", buffering=1) as log:
        while True:
            due = loop.time() + 0.1
            await asyncio.sleep(0.1)
            log.write(f"{time.time():.3f} {max(0.0, loop.time() - due) * 1000.0:.3f}\\n")
asyncio.run(main())
"""


def catalog_tle(n: int, epoch: datetime) -> str:
    """``n`` LEO sets spread in plane and phase (sgp4's own exporter writes the lines)."""
    from sgp4.api import WGS72, Satrec
    from sgp4.exporter import export_tle

    xpdotp = 1440.0 / (2.0 * math.pi)
    days = (epoch - datetime(1949, 12, 31, tzinfo=timezone.utc)).total_seconds() / 86400.0
    out = []
    for i in range(n):
        sat = Satrec()
        sat.sgp4init(WGS72, "i", 100000 + i if i >= 90000 else 10000 + i, days - (i % 97) / 500.0, 1.0e-4, 0.0,
                     0.0, 0.0005 + (i % 13) * 0.001, math.radians((i * 37) % 360), math.radians(40.0 + (i * 7) % 60),
                     math.radians((i * 61) % 360), (14.0 + (i % 20) * 0.1) / xpdotp, math.radians((i * 47) % 360))
        sat.intldesg, sat.classification, sat.elnum, sat.revnum, sat.ephtype = "24001A", "U", 999, 1, 0
        out.append(f"SYNTH-{i:06d}\n" + "\n".join(export_tle(sat)) + "\n")
    return "".join(out)


def read_log(path: Path) -> list[tuple[float, float]]:
    if not path.exists():
        return []
    rows = []
    for line in path.read_text().splitlines():
        parts = line.split()
        if len(parts) == 2:
            rows.append((float(parts[0]), float(parts[1])))
    return rows


def stats(rows: list[tuple[float, float]], t0: float, t1: float) -> dict:
    lags = [lag for t, lag in rows if t0 <= t <= t1]
    if not lags:
        return {"samples": 0, "p50_ms": None, "p99_ms": None, "max_ms": None}
    return {"samples": len(lags), "p50_ms": pct(lags, 0.5), "p99_ms": pct(lags, 0.99), "max_ms": max(lags)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", type=int, default=30000, help="element sets in the catalog")
    ap.add_argument("--idle-s", type=float, default=5.0)
    ap.add_argument("--src", default=None, help="run urc from this source tree (e.g. the code before the change)")
    ap.add_argument("--show-log", action="store_true", help="print the end of urc run's output")
    ap.add_argument("--json", default=str(ROOT / "bench" / "results" / "loop_lag.json"))
    args = ap.parse_args()

    now = datetime.now(timezone.utc)
    results: dict = {"sets": args.sets, "src": args.src or str(ROOT / "src"), "cpus": os.cpu_count(),
                     "load_avg_start": os.getloadavg(), "phases": [], "silence_stops": []}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        files = [work / f"catalog-{k}.tle" for k in range(3)]
        t_gen = time.monotonic()
        for k, path in enumerate(files):
            epoch = now + timedelta(hours=2 * k)
            path.write_text(catalog_tle(args.sets, epoch) + iss_like_tle(epoch))
        results["generate_s"] = time.monotonic() - t_gen
        src = Path(args.src).resolve() if args.src else ROOT / "src"
        os.environ["PYTHONPATH"] = os.pathsep.join([str(src), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        urc = UrcProcess(work, extra=STATION + f"[tracking]\ncatalog_dir = '{work / 'cat'}'\n"
                                              "[[tracking.schedule]]\nsat = 'ISS (ZARYA)'\n")
        tle_import = [sys.executable, "-m", "urc", "tle", "import", "--config", str(urc.config)]
        subprocess.run(tle_import + [str(files[0])], check=True, capture_output=True)
        launcher = work / "launch.py"
        launcher.write_text(LAUNCHER.format(probe=str(PROBE_FILE)))
        import urc_process
        urc_process.URC = [sys.executable, str(launcher)]
        lag_log, ref_log = work / "lag.log", work / "ref.log"
        os.environ["URC_LOOP_LAG_LOG"] = str(lag_log)
        reference = subprocess.Popen([sys.executable, "-c", REFERENCE, str(ref_log)])
        marks: list[tuple[str, float, float]] = []
        events: set[str] = set()

        def phase(name: str, t0: float) -> None:
            marks.append((name, t0, time.time()))
            results.setdefault("rss_mb", {})[name] = rss_mb(urc.proc.pid)
            for e in HTTP.get(urc.url + "/api/status").json()["events"]:
                events.add(e)

        def get(path: str) -> int:
            return HTTP.get(urc.url + path, timeout=60.0).status_code
        try:
            t0 = time.time()
            urc.start_logged(work / "urc.log")
            phase("start-up, until the API answers", t0)

            t0 = time.time()
            for path in ("/", "/api/status", "/api/info", "/api/passes?hours=24", "/api/history", "/api/status"):
                results.setdefault("first_requests", {})[path] = get(path)
            urc.post("/api/track", {"kind": "sun"})
            get("/api/status")
            time.sleep(3.0)
            phase("first requests", t0)

            t0 = time.time()
            time.sleep(args.idle_s)
            phase("idle", t0)

            t0 = time.time()
            r = HTTP.get(urc.url + "/api/passes?hours=24", timeout=60.0)
            assert r.status_code == 200, f"/api/passes: HTTP {r.status_code} {r.text[:300]}"
            passes = r.json()
            iss = next(p for p in passes if p["norad"] == 25544)
            r = HTTP.post(urc.url + "/api/track/pass", json={"norad": 25544, "aos": iss["aos"]}, timeout=60.0)
            results["track_pass_status"] = r.status_code
            get("/api/status")
            r = HTTP.post(urc.url + "/api/track", json={"kind": "satellite", "name": "iss"}, timeout=60.0)
            results["track_status"] = r.status_code
            for _ in range(10):
                get("/api/status")
                time.sleep(0.2)
            phase("pass planned via the API", t0)

            for k in (1, 2):
                t0 = time.time()
                said = sum("element catalog changed on disk" in e for e in HTTP.get(urc.url + "/api/status")
                           .json()["events"])
                subprocess.run(tle_import + [str(files[k])], check=True, capture_output=True)
                results.setdefault("import_s", []).append(time.time() - t0)
                deadline = time.monotonic() + 300.0
                while time.monotonic() < deadline:
                    evs = HTTP.get(urc.url + "/api/status").json()["events"]
                    if sum("element catalog changed on disk" in e for e in evs) > said:
                        break
                    time.sleep(0.2)
                else:
                    results["reload_not_seen"] = True
                results.setdefault("reload_s", []).append(time.time() - t0)
                time.sleep(2.0)
                phase(f"catalog reload {k} (urc tle import)", t0)

            t0 = time.time()
            time.sleep(args.idle_s)
            phase("idle after", t0)
            results["loop_lag_status"] = HTTP.get(urc.url + "/api/status").json().get("loop_lag")
        finally:
            urc.stop()
            if args.show_log:
                print((work / "urc.log").read_text()[-5000:])
            reference.kill()
            reference.wait()
        rows, ref_rows = read_log(lag_log), read_log(ref_log)
        for name, a, b in marks:
            results["phases"].append({"phase": name, "seconds": b - a, "urc": stats(rows, a, b),
                                      "reference": stats(ref_rows, a, b), "rss_mb": results["rss_mb"][name]})
        results["whole_run"] = {"urc": stats(rows, marks[0][1], marks[-1][2]),
                                "reference": stats(ref_rows, marks[0][1], marks[-1][2])}
        results["silence_stops"] = sorted(e for e in events if "silent" in e)
    results["load_avg_end"] = os.getloadavg()

    def cell(s: dict, key: str) -> str:
        return "-" if s[key] is None else f"{s[key]:.1f}"
    print(f"event-loop lag of urc run (0.1 s timer), {args.sets} sets, src {results['src']}, "
          f"{os.cpu_count()} CPUs, load average {results['load_avg_start'][0]:.1f} at start")
    print(f"  {'phase':<34} {'s':>5} {'p50 ms':>7} {'p99 ms':>7} {'max ms':>8} {'ref p99':>8} {'ref max':>8} "
          f"{'RSS MB':>7}")
    for p in results["phases"] + [{"phase": "whole run", "seconds": float("nan"), "rss_mb": float("nan"),
                                   **results["whole_run"]}]:
        u, ref = p["urc"], p["reference"]
        print(f"  {p['phase']:<34} {p['seconds']:5.1f} {cell(u, 'p50_ms'):>7} {cell(u, 'p99_ms'):>7} "
              f"{cell(u, 'max_ms'):>8} {cell(ref, 'p99_ms'):>8} {cell(ref, 'max_ms'):>8} {p['rss_mb']:7.1f}")
    print(f"  I/O-silence stops: {len(results['silence_stops'])}"
          + "".join(f"\n    {e}" for e in results["silence_stops"]))
    print(f"  track/pass HTTP {results.get('track_pass_status')}, track HTTP {results.get('track_status')}; "
          f"imports took {', '.join(f'{s:.1f}' for s in results.get('import_s', []))} s, reloads seen after "
          f"{', '.join(f'{s:.1f}' for s in results.get('reload_s', []))} s"
          + ("; a reload was NOT seen" if results.get("reload_not_seen") else ""))
    write_json(results, args.json)


if __name__ == "__main__":
    main()
