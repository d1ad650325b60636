"""Control benchmark for every simulated profile.

Measures, against the simulator's truth (never the sensor's word):
* step response of each axis for 10, 90 and 180 degree moves: time to settle within one
  sensor count and stay there, overshoot, final error;
* ramp following at 1 and 5 deg/s (capped at the axis' top speed): RMS and max error
  after acquisition;
* virtual-time speed-up (simulated seconds per CPU second);
* CPU share of one core of a real ``urc run`` process, idle and while moving.

Prints a table, writes JSON (default bench/results/control.json). Never gates CI.
Usage: python bench/control_bench.py [--profiles a,b] [--no-cpu] [--json PATH]
"""

from __future__ import annotations

import argparse
import math
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_report import write_json
from urc.assembly import build_rotator
from urc.clock import VirtualClock
from urc.config import Config
from urc.profiles import PROFILES
from urc.rotator.loop import run_virtual

STEPS_DEG = (10.0, 90.0, 180.0)
RAMPS_DEG_PER_S = (1.0, 5.0)


def make(profile: str, tmp: Path):
    cfg = Config.from_dict({"rotator": {"profile": profile}, "hardware": {"sim": {"wind": False}}})
    clock = VirtualClock(0.0)
    rot = build_rotator(cfg, clock, tmp, fast_virtual=True)
    return rot, clock


def settle(rot, clock, limit_s=400.0):
    return run_virtual(rot, clock, limit_s, until=lambda s: not s.moving and s.az.mode != "driving"
                       and s.el.mode != "driving")


def step_response(profile: str, axis: str, size_deg: float) -> dict | None:
    with tempfile.TemporaryDirectory() as tmp:
        rot, clock = make(profile, Path(tmp))
        caps = rot.caps.axis(axis)
        lo, hi = rot.settings.limits(axis)
        if hi - lo < size_deg + 2:
            return None
        start = lo + 1.0
        other = "el" if axis == "az" else "az"
        other_pos = 10.0 if other == "el" else 100.0
        pose = {axis: start, other: other_pos}
        rot.goto(pose["az"], pose["el"])
        settle(rot, clock)
        target = start + size_deg
        pose[axis] = target
        t0 = clock.now_s()
        q = caps.sensor.resolution_deg
        samples = []
        rot.goto(pose["az"], pose["el"]) if axis == "el" or target < 360 else rot.goto(target, pose["el"])
        run_virtual(rot, clock, size_deg / caps.max_rate_deg_per_s + 30.0,
                    on_tick=lambda s: samples.append((s.t_s - t0, s.sim_truth[axis]["deg"])))
        # the sky azimuth given may have been flown on another wrap: compare in the frame flown
        flown = rot.axes[axis].sp.target_deg if rot.axes[axis].sp else target
        err = [(t, p - flown) for t, p in samples]
        outside = [t for t, e in err if abs(e) > q]
        settle_s = (outside[-1] if outside else 0.0) if err and abs(err[-1][1]) <= q else math.nan
        direction = 1.0 if flown >= start else -1.0
        overshoot = max(0.0, max(e * direction for _, e in err))
        return {"axis": axis, "step_deg": size_deg, "settle_s": settle_s, "overshoot_deg": overshoot,
                "final_error_deg": abs(err[-1][1]), "count_deg": q}


def ramp(profile: str, rate_deg_per_s: float) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        rot, clock = make(profile, Path(tmp))
        caps = rot.caps.az
        rate = min(rate_deg_per_s, caps.max_rate_deg_per_s * 0.9)
        start = rot.settings.limits("az")[0] + 5.0
        rot.goto(start, 20.0)
        settle(rot, clock)
        t0 = clock.now_s()
        rot.track(start, 20.0, rate, 0.0, t0)
        duration = min(40.0, (rot.settings.limits("az")[1] - start - 10.0) / rate)
        errs = []

        def sample(s):
            t = s.t_s - t0
            if t > 5.0:  # after acquisition
                errs.append(s.sim_truth["az"]["deg"] - (start + rate * t))
        cpu0 = time.process_time()
        run_virtual(rot, clock, duration, on_tick=sample)
        cpu = time.process_time() - cpu0
        rms = math.sqrt(sum(e * e for e in errs) / len(errs)) if errs else math.nan
        return {"rate_deg_per_s": rate, "rms_deg": rms, "max_deg": max(map(abs, errs), default=math.nan),
                "floor_deg": caps.sensor.resolution_deg / math.sqrt(12), "speedup": duration / cpu if cpu else math.nan}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def cpu_ticks(pid: int) -> int:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])  # utime + stime


def cpu_share(profile: str, window_s: float = 5.0) -> dict:
    import httpx

    port = free_port()
    with tempfile.TemporaryDirectory() as tmp:
        cfg = Path(tmp) / "urc.toml"
        cfg.write_text(f'serve = []\n[rotator]\nprofile = "{profile}"\n[api]\nport = {port}\n')
        proc = subprocess.Popen([sys.executable, "-m", "urc", "run", "--config", str(cfg), "--state-dir", tmp],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            url = f"http://127.0.0.1:{port}/api"
            for _ in range(100):
                try:
                    httpx.get(url + "/status", timeout=0.5)
                    break
                except httpx.HTTPError:
                    time.sleep(0.1)
            time.sleep(1.0)
            hz = os.sysconf("SC_CLK_TCK")

            def share() -> float:
                c0, t0 = cpu_ticks(proc.pid), time.monotonic()
                time.sleep(window_s)
                return (cpu_ticks(proc.pid) - c0) / hz / (time.monotonic() - t0)
            idle = share()
            httpx.post(url + "/goto", json={"az_deg": 300.0, "el_deg": 60.0}, timeout=2)
            time.sleep(0.5)
            moving = share()
            return {"idle_cpu_pct": 100 * idle, "moving_cpu_pct": 100 * moving}
        finally:
            proc.terminate()
            proc.wait(timeout=10)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--profiles", default=",".join(PROFILES))
    ap.add_argument("--no-cpu", action="store_true", help="skip the real-process CPU measurement")
    ap.add_argument("--json", default="bench/results/control.json")
    args = ap.parse_args()
    results = {}
    for profile in args.profiles.split(","):
        r = {"steps": [], "ramps": []}
        for axis in ("az", "el"):
            for size in STEPS_DEG:
                sr = step_response(profile, axis, size)
                if sr:
                    r["steps"].append(sr)
        r["ramps"] = [ramp(profile, v) for v in RAMPS_DEG_PER_S]
        if not args.no_cpu:
            r["cpu"] = cpu_share(profile)
        results[profile] = r
        print(f"{profile}: done", file=sys.stderr, flush=True)

    print("\nStep response (simulator truth; settle = within one sensor count and staying)")
    print(f"{'profile':13s} {'axis':4s} {'step':>6s} {'settle s':>9s} {'overshoot':>10s} {'final err':>10s} {'count':>7s}")
    for p, r in results.items():
        for s in r["steps"]:
            settle_txt = "never" if math.isnan(s["settle_s"]) else f"{s['settle_s']:.2f}"
            print(f"{p:13s} {s['axis']:4s} {s['step_deg']:6.0f} {settle_txt:>9s} {s['overshoot_deg']:10.3f} "
                  f"{s['final_error_deg']:10.3f} {s['count_deg']:7.3f}")
    print("\nRamp following, azimuth (RMS/max error after 5 s acquisition; floor = q/sqrt(12))")
    print(f"{'profile':13s} {'rate':>6s} {'RMS deg':>8s} {'max deg':>8s} {'floor':>7s} {'virtual x':>10s}")
    for p, r in results.items():
        for m in r["ramps"]:
            print(f"{p:13s} {m['rate_deg_per_s']:6.2f} {m['rms_deg']:8.3f} {m['max_deg']:8.3f} "
                  f"{m['floor_deg']:7.3f} {m['speedup']:10.0f}")
    if not args.no_cpu:
        print("\nCPU share of one core, real `urc run` process (/proc utime+stime)")
        print(f"{'profile':13s} {'idle %':>7s} {'moving %':>9s}")
        for p, r in results.items():
            print(f"{p:13s} {r['cpu']['idle_cpu_pct']:7.1f} {r['cpu']['moving_cpu_pct']:9.1f}")
    write_json(results, args.json)


if __name__ == "__main__":
    main()
