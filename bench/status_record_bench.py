"""The shared-memory status record (urc.link.status_record) against the pickled Status it
can replace on most ticks: CPU microseconds per status of each step, on real statuses of
the simulator (tartu-urc, moving, on the virtual clock).

Control side, every tick: ``ColdGeneration.update`` (cold_key and its comparison with the
last tick's) and ``StatusRecord.write`` (pack, CRC, seqlock), against ``codec.dumps`` of
the ("status", Status) message. I/O side, per read: ``StatusRecord.read`` (copy, CRC,
unpack) and ``merge`` into the last full Status, against ``codec.loads``. Also
``liveness()``, and ``merge`` done with dataclasses.replace instead of evolve. Status kinds:
"hardware" (the simulator's truth dict left out: what a real rotator's Status holds),
"sim" (with it: on the simulator every tick changes a cold field), "az-only" and "faulted"
(two faults, a dead sensor, events). Also the share of ticks on which the cold
generation changed (the ticks whose full Status must still be pickled).

Each figure is the best (min) and the median of ``--repeat`` timings of ``--loops`` calls,
in this thread's CPU time (CLOCK_THREAD_CPUTIME_ID: time other processes take is not
counted, though what they do to the caches is). Prints a table and
writes JSON (default bench/results/status_record.json).
Usage: python bench/status_record_bench.py [--loops 5000] [--repeat 25] [--json PATH]
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import logging
import os
import statistics
import tempfile
import time
from pathlib import Path

from bench_report import write_json

from urc.assembly import build_rotator
from urc.clock import VirtualClock
from urc.config import Config
from urc.link import codec
from urc.link.status_record import AXIS_HOT, SIZE, ColdGeneration, StatusRecord, merge
from urc.rotator.loop import run_virtual
from urc.model.snapshot import Status


def run_statuses(tmp: Path, truth: bool, faulted: bool = False, **config) -> list[Status]:
    """Consecutive statuses of a simulated tartu-urc driving (the last 500 ticks)."""
    config.setdefault("rotator", {})["profile"] = "tartu-urc"
    config["hardware"] = {"sim": {"wind": False}}
    if faulted:
        config["faults"] = {"overcurrent_a": 100.0}
    clock = VirtualClock(1000.0)
    rot = build_rotator(Config.from_dict(config), clock, tmp, durable_state=False, fast_virtual=True)
    if not truth:
        rot.hw.truth_hook = None
    out: list[Status] = []
    rot.goto(200.0, 40.0)
    run_virtual(rot, clock, 3.0)
    if faulted:
        rot.hw.world.inject("az", "jam")
        run_virtual(rot, clock, 5.0)
        rot.hw.world.inject("el", "sensor_dead")
        run_virtual(rot, clock, 1.0)
        assert len(rot.status().faults) >= 2, rot.status().faults
    run_virtual(rot, clock, 500 / rot.caps.loop_hz, on_tick=out.append)
    rot.hw.close()
    return out


def timed(steps: dict, loops: int, repeat: int) -> dict[str, tuple[float, float]]:
    """Each step's (best, median) microseconds per call of ``fn(i)``; the steps take turns
    within each repeat, so a busy moment of the machine falls on all of them alike."""
    runs: dict[str, list[float]] = {name: [] for name in steps}
    for _ in range(repeat):
        for name, fn in steps.items():
            t0 = time.thread_time_ns()
            for i in range(loops):
                fn(i)
            runs[name].append((time.thread_time_ns() - t0) / loops / 1000.0)
    return {name: (min(r), statistics.median(r)) for name, r in runs.items()}


def replace_merge(cold: Status, hot) -> Status:
    """merge() written with dataclasses.replace (what it is measured against)."""
    el = None if hot.el is None else dataclasses.replace(cold.el, **dict(zip(AXIS_HOT, hot.el)))
    return dataclasses.replace(
        cold, t_s=hot.t_s, az_deg=hot.az_deg, el_deg=hot.el_deg, az=dataclasses.replace(cold.az, **dict(zip(
            AXIS_HOT, hot.az))), el=el, target_az_deg=hot.target_az_deg, target_el_deg=hot.target_el_deg,
        flipped=hot.flipped, wrap_turns=hot.wrap_turns, moving=hot.moving, parked=hot.parked,
        position_known=hot.position_known, tick_late_p99_ms=hot.tick_late_p99_ms)


def measure(kind: str, statuses: list[Status], loops: int, repeat: int) -> dict:
    rec = StatusRecord.create()
    reader = StatusRecord.attach(os.dup(rec.fd))  # (a mapping of its own, as the other process has)
    n = len(statuses)
    cold = ColdGeneration()
    gens = [cold.update(s) for s in statuses]
    s0 = statuses[-1]
    rec.write(s0, 1, 1)
    hot = reader.read()
    assert merge(s0, hot) == s0
    msg = codec.dumps(("status", s0))
    row = {"kind": kind, "pickle_bytes": len(msg), "record_bytes": SIZE,
           "cold_changes_per_100_ticks": 100.0 * (len(set(gens)) - 1) / (n - 1)}

    def write(i: int) -> None:
        rec.write(statuses[i % n], i, 1)

    gen = ColdGeneration()

    def update(i: int) -> None:  # (consecutive ticks: the comparisons a running tick makes)
        gen.update(statuses[i % n])
    steps = {
        "write": write, "cold_update": update,
        "read": lambda _i: reader.read(), "liveness": lambda _i: reader.liveness(),
        "merge": lambda _i: merge(s0, hot), "merge_replace": lambda _i: replace_merge(s0, hot),
        "pickle_dumps": lambda _i: codec.dumps(("status", s0)), "pickle_loads": lambda _i: codec.loads(msg),
    }
    for name, (best, median) in timed(steps, loops, repeat).items():
        row[f"{name}_us"], row[f"{name}_median_us"] = best, median
    assert reader.busy_retries == reader.torn_retries == reader.crc_rejects == 0
    rec.close()
    reader.close()
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--loops", type=int, default=5000)
    ap.add_argument("--repeat", type=int, default=25)
    ap.add_argument("--json", default="bench/results/status_record.json")
    args = ap.parse_args()
    logging.disable(logging.CRITICAL)
    counter = itertools.count()
    with tempfile.TemporaryDirectory() as d:
        def tmp() -> Path:
            return Path(d) / f"state{next(counter)}"
        kinds = {"hardware": run_statuses(tmp(), truth=False), "sim": run_statuses(tmp(), truth=True),
                 "az-only": run_statuses(tmp(), truth=False, rotator={"elevation": False}),
                 "faulted": run_statuses(tmp(), truth=False, faulted=True)}
    rows = [measure(kind, ss, args.loops, args.repeat) for kind, ss in kinds.items()]
    cols = ["write", "cold_update", "pickle_dumps", "read", "liveness", "merge", "merge_replace", "pickle_loads"]
    print(f"microseconds per status, best (median) of {args.repeat} x {args.loops} calls\n")
    print(f"{'status':9s} {'pickle B':>8s} {'cold %':>6s} " + " ".join(f"{c:>14s}" for c in cols))
    for r in rows:
        print(f"{r['kind']:9s} {r['pickle_bytes']:8d} {r['cold_changes_per_100_ticks']:6.1f} " + " ".join(
            f"{r[c + '_us']:6.2f} ({r[c + '_median_us']:5.2f})" for c in cols))
    print("\ncontrol side per tick: write + cold_update (record) against pickle_dumps;"
          "\nI/O side per read: read + merge (record) against pickle_loads;"
          "\ncold %: ticks whose cold generation changed (their full Status is still pickled)")
    write_json({"loops": args.loops, "repeat": args.repeat, "rows": rows}, args.json)


if __name__ == "__main__":
    main()
