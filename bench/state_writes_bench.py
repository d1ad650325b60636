"""State-file writes per hour of tracking (issue 9.14: SD cards wear out).

Counts ``StateStore.save`` calls while each simulated profile tracks, on the virtual
clock: a LEO-like pass (az sweeping 150 deg, el up to 60 deg in 10 minutes) and a slow
Moon-like target (15 deg/h). Works on any urc version (it wraps the rotator's own
store), so the same command run with an older tree on PYTHONPATH gives "before".
Prints a table, writes JSON (default bench/results/state_writes.json).
Usage: python bench/state_writes_bench.py [--profiles a,b] [--json PATH]
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

from bench_report import write_json
from urc.assembly import build_rotator
from urc.clock import VirtualClock
from urc.config import Config
from urc.profiles import PROFILES
from urc.rotator.loop import run_virtual

PASS_S = 600.0


def leo(t_s: float) -> tuple[float, float, float, float]:
    """az, el, az rate, el rate of a 10-minute pass."""
    w = math.pi / PASS_S
    return (100.0 + 0.25 * t_s, 5.0 + 55.0 * math.sin(w * t_s), 0.25, 55.0 * w * math.cos(w * t_s))


def moon(t_s: float) -> tuple[float, float, float, float]:
    return (120.0 + t_s / 240.0, 20.0 + t_s / 360.0, 1 / 240.0, 1 / 360.0)


def writes_per_hour(profile: str, target, duration_s: float) -> dict:
    cfg = Config.from_dict({"rotator": {"profile": profile}, "hardware": {"sim": {"wind": True}}})
    clock = VirtualClock(1000.0)
    with tempfile.TemporaryDirectory() as d:
        rot = build_rotator(cfg, clock, Path(d) / "state", durable_state=False)
        az, el, *_ = target(0.0)
        rot.goto(az, el)
        run_virtual(rot, clock, 300.0, until=lambda s: not s.moving and s.az.mode in ("holding", "idle")
                    and s.el.mode in ("holding", "idle"))
        store = rot.store
        count = [0]
        real_save = store.save

        def save(payload):
            count[0] += 1
            real_save(payload)
        store.save = save
        t0 = clock.now_s()
        last = [-1.0]

        def feed(status):
            t = status.t_s - t0
            if t - last[0] >= 0.5:  # a tracker's update rate
                last[0] = t
                a, e, ra, re = target(t)
                rot.track(a, e, ra, re, t_ref_s=status.t_s)
        run_virtual(rot, clock, duration_s, on_tick=feed)
        rot.stop()
        run_virtual(rot, clock, 30.0)
        rot.shutdown()
        rot.hw.close()
    return {"writes": count[0], "per_hour": count[0] * 3600.0 / (duration_s + 30.0)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--profiles", default=",".join(sorted(PROFILES)))
    ap.add_argument("--json", default="bench/results/state_writes.json")
    args = ap.parse_args()
    results = {}
    print(f"{'profile':14} {'LEO pass writes/h':>18} {'slow target writes/h':>21}")
    for profile in args.profiles.split(","):
        r = {"leo_pass": writes_per_hour(profile, leo, PASS_S),
             "slow_target": writes_per_hour(profile, moon, PASS_S)}
        results[profile] = r
        print(f"{profile:14} {r['leo_pass']['per_hour']:18.0f} {r['slow_target']['per_hour']:21.0f}", flush=True)
    write_json(results, args.json)


if __name__ == "__main__":
    main()
