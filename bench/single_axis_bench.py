"""Azimuth pointing of single-axis rotators ([rotator] elevation = false) flying whole
passes on the simulator: the Tartu TRC-style turntable (tartu-urc, encoder 0.1 deg) and
BIG-RAS with "Elevation: OFF" (bigras, pulses 0.5 deg), over the same standard passes as
bench/tracking_bench.py (a low pass, a pass crossing north, a ~89 deg keyhole).

The measure is the azimuth error (the beam stands at the horizon: the elevation error
is the satellite's elevation by construction): RMS, p95, max, time within 0.1 / 0.5 deg,
error at AOS, against the sensor floor q/sqrt(12). Also the plan's own azimuth error
(a keyhole's 180 deg swing is faster than any azimuth motor: geometry, not control).
Prints a table, writes JSON (default bench/results/single_axis.json).
Usage: python bench/single_axis_bench.py [--profiles a,b] [--json PATH]
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_report import write_json  # noqa: E402
from tracking_bench import scenarios  # noqa: E402
from urc.profiles import PROFILES  # noqa: E402
from urc.testing.evaluate import PointingStats, fly_pass_on_sim  # noqa: E402
from urc.tracking.propagate import look_angles  # noqa: E402


def az_error_deg(a, b) -> np.ndarray:
    return np.abs((np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0)


def run(profiles: list[str]) -> list[dict]:
    rows = []
    for profile in profiles:
        q = PROFILES[profile].az.sensor.resolution_deg
        for name, es, station, p in scenarios():
            with tempfile.TemporaryDirectory() as tmp:
                flown = fly_pass_on_sim(profile, es, station, p, Path(tmp),
                                        config={"rotator": {"elevation": False}})
            t, az, _ = flown.flight
            up = (t >= p.aos_unix_s) & (t <= p.los_unix_s)
            la = look_angles(es, station, t[up])
            stats = PointingStats.of(az_error_deg(az[up], la.az_deg))
            plan_az = np.interp(t[up], flown.plan.t_s, flown.plan.az_deg) + flown.rotator.geometry.az_offset_deg
            plan = PointingStats.of(az_error_deg(plan_az, la.az_deg))
            rows.append({"profile": profile, "scenario": name, "max_el_deg": round(p.max_el_deg, 1),
                         "faults": [f.kind for f in flown.rotator.status().faults],
                         "floor_deg": round(q / math.sqrt(12), 4), "az": stats.as_dict(), "plan_az": plan.as_dict(),
                         "notes": list(flown.plan.notes)})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profiles", default="tartu-urc,bigras")
    ap.add_argument("--json", default="bench/results/single_axis.json")
    args = ap.parse_args()
    rows = run(args.profiles.split(","))
    print(f"{'profile':10} {'scenario':22} {'RMS':>7} {'p95':>7} {'max':>7} {'<0.1':>6} {'<0.5':>6} "
          f"{'AOS':>6} {'plan max':>8} {'floor':>6}  faults")
    for r in rows:
        a = r["az"]
        print(f"{r['profile']:10} {r['scenario']:22} {a['rms_deg']:7.3f} {a['p95_deg']:7.3f} {a['max_deg']:7.2f} "
              f"{a['within_0_1_pct']:5.1f}% {a['within_0_5_pct']:5.1f}% {a['aos_error_deg']:6.2f} "
              f"{r['plan_az']['max_deg']:8.2f} {r['floor_deg']:6.3f}  {','.join(r['faults']) or '-'}")
    write_json({"rows": rows}, args.json)


if __name__ == "__main__":
    main()
