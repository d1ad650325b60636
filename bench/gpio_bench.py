"""gpio backend benchmark: CPU per control tick on the emulated gpio backend (the real
drivers on MockFactory pins and a fake SMBus, plus the simulator behind them) against
the sim backend, and the quadrature / pulse counting headroom.

Counting: the x4 decoder's cost per edge (gpiozero pin callback + decode) measured on
mock pins here, as the edge rate this machine can count, against the fastest counting
seed machine's edge rate at full speed (encoder counts/deg x max rate). On a Pi the
edges arrive through lgpio's alert thread, which adds its own cost per edge; the
numbers here are this machine's, not a Pi's.
Usage: python bench/gpio_bench.py [--seconds 60] [--json PATH]
"""

from __future__ import annotations

import argparse
import logging
import tempfile
import time
from pathlib import Path

from bench_report import write_json
from gpiozero.pins.mock import MockFactory, MockPWMPin

from urc.assembly import build_rotator
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.hardware.gpio.pins import PinPulseCounter, PinQuadrature
from urc.profiles import PROFILES
from urc.rotator.loop import run_virtual

ROOT = Path(__file__).resolve().parents[1]


def cpu_per_tick(cfg: Config, seconds: float) -> tuple[float, int]:
    with tempfile.TemporaryDirectory() as d:
        clock = VirtualClock(1000.0)
        rot = build_rotator(cfg, clock, Path(d), fast_virtual=True)
        lo, hi = rot.status().limits["az"]
        n = 0

        def count(_s) -> None:
            nonlocal n
            n += 1
        t0 = time.process_time()
        # back and forth across the range: motors, counters and buses all busy
        for i in range(int(seconds // 20)):
            rot.goto(lo + 10 if i % 2 else min(hi - 10, lo + 180), 20.0)
            run_virtual(rot, clock, 20.0, on_tick=count)
        cpu = time.process_time() - t0
        rot.hw.close()
        return cpu / max(n, 1), n


def edge_cost_s(edges: int = 200_000) -> float:
    f = MockFactory(pin_class=MockPWMPin)
    q = PinQuadrature(f, 17, 27)
    seq = [(q.a.drive_low, None), (q.b.drive_low, None), (q.a.drive_high, None), (q.b.drive_high, None)]
    t0 = time.perf_counter()
    for i in range(edges):
        seq[i % 4][0]()
        if i % 4096 == 0:
            q.a.clear_states()
            q.b.clear_states()
    dt = time.perf_counter() - t0
    assert abs(q.count()) == edges and q.errors() == 0, (q.count(), q.errors())
    f.close()
    return dt / edges


def pulse_cost_s(pulses: int = 100_000) -> float:
    f = MockFactory(pin_class=MockPWMPin)
    c = PinPulseCounter(f, 17)
    t0 = time.perf_counter()
    for i in range(pulses):
        c.pin.drive_low()
        c.pin.drive_high()
        if i % 4096 == 0:
            c.pin.clear_states()
    dt = time.perf_counter() - t0
    assert c.count() == pulses
    f.close()
    return dt / pulses


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--json", default="bench/results/gpio.json")
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    rows = []
    for path in sorted((ROOT / "examples").glob("*.toml")):
        data = load_config(path).to_dict()
        data["hardware"]["gpio"]["emulate"] = True
        data["hardware"]["sim"] = {"wind": False}
        gpio_cfg = Config.from_dict(data)
        sim_cfg = Config.from_dict({"rotator": data["rotator"], "hardware": {"sim": {"wind": False}}})
        g, n = cpu_per_tick(gpio_cfg, args.seconds)
        s, _ = cpu_per_tick(sim_cfg, args.seconds)
        rows.append({"example": path.stem, "ticks": n, "gpio_cpu_us_per_tick": g * 1e6,
                     "sim_cpu_us_per_tick": s * 1e6,
                     "gpio_cpu_share_at_loop_hz": g * PROFILES[data["rotator"]["profile"]].loop_hz})
    edge_s, pulse_s = edge_cost_s(), pulse_cost_s()
    need = {}
    for name, caps in PROFILES.items():
        for ax in (caps.az, caps.el):
            if ax.sensor.kind in ("encoder", "pulse"):
                need[f"{name} {ax.name} ({ax.sensor.kind})"] = (ax.max_rate_deg_per_s / ax.sensor.resolution_deg,
                                                                ax.sensor.kind)
    print(f"{'example':14s} {'ticks':>6s} {'gpio us/tick':>13s} {'sim us/tick':>12s} {'gpio CPU share':>15s}")
    for r in rows:
        print(f"{r['example']:14s} {r['ticks']:6d} {r['gpio_cpu_us_per_tick']:13.0f} "
              f"{r['sim_cpu_us_per_tick']:12.0f} {100 * r['gpio_cpu_share_at_loop_hz']:14.1f}%")
    print(f"\nx4 decoder: {edge_s * 1e6:.2f} us per edge = {1 / edge_s:,.0f} edges/s; "
          f"pulse counter: {pulse_s * 1e6:.2f} us per pulse = {1 / pulse_s:,.0f} pulses/s (one core)")
    counting = []
    for axis, (rate, kind) in sorted(need.items(), key=lambda kv: -kv[1][0]):
        cap = 1 / (edge_s if kind == "encoder" else pulse_s)
        counting.append({"axis": axis, "edges_per_s_at_max_rate": rate, "capacity_per_s": cap,
                         "headroom": cap / rate})
        print(f"  {axis:32s} needs {rate:7.1f}/s at full speed: headroom {cap / rate:,.0f}x")
    write_json({"ticks": rows, "edge_cost_us": edge_s * 1e6, "pulse_cost_us": pulse_s * 1e6,
                "counting": counting}, args.json)


if __name__ == "__main__":
    main()
