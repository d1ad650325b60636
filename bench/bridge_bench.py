"""Bridge benchmark: a full pass flown through each bridge protocol, on the virtual clock.

The controller a station owns is urc's simulator (one profile, default g5500: a
G-5500 class rotator) behind urc's own device emulation of each protocol; the wire is
simulated at the protocol's usual baud rate with Hamlib's post-write delays
(urc.testing.bridged_rig). For each protocol the same pass is flown three ways and
judged by the controller's simulator truth (docs/ARCHITECTURE.md pointing error):

* ``bridge``: urc with the bridge backend plans and tracks the pass;
* ``gpredict``: Gpredict-style driving of the same controller over the same wire (a
  target every 0.8 s when it moved more than 5 deg, no plan);
* and once, ``direct``: urc on the simulator itself (no bridge), the floor.

Like with like (as bench/tracking_bench.py): where the controller can flip, every driver
flies by its own flip rule, urc's planner per pass (flip = "auto"), Gpredict a whole pass
flipped when its azimuth track crosses north (is_flipped_pass); the flip column names the
rule and what it chose.

Also the link each protocol makes: round trip of one exchange and the age of a
position report. Prints a table, writes JSON (default bench/results/bridge.json).
Usage: python bench/bridge_bench.py [--profile g5500] [--protocols a,b] [--scenario low]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench_report import write_json
from tracking_bench import FLIP_RULES, flip_text, scenarios
from urc.hardware.bridge import BRIDGE_PROTOCOLS
from urc.testing.bridged_rig import BridgedRig
from urc.testing.evaluate import (GpredictDriver, PointingStats, fly_pass_on_sim, gpredict_flips_pass,
                                   great_circle_deg)
from urc.tracking.propagate import look_angles
from urc.tracking.targets import SatelliteTarget
from urc.tracking.tracker import Tracker

LEAD_S = 240.0  # the flight starts this long before AOS (pre-positioning)
#: Rot1Prog turns azimuth only: the bridged urc's elevation is held at 0 (README), and
#: its pass is judged by the azimuth error alone
AZ_ONLY = {"rot1prog": {"limits": {"el": {"min_deg": 0.0, "max_deg": 1.0}}}}


class _WireGoto:
    """What Gpredict drives: the controller itself, over the wire (no urc in between)."""

    def __init__(self, rig: BridgedRig):
        self.rig = rig

    def goto(self, az_deg: float, el_deg: float) -> None:
        self.rig.client.post("az", az_deg)
        self.rig.client.post("el", el_deg)


def fly_bridge(protocol: str, profile: str, es, station, p, driver: str, tmp: Path) -> dict:
    start_u = p.aos_unix_s - LEAD_S
    rig = BridgedRig(protocol, profile, tmp, downstream_config=AZ_ONLY.get(protocol))

    def unix_at(now_s: float) -> float:
        return start_u + now_s
    if driver == "bridge":
        tracker = Tracker(rig.downstream, station, unix_at, park_after_pass=False)
        flipped = bool(tracker.track_pass(es, p, rig.clock.now_s()).flip)
        step = tracker.step
    else:
        # the rotator's ranges as the bridged urc has them (Rot1Prog: azimuth only)
        flipped = gpredict_flips_pass(es, station, p, rig.downstream.geometry)
        step = GpredictDriver(_WireGoto(rig), SatelliteTarget(es, station), unix_at, p.aos_unix_s,
                              p.los_unix_s, flipped=flipped).step
    geometry = rig.upstream.geometry
    t, az, el, rtt, age = [], [], [], [], []
    n = round((p.los_unix_s - unix_at(rig.clock.now_s())) / rig.period_s)
    for _ in range(n):
        rig.tick(downstream=driver == "bridge")
        now = rig.clock.now_s()
        step(now)
        truth = rig.upstream.status().sim_truth
        a, e = geometry.to_sky(truth["az"]["deg"], truth["el"]["deg"])
        t.append(unix_at(now))
        az.append(a)
        el.append(e)
        rtt.append(rig.client.latency_s())
        age.append(rig.client.sample_interval_s())
    t, az, el = np.array(t), np.array(az), np.array(el)
    up = (t >= p.aos_unix_s) & (t <= p.los_unix_s)
    la = look_angles(es, station, t[up])
    if protocol in AZ_ONLY:
        stats = PointingStats.of(np.abs((az[up] - la.az_deg + 180.0) % 360.0 - 180.0))
    else:
        stats = PointingStats.of(great_circle_deg(az[up], el[up], la.az_deg, la.el_deg))
    faults = [f.kind for f in rig.downstream.status().faults] if driver == "bridge" else []
    g = rig.downstream.geometry   # its limits (Rot1Prog: elevation held at 0, cannot flip)
    can_flip = g.el_max_deg + g.el_offset_deg >= 180.0
    rule = FLIP_RULES["gpredict" if driver == "gpredict" else "urc"] if can_flip else "cannot"
    return {**stats.as_dict(), "flip_rule": rule, "flip": flipped, "rtt_ms": 1000 * float(np.median(rtt)),
            "report_interval_ms": 1000 * float(np.median(age)),
            "sets": rig.client.counts["sets"], "faults": faults,
            "garbage_or_timeouts": rig.client.counts["garbage"] + rig.client.counts["timeouts"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--profile", default="g5500")
    ap.add_argument("--protocols", default=",".join(BRIDGE_PROTOCOLS))
    ap.add_argument("--scenario", default="low pass", help="low pass | north crossing | keyhole")
    ap.add_argument("--json", default="bench/results/bridge.json")
    args = ap.parse_args()
    name, es, station, p = next(c for c in scenarios() if c[0].startswith(args.scenario))
    print(f"{name}: max el {p.max_el_deg:.1f} deg, {(p.los_unix_s - p.aos_unix_s) / 60:.1f} min, "
          f"profile {args.profile}", file=sys.stderr)
    rows = []
    for driver in ("urc", "gpredict"):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.process_time()
            flown = fly_pass_on_sim(args.profile, es, station, p, Path(tmp), driver=driver, lead_s=LEAD_S)
            rows.append({"protocol": "direct (sim)", "driver": driver, **flown.stats.as_dict(),
                         "flip_rule": FLIP_RULES[driver] if flown.rotator.caps.can_flip else "cannot",
                         "flip": flown.flipped, "rtt_ms": None,
                         "report_interval_ms": None, "sets": None, "faults": [], "garbage_or_timeouts": 0,
                         "cpu_s": time.process_time() - t0})
    for protocol in args.protocols.split(","):
        for driver in ("bridge", "gpredict"):
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.process_time()
                r = fly_bridge(protocol, args.profile, es, station, p, driver, Path(tmp))
                rows.append({"protocol": protocol, "driver": driver, **r, "cpu_s": time.process_time() - t0})
        print(f"{protocol}: done", file=sys.stderr, flush=True)
    print(f"\nPointing error through each bridge vs the controller's simulator truth (deg); {name}, "
          f"profile {args.profile}.\nrtt = one exchange on the simulated wire; report = spacing of "
          "position reports; sets = targets sent to the controller; rot1prog (azimuth only): the azimuth error;"
          "\nflip = rule:choice; auto = urc's planner per pass, gp = Gpredict's whole-pass flip across north")
    print(f"{'protocol':13s} {'driver':8s} {'RMS':>6s} {'p95':>6s} {'max':>6s} {'<0.5%':>6s} {'AOS err':>7s} "
          f"{'rtt ms':>7s} {'report ms':>9s} {'sets':>5s} {'faults':>6s} {'flip':>9s}")
    for r in rows:
        rtt = "" if r["rtt_ms"] is None else f"{r['rtt_ms']:.1f}"
        rep = "" if r["report_interval_ms"] is None else f"{r['report_interval_ms']:.0f}"
        print(f"{r['protocol']:13s} {r['driver']:8s} {r['rms_deg']:6.3f} {r['p95_deg']:6.3f} {r['max_deg']:6.3f} "
              f"{r['within_0_5_pct']:6.1f} {r['aos_error_deg']:7.3f} {rtt:>7s} {rep:>9s} "
              f"{'' if r['sets'] is None else r['sets']:>5} {len(r['faults']):6d} {flip_text(r):>9s}")
    write_json({"scenario": name, "profile": args.profile, "max_el_deg": p.max_el_deg, "rows": rows}, args.json)


if __name__ == "__main__":
    main()
