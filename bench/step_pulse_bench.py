"""Step-pulse timing of the chosen method (lgpio's ``tx_pulse``), measured on this machine
(issue 37): how late lg's pulse thread puts out each STEP edge, and the step rate past
which the pulses fall behind.

There is no GPIO here, so the measure is lg's timing loop itself (``bench/step_probe.c``:
lgPthTx.c's one ``clock_nanosleep`` to an absolute deadline per edge), without the
gpiochip ioctl that writes the line (a few microseconds more per edge on a Pi), at normal
priority and at SCHED_FIFO 5 (what lg's thread inherits in urc's control process, which
opens the chip). Absolute deadlines mean a late edge is late, never dropped: the count
stays exact. What lateness costs: after a late wake-up lg puts the overdue edges out back
to back ("shortest": their spacing), a burst of steps the rotor may not follow (lost
steps on iron, which only an absolute sensor sees); and an edge pair squeezed under the
chip's minimum high or low time (counted: under 2 us, the DRV8825's 1.9 us) is a pulse
the chip may miss.

Per step rate (both edges of each step): lateness p50 / p99 / max in microseconds, the
shortest high or low time that came out, the edges under 2 us, and "keeps up": p99
lateness under a quarter of the step period. The SatNOGS rate is 3200 steps/s (1/8
microstep); 6400 is 1/16 at the same axis speed; 51 200 is what x16 microstepping of the
firmware's 3200 full-step-equivalent figure would ask. The numbers are this machine's
(a shared, loaded VM when written), not a Pi's: run it on the Pi to know the Pi.

Prints a table, writes JSON (default bench/results/step_pulse.json). Never gates CI.
Usage: python bench/step_pulse_bench.py [--seconds 3] [--rates 800,3200,...] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
from bench_report import write_json  # noqa: E402

RATES = (800, 1600, 3200, 6400, 12800, 25600, 51200)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--rates", default=",".join(str(r) for r in RATES))
    ap.add_argument("--priorities", default="0,5", help="0 = normal, else SCHED_FIFO priority")
    ap.add_argument("--json", default=str(ROOT / "bench" / "results" / "step_pulse.json"))
    args = ap.parse_args()
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        print("no C compiler: nothing measured")
        return 1
    rows = []
    with tempfile.TemporaryDirectory() as work:
        exe = Path(work) / "step_probe"
        subprocess.run([cc, "-O2", "-o", str(exe), str(ROOT / "bench" / "step_probe.c")], check=True)
        for prio in (int(p) for p in args.priorities.split(",")):
            for hz in (float(r) for r in args.rates.split(",")):
                out = subprocess.run([str(exe), f"{hz:g}", f"{args.seconds:g}", str(prio)], capture_output=True,
                                     text=True, check=True, timeout=args.seconds * 20 + 30)
                r = json.loads(out.stdout)
                r["step_hz"], r["priority"] = hz, prio
                r["keeps_up"] = r["late_p99_us"] < 0.25e6 / hz
                rows.append(r)
    print(f"{'sched':>8} {'steps/s':>8} {'p50 us':>10} {'p99 us':>11} {'max us':>11} {'shortest us':>12} "
          f"{'<2us':>5}  keeps up")
    for r in rows:
        sched = f"FIFO {r['priority']}" if r["rt"] else "normal"
        print(f"{sched:>8} {r['step_hz']:8.0f} {r['late_p50_us']:10.1f} {r['late_p99_us']:11.1f} "
              f"{r['late_max_us']:11.1f} {r['shortest_us']:12.1f} {r['under_2us']:5d}  "
              f"{'yes' if r['keeps_up'] else 'NO'}")
    for prio in sorted({r["priority"] for r in rows}):
        ok = [r["step_hz"] for r in rows if r["priority"] == prio and r["keeps_up"]]
        print(f"priority {prio}: ceiling (p99 lateness under a quarter period): "
              + (f"{max(ok):.0f} steps/s" if ok else "none of the rates tried"))
    write_json({"method": "lgpio tx_pulse timing loop (bench/step_probe.c)", "seconds": args.seconds,
                "rates": rows}, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
