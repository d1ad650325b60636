"""Pointing on the emulated gpio backend against the sim backend: the highest ISS pass
of a day over Tartu (the pass tests/hardware/test_gpio_passes.py flies) on every
shipped example, through the real drivers on emulated pins and chips (mux, MCP3008,
current sense and all) and on the simulator's own parts; RMS and max error.

Usage: python bench/gpio_pass_bench.py [--examples berkeley,g4jnt] [--json PATH]
"""

from __future__ import annotations

import argparse
import logging
import tempfile
from pathlib import Path

from bench_report import write_json

import urc.registrations  # noqa: F401  (the configuration's owners' checks, before load_config)
from urc.config import load_config
from urc.tracking.elements import load_elements
from urc.testing.evaluate import fly_pass_on_sim
from urc.tracking.passes import find_passes
from urc.tracking.station import Station

ROOT = Path(__file__).resolve().parents[1]
TARTU = Station(58.3780, 26.7290, 70.0, "Tartu")
T0_UNIX_S = 1704110400.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--examples", default="", help="comma-separated example names (default: all)")
    ap.add_argument("--json", default="bench/results/gpio_pass.json")
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    es = next(s for s in load_elements(ROOT / "tests" / "tracking" / "fixtures" / "leo.tle") if s.norad_id == 25544)
    p = max(find_passes(es, TARTU, T0_UNIX_S, duration_s=86400, min_el_deg=10), key=lambda p: p.max_el_deg)
    wanted = {n for n in args.examples.split(",") if n}
    rows = []
    print(f"ISS pass max el {p.max_el_deg:.1f} deg over Tartu")
    print(f"{'example':14s} {'sim RMS':>8s} {'gpio RMS':>9s} {'ratio':>6s} {'sim max':>8s} {'gpio max':>9s}  (deg)")
    for path in sorted((ROOT / "examples").glob("*.toml")):
        if wanted and path.stem not in wanted:
            continue
        cfg = load_config(path)
        doc = cfg.to_dict()
        gpio = doc["hardware"]["gpio"]
        gpio["emulate"] = True
        profile = cfg.rotator.profile
        own = {"rotator": doc["rotator"], "limits": doc["limits"]}   # the example's rotator and range
        with tempfile.TemporaryDirectory() as d:
            sim = fly_pass_on_sim(profile, es, TARTU, p, Path(d) / "sim", config=own)[2]
            emu = fly_pass_on_sim(profile, es, TARTU, p, Path(d) / "gpio", config={
                **own, "hardware": {"backend": "gpio", "gpio": gpio, "sim": {"wind": False}}})[2]
        rows.append({"example": path.stem, "sim_rms_deg": sim.rms_deg, "gpio_rms_deg": emu.rms_deg,
                     "ratio": emu.rms_deg / sim.rms_deg if sim.rms_deg else None,
                     "sim_max_deg": sim.max_deg, "gpio_max_deg": emu.max_deg})
        r = rows[-1]
        r["azimuth_only"] = not cfg.caps.has_el
        print(f"{r['example']:14s} {r['sim_rms_deg']:8.3f} {r['gpio_rms_deg']:9.3f} {r['ratio']:6.2f} "
              f"{r['sim_max_deg']:8.3f} {r['gpio_max_deg']:9.3f}"
              + ("  azimuth only: the error counts the elevation it cannot point (bench/single_axis_bench.py)"
                 if r["azimuth_only"] else ""))
    write_json({"pass_max_el_deg": p.max_el_deg, "examples": rows}, args.json)


if __name__ == "__main__":
    main()
