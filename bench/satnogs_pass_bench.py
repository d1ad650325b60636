"""Passes flown on ``satnogs-v3`` against skyfield (issue 37): on the simulator and on the
gpio backend emulated (examples/satnogs-v3.toml: lgpio's step queue, the A4988 and the
stepper pull-out model behind the pins), the antenna's true pointing compared with where
skyfield puts the satellite (EarthSatellite minus the station's wgs84 position, altaz,
no refraction: an ephemeris path independent of urc's own look angles), in degrees and in
step quanta (degrees per microstep after the worm: 1 / steps_per_deg).

Passes over Tartu from the fixture TLEs: the ISS's highest and lowest of a day and a
NOAA-19 pass crossing north (the azimuth wrap). The ``urc`` columns are the same flights
judged by urc's own look angles; ``ref`` is how far urc's and skyfield's target differ
(the reference's share of the error).

Usage: python bench/satnogs_pass_bench.py [--json PATH]
"""

from __future__ import annotations

import argparse
import logging
import math
import tempfile
import time
from pathlib import Path

import numpy as np
from skyfield.api import EarthSatellite, load, wgs84

from bench_report import write_json

from urc.config import load_config
from urc.testing.evaluate import fly_pass_on_sim
from urc.tracking.elements import load_elements
from urc.tracking.passes import find_passes
from urc.tracking.propagate import look_angles
from urc.tracking.station import Station

ROOT = Path(__file__).resolve().parents[1]
TARTU = Station(58.3780, 26.7290, 70.0, "Tartu")
T0_UNIX_S = 1704110400.0      # 2024-01-01 12:00 UTC, hours after the fixture epochs
DAY_S = 86400.0


def skyfield_look(es, station: Station, t_unix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(az, el) in degrees from skyfield alone (its builtin time tables)."""
    ts = load.timescale(builtin=True)
    days = np.floor(t_unix / DAY_S)
    t = ts.utc(1970, 1, 1 + days, 0, 0, t_unix - days * DAY_S)   # the day's own leap seconds
    sat = EarthSatellite.from_satrec(es.satrec, ts)
    here = wgs84.latlon(station.lat_deg, station.lon_deg, elevation_m=station.alt_m)
    alt, az, _ = (sat - here).at(t).altaz()
    return az.degrees, alt.degrees


def great_circle_deg(az1, el1, az2, el2) -> np.ndarray:
    a1, e1, a2, e2 = (np.radians(np.asarray(x, dtype=float)) for x in (az1, el1, az2, el2))
    c = np.sin(e1) * np.sin(e2) + np.cos(e1) * np.cos(e2) * np.cos(a1 - a2)
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def crosses_north(es, p) -> bool:
    la = look_angles(es, TARTU, np.arange(p.aos_unix_s, p.los_unix_s, 5.0))
    return bool(np.any(np.abs(np.diff(la.az_deg)) > 180.0))


def passes():
    sets = {s.norad_id: s for s in load_elements(ROOT / "tests" / "tracking" / "fixtures" / "leo.tle")}
    iss, noaa = sets[25544], sets[33591]
    ps = find_passes(iss, TARTU, T0_UNIX_S, duration_s=DAY_S, min_el_deg=10)
    north = next(p for p in find_passes(noaa, TARTU, T0_UNIX_S, duration_s=DAY_S, min_el_deg=10)
                 if crosses_north(noaa, p))
    return [("ISS high", iss, max(ps, key=lambda p: p.max_el_deg)),
            ("ISS low", iss, min(ps, key=lambda p: p.max_el_deg)),
            ("NOAA-19 north", noaa, north)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", default="bench/results/satnogs_pass.json")
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    cfg = load_config(ROOT / "examples" / "satnogs-v3.toml")
    doc = cfg.to_dict()
    gpio = {**doc["hardware"]["gpio"], "emulate": True}
    own = {"rotator": doc["rotator"], "limits": doc["limits"]}
    quantum = {ax: getattr(cfg.caps, ax).sensor.resolution_deg for ax in ("az", "el")}
    q_deg = max(quantum.values())     # one microstep after the worm, the coarser axis
    backends = {"sim": own, "emulate": {**own, "hardware": {"backend": "gpio", "gpio": gpio,
                                                            "sim": {"wind": False}}}}
    rows = []
    print(f"satnogs-v3, step quantum {q_deg:.5f} deg (az {1 / quantum['az']:.0f}, el {1 / quantum['el']:.0f} "
          "microsteps/deg)")
    print(f"{'pass':14s} {'max el':>6s} {'backend':8s} {'RMS':>7s} {'max':>7s} {'RMS/q':>6s} {'max/q':>6s} "
          f"{'urc RMS':>8s} {'ref max':>8s} {'wall s':>6s}  (deg vs skyfield)")
    for name, es, p in passes():
        for backend, config in backends.items():
            t0 = time.perf_counter()
            with tempfile.TemporaryDirectory() as d:
                flown = fly_pass_on_sim("satnogs-v3", es, TARTU, p, Path(d), config=config)
            wall_s = time.perf_counter() - t0
            t, az, el = flown.flight
            up = (t >= p.aos_unix_s) & (t <= p.los_unix_s)
            sf_az, sf_el = skyfield_look(es, TARTU, t[up])
            err = great_circle_deg(az[up], el[up], sf_az, sf_el)
            urc_la = look_angles(es, TARTU, t[up])
            ref = great_circle_deg(urc_la.az_deg, urc_la.el_deg, sf_az, sf_el)
            rms, mx = float(math.sqrt(np.mean(err ** 2))), float(err.max())
            row = {"pass": name, "max_el_deg": round(p.max_el_deg, 2), "backend": backend,
                   "rms_deg": rms, "max_deg": mx, "rms_quanta": rms / q_deg, "max_quanta": mx / q_deg,
                   "urc_rms_deg": flown.stats.rms_deg, "urc_max_deg": flown.stats.max_deg,
                   "reference_max_deg": float(ref.max()), "flipped": flown.flipped,
                   "samples": int(up.sum()), "wall_s": round(wall_s, 1)}
            rows.append(row)
            print(f"{name:14s} {p.max_el_deg:6.1f} {backend:8s} {rms:7.4f} {mx:7.4f} {rms / q_deg:6.1f} "
                  f"{mx / q_deg:6.1f} {flown.stats.rms_deg:8.4f} {ref.max():8.1e} {wall_s:6.1f}"
                  + ("  flipped" if flown.flipped else ""))
    write_json({"profile": "satnogs-v3", "step_quantum_deg": q_deg, "quantum_deg": quantum, "rows": rows},
               args.json)


if __name__ == "__main__":
    main()
