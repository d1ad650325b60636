"""Pass-search benchmark: urc's catalog search against skyfield's ``find_events``.

A deterministic 1000-satellite LEO catalog (inclination 0-110 deg, RAAN/argument of
perigee/mean anomaly uniform, eccentricity 0.0001-0.02, mean motion 14-16 rev/day) is
written as TLE lines with correct checksums by sgp4's exporter, read back through
``urc.tracking.elements.parse_tle``, and searched for 24 h of passes from one station
by both programs in the same run. Passes are compared event by event: AOS (rise) and LOS
(set) must agree within 1 s; unmatched events on either side are listed.

Prints a table, writes JSON (default bench/results/passes.json). Never gates CI.
Usage: python bench/passes_bench.py [--sats 1000] [--hours 24] [--min-el 0,10]
       [--sky-subset N] [--repeat 5] [--sky-repeat 2] [--json PATH]
``--sky-subset N`` times skyfield on N random satellites only and scales to the catalog
(the table says so); by default skyfield runs on all of them.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import random
import sys
import time
import warnings
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
from sgp4.api import WGS72, Satrec
from sgp4.exporter import export_tle

from urc.tracking import sky
from urc.tracking.elements import parse_tle
from urc.tracking.passes import search_passes
from urc.tracking.station import Station

START = datetime(2024, 1, 1, 12, 0, tzinfo=timezone.utc)
EPOCH = datetime(2024, 1, 1, 6, 0, tzinfo=timezone.utc)
STATION = Station(58.3780, 26.7290, 70.0, "Tartu")
MATCH_S = 1.0


def make_catalog(n: int, seed: int = 20240101) -> str:
    """``n`` synthetic LEO element sets as 3LE text (deterministic)."""
    rng = random.Random(seed)
    xpdotp = 1440.0 / (2.0 * math.pi)
    epoch_days = (EPOCH - datetime(1949, 12, 31, tzinfo=timezone.utc)).total_seconds() / 86400
    lines = []
    for i in range(n):
        norad = 70000 + i
        inc = rng.choice([rng.uniform(0, 30), rng.uniform(45, 75), rng.uniform(80, 110),
                          rng.uniform(96, 99)])
        ecc = rng.uniform(0.0001, 0.02)
        n_rev = rng.uniform(14.0, 16.0)
        sat = Satrec()
        sat.sgp4init(WGS72, "i", norad, epoch_days + rng.uniform(-1.0, 0.0),
                     rng.uniform(1e-5, 3e-4), rng.uniform(0, 2e-4) / (xpdotp * 1440.0), 0.0,
                     ecc, math.radians(rng.uniform(0, 360)), math.radians(inc),
                     math.radians(rng.uniform(0, 360)), n_rev / xpdotp,
                     math.radians(rng.uniform(0, 360)))
        sat.intldesg, sat.classification, sat.elnum, sat.revnum, sat.ephtype = \
            f"24{i // 26 + 1:03d}{chr(65 + i % 26)}", "U", 999, 1000 + i, 0
        l1, l2 = export_tle(sat)
        lines += [f"SYNTH-{i:04d}", l1, l2]
    return "\n".join(lines) + "\n"


def skyfield_events(sets, hours: float, min_el: float):
    from skyfield.api import EarthSatellite

    ts = sky.timescale()
    t0 = sky.to_time(START)
    t1 = sky.to_time(START + timedelta(hours=hours))
    out = {}
    for es in sets:
        sat = EarthSatellite.from_satrec(es.satrec, ts)
        t, ev = sat.find_events(STATION.skyfield, t0, t1, altitude_degrees=min_el)
        u = sky.unix_s(t) if len(ev) else np.array([])
        out[es.norad_id] = (np.atleast_1d(u), np.atleast_1d(ev))
    return out


def crosses(es, t_unix_s: float, min_el: float) -> bool:
    """The arbiter for an event only one side found: does elevation cross min_el there?"""
    from urc.tracking.propagate import look_angles

    el = look_angles(es, STATION, [t_unix_s - 2.0, t_unix_s + 2.0]).el_deg
    return bool((el[0] - min_el) * (el[1] - min_el) < 0)


def compare(passes, sky_events, ids, by_id, min_el: float) -> dict:
    """Match rises to AOS and sets to LOS within MATCH_S; check the leftovers against the
    elevation itself (a real crossing or not)."""
    ours = {i: ([], []) for i in ids}
    for p in passes:
        if not p.aos_clipped:
            ours[p.norad_id][0].append(p.aos.timestamp())
        if not p.los_clipped:
            ours[p.norad_id][1].append(p.los.timestamp())
    stats = {"events_sky": 0, "events_urc": 0, "matched": 0, "max_diff_s": 0.0,
             "missed_by_urc": [], "extra_in_urc": []}
    diffs = []
    for i in ids:
        u, ev = sky_events[i]
        for kind, mine in ((0, ours[i][0]), (2, ours[i][1])):
            theirs = sorted(u[ev == kind].tolist())
            mine = sorted(mine)
            stats["events_sky"] += len(theirs)
            stats["events_urc"] += len(mine)
            used = set()
            for t in theirs:
                j = min(range(len(mine)), key=lambda j: abs(mine[j] - t), default=None)
                if j is not None and j not in used and abs(mine[j] - t) <= MATCH_S:
                    used.add(j)
                    diffs.append(abs(mine[j] - t))
                else:
                    stats["missed_by_urc"].append((i, "rise" if kind == 0 else "set",
                                                   sky.utc_datetime(t).isoformat(),
                                                   "real" if crosses(by_id[i], t, min_el)
                                                   else "not a crossing"))
            for j, t in enumerate(mine):
                if j not in used:
                    stats["extra_in_urc"].append((i, "AOS" if kind == 0 else "LOS",
                                                  sky.utc_datetime(t).isoformat(),
                                                  "real" if crosses(by_id[i], t, min_el)
                                                  else "not a crossing"))
    stats["matched"] = len(diffs)
    stats["max_diff_s"] = max(diffs, default=0.0)
    stats["mean_diff_s"] = float(np.mean(diffs)) if diffs else 0.0
    return stats


def run(n_sats: int, hours: float, min_el: float, subset: int | None, repeat: int,
        sky_repeat: int) -> dict:
    sets = parse_tle(make_catalog(n_sats), "synthetic")
    best = best_cpu = math.inf
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        res = search_passes(sets, STATION, START, duration_s=hours * 3600.0, min_el_deg=min_el)
        best = min(best, time.perf_counter() - t)
        best_cpu = min(best_cpu, time.process_time() - c)
    if subset and subset < n_sats:
        chosen = random.Random(1).sample(sets, subset)
    else:
        chosen = sets
    sky_s = sky_cpu_s = math.inf
    for _ in range(sky_repeat):
        t, c = time.perf_counter(), time.process_time()
        sky_ev = skyfield_events(chosen, hours, min_el)
        sky_s = min(sky_s, time.perf_counter() - t)
        sky_cpu_s = min(sky_cpu_s, time.process_time() - c)
    sky_full_s = sky_s * n_sats / len(chosen)
    sky_full_cpu_s = sky_cpu_s * n_sats / len(chosen)
    chosen_ids = [es.norad_id for es in chosen]
    cmp = compare([p for p in res.passes if p.norad_id in set(chosen_ids)], sky_ev, chosen_ids,
                  {es.norad_id: es for es in chosen}, min_el)
    return {"satellites": n_sats, "hours": hours, "min_el_deg": min_el,
            "passes_urc": len(res.passes), "urc_s": best, "urc_cpu_s": best_cpu,
            "skyfield_s": sky_full_s, "skyfield_cpu_s": sky_full_cpu_s,
            "skyfield_measured_on": len(chosen), "skyfield_scaled": len(chosen) != n_sats,
            "ratio": sky_full_s / best, "ratio_cpu": sky_full_cpu_s / best_cpu,
            "urc_evaluations": res.stats["evaluations"],
            "evaluations_per_sat": res.stats["evaluations"] / n_sats,
            "sgp4_errors": len(res.errors), **cmp}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sats", type=int, default=1000)
    ap.add_argument("--hours", type=float, default=24.0)
    ap.add_argument("--min-el", default="0,10", help="comma-separated minimum elevations")
    ap.add_argument("--sky-subset", type=int, default=None)
    ap.add_argument("--repeat", type=int, default=5, help="urc runs (best is kept)")
    ap.add_argument("--sky-repeat", type=int, default=2, help="skyfield runs (best is kept)")
    ap.add_argument("--json", default=str(Path(__file__).parent / "results" / "passes.json"))
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore", RuntimeWarning)
    sky.timescale()  # load data outside the timed parts
    rows = [run(args.sats, args.hours, float(e), args.sky_subset, args.repeat, args.sky_repeat)
            for e in args.min_el.split(",")]
    print(f"Pass search, {args.sats} satellites x {args.hours:g} h, station "
          f"{STATION.lat_deg:.3f}N {STATION.lon_deg:.3f}E, start {START.isoformat()}")
    head = (f"{'min_el':>6} {'passes':>7} {'urc s':>8} {'skyfield s':>11} {'ratio':>7} "
            f"{'cpu ratio':>9} "
            f"{'evals/sat':>9} {'AOS+LOS':>8} {'matched':>8} {'max d s':>8} {'missed':>7} "
            f"{'extra':>6}")
    print(head)
    print("-" * len(head))
    for r in rows:
        scaled = "*" if r["skyfield_scaled"] else " "
        print(f"{r['min_el_deg']:>6g} {r['passes_urc']:>7d} {r['urc_s']:>8.3f} "
              f"{r['skyfield_s']:>10.2f}{scaled} {r['ratio']:>6.1f}x {r['ratio_cpu']:>8.1f}x "
              f"{r['evaluations_per_sat']:>9.0f} "
              f"{r['events_sky']:>8d} {r['matched']:>8d} {r['max_diff_s']:>8.3f} "
              f"{len(r['missed_by_urc']):>7d} {len(r['extra_in_urc']):>6d}")
        for what in ("missed_by_urc", "extra_in_urc"):
            for item in r[what][:5]:
                print(f"    {what}: NORAD {item[0]} {item[1]} {item[2]} ({item[3]})")
    print(f"best of {args.repeat} urc and {args.sky_repeat} skyfield runs; ratio = wall time, "
          "cpu ratio = process CPU time (steadier on a shared machine)")
    if any(r["skyfield_scaled"] for r in rows):
        print("* skyfield timed on a random subset and scaled to the whole catalog; "
              "passes compared on that subset")
    out = {"benchmark": "passes", "python": sys.version.split()[0],
           "machine": platform.machine(), "station": [STATION.lat_deg, STATION.lon_deg,
                                                      STATION.alt_m],
           "start": START.isoformat(), "match_tolerance_s": MATCH_S, "runs": rows}
    path = Path(args.json)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
