"""A pass flown while ``stress-ng --cpu 8`` runs (issue 21): no stop for a silent I/O
process, and the antenna on the satellite at AOS.

A synthetic LEO satellite is chosen whose pass over the station starts a few minutes
from now (elements of today's epoch, so nothing ages); a real ``urc run`` (simulator)
imports it, ``stress-ng --cpu N`` starts, and the pass is asked for through the API
(``POST /api/track/pass``, what the dashboard's "track this pass" does). /api/status is
polled every 0.2 s until LOS. Reported: the pointing error (great circle between the
antenna's az/el in the status and the satellite's look angles at the time of the
sample) at AOS, and its p50/p99/max over the pass; the events saying the axes were
stopped for a silent I/O process or a late loop; faults latched; the control loop's
late-tick p99; how long the track request took to be answered.

Prints a table, writes JSON (default bench/results/stress-pass.json). Never gates CI.
Usage: python bench/stress_pass_bench.py [--cpu 8] [--profile g5500] [--json PATH]
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "bench"))
from bench_report import write_json  # noqa: E402
from urc_process import URC, UrcProcess, stop_process_group  # noqa: E402

from urc.angles import great_circle_deg  # noqa: E402
from urc.testing.synthetic import STATION_TOML as STATION  # noqa: E402
from urc.testing.synthetic import satellite_passing_soon  # noqa: E402
from urc.tracking.propagate import look_angles  # noqa: E402
from urc.tracking.station import Station  # noqa: E402

TARTU = Station(58.378, 26.729, 70.0, "Tartu")
NORAD = 99001
POLL_S = 0.2


def pick_satellite(work: Path, lead_s: tuple[float, float], min_max_el_deg: float):
    """(TLE text, elements, pass) of a synthetic LEO whose next pass starts within
    ``lead_s`` seconds from now and rises above ``min_max_el_deg``."""
    return satellite_passing_soon(work, TARTU, lead_s, min_max_el_deg, norad=NORAD, name="STRESS-SAT")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cpu", type=int, default=8, help="stress-ng --cpu workers (0: no stress)")
    ap.add_argument("--profile", default="g5500")
    ap.add_argument("--min-max-el", type=float, default=30.0)
    ap.add_argument("--json", default="bench/results/stress-pass.json")
    args = ap.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        text, es, p = pick_satellite(work, (150.0, 420.0), args.min_max_el)
        print(f"pass: AOS {p.aos:%H:%M:%S}Z, LOS {p.los:%H:%M:%S}Z, max el {p.max_el_deg:.1f} deg, "
              f"AOS az {p.aos_az_deg:.1f}", flush=True)
        tle = work / "sat.tle"
        tle.write_text(text)
        urc = UrcProcess(work, profile=args.profile, extra=STATION + f"[tracking]\ncatalog_dir = '{work / 'cat'}'\n")
        subprocess.run(URC + ["tle", "import", str(tle), "--config", str(urc.config)], check=True,
                       capture_output=True)
        log_path = work / "urc.log"
        urc.start_logged(log_path)
        stress = None
        try:
            if args.cpu:
                stress = subprocess.Popen(["stress-ng", "--cpu", str(args.cpu), "--timeout",
                                           f"{int(p.los_unix_s - time.time() + 60)}s", "--quiet"],
                                          start_new_session=True)
                time.sleep(5.0)  # the load is on before the request
            t_req = time.monotonic()
            r = httpx.post(urc.url + "/api/track/pass", json={"norad": NORAD, "aos": p.aos.isoformat()},
                           timeout=120)
            request_s = time.monotonic() - t_req
            r.raise_for_status()
            samples, events, faults = poll_until(urc.url, p.los_unix_s + 5.0)
            final = httpx.get(urc.url + "/api/status", timeout=60).json()
        finally:
            if stress is not None:
                stop_process_group(stress, timeout_s=10)
            stop_process_group(urc.proc)

    t = np.array([s[0] for s in samples])
    up = (t >= p.aos_unix_s) & (t <= p.los_unix_s)
    la = look_angles(es, TARTU, t[up])
    err = great_circle_deg(np.array([s[1] for s in samples])[up], np.array([s[2] for s in samples])[up],
                           la.az_deg, la.el_deg)
    stops = [e for e in events if "silent" in e or "late by" in e or "motors stopped" in e]
    result = {"cpu_workers": args.cpu, "profile": args.profile, "aos": p.aos.isoformat(), "los": p.los.isoformat(),
              "max_el_deg": p.max_el_deg, "track_request_s": round(request_s, 2),
              "aos_error_deg": round(float(err[0]), 3) if len(err) else math.nan,
              "error_p50_deg": round(float(np.percentile(err, 50)), 3) if len(err) else math.nan,
              "error_p99_deg": round(float(np.percentile(err, 99)), 3) if len(err) else math.nan,
              "error_max_deg": round(float(err.max()), 3) if len(err) else math.nan,
              "samples_in_pass": int(up.sum()), "stop_events": stops, "faults": sorted(faults),
              "tick_late_p99_ms": final.get("tick_late_p99_ms"), "events": events}
    rows = [("stress-ng --cpu", str(args.cpu)), ("pass", f"{result['aos']} .. {result['los']}, max el "
                                                          f"{p.max_el_deg:.1f} deg"),
            ("track request answered in", f"{request_s:.2f} s"),
            ("pointing error at AOS", f"{result['aos_error_deg']:.3f} deg"),
            ("pointing error over the pass", f"p50 {result['error_p50_deg']:.3f}, p99 {result['error_p99_deg']:.3f}, "
                                             f"max {result['error_max_deg']:.3f} deg ({result['samples_in_pass']} samples)"),
            ("axes stopped (silence, late loop)", "; ".join(stops) or "none"),
            ("faults latched", "; ".join(result["faults"]) or "none"),
            ("control loop late-tick p99", f"{result['tick_late_p99_ms']} ms")]
    width = max(len(r[0]) for r in rows)
    for name, value in rows:
        print(f"  {name:<{width}}  {value}")
    write_json(result, args.json)


def poll_until(url: str, end_unix_s: float) -> tuple[list[tuple[float, float, float]], list[str], set[str]]:
    """(unix time, az, el) of each status until ``end_unix_s``, every event seen, every fault."""
    samples: list[tuple[float, float, float]] = []
    events: list[str] = []
    faults: set[str] = set()
    with httpx.Client(timeout=30) as http:
        while time.time() < end_unix_s:
            t0 = time.time()
            try:
                s = http.get(url + "/api/status").json()
            except httpx.HTTPError:
                continue
            t1 = time.time()
            if t1 - t0 < 0.5:  # a late answer cannot be placed in time well enough
                samples.append((0.5 * (t0 + t1), s["az_deg"], s["el_deg"]))
            for e in s["events"]:
                if e not in events:
                    events.append(e)
            faults.update(f"{f['kind']}: {f['reason']}" for f in s["faults"])
            time.sleep(max(0.0, t0 + POLL_S - time.time()))
    return samples, events, faults



if __name__ == "__main__":
    main()
