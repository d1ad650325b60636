"""Synthetic satellites for tests and benches: element sets of today's epoch (stored
fixtures age into decay), and one whose next pass over a station starts when a real-time
test or bench needs it."""

from __future__ import annotations

import math
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

#: [station] of the Tartu controller (the seed machine), as config text
STATION_TOML = "[station]\nlat_deg = 58.378\nlon_deg = 26.729\nalt_m = 70.0\n"


def synthetic_tle(name: str, norad: int, epoch: datetime, *, inc_deg: float, raan_deg: float,
                  argp_deg: float, ma_deg: float, rev_per_day: float, ecc: float = 0.001) -> str:
    """A three-line element set of ``epoch`` (fixture element sets age into decay)."""
    from sgp4.api import WGS72, Satrec
    from sgp4.exporter import export_tle

    xpdotp = 1440.0 / (2.0 * math.pi)
    days = (epoch - datetime(1949, 12, 31, tzinfo=timezone.utc)).total_seconds() / 86400.0
    sat = Satrec()
    sat.sgp4init(WGS72, "i", norad, days, 1.0e-4, 0.0, 0.0, ecc, math.radians(argp_deg), math.radians(inc_deg),
                 math.radians(ma_deg), rev_per_day / xpdotp, math.radians(raan_deg))
    sat.intldesg, sat.classification, sat.elnum, sat.revnum, sat.ephtype = "98067A", "U", 999, 1, 0
    l1, l2 = export_tle(sat)
    return f"{name}\n{l1}\n{l2}\n"


def satellite_passing_soon(work: Path, station, lead_s: tuple[float, float], min_max_el_deg: float = 20.0,
                           norad: int = 99001, name: str = "SYNTH-SAT",
                           accept: Callable[[object], bool] = lambda p: True):
    """(TLE text, elements, pass) of a synthetic LEO whose next pass over ``station``
    starts ``lead_s`` (min, max) seconds from now, rises above ``min_max_el_deg`` and
    satisfies ``accept(pass)`` (one vectorised search over a dense grid of orbits: a
    coarse grid found none in some windows)."""
    now_s = time.time()
    return satellite_passing_between(work, station, (now_s + lead_s[0], now_s + lead_s[1]), min_max_el_deg,
                                     norad, name, accept)


def satellite_passing_between(work: Path, station, aos_window_unix_s: tuple[float, float],
                              min_max_el_deg: float = 20.0, norad: int = 99001, name: str = "SYNTH-SAT",
                              accept: Callable[[object], bool] = lambda p: True, min_el_deg: float = 0.0):
    """(TLE text, elements, pass) of a synthetic LEO with a pass over ``station`` (above
    ``min_el_deg``, as ``[tracking] min_el_deg`` counts it) whose AOS lies in the absolute
    window ``aos_window_unix_s`` (UTC seconds), rising above ``min_max_el_deg`` and
    satisfying ``accept(pass)``."""
    return satellites_passing_between(work, station, [aos_window_unix_s], min_max_el_deg, [norad], [name],
                                      accept, min_el_deg)[0]


def satellites_passing_between(work: Path, station, aos_windows_unix_s: list[tuple[float, float]],
                               min_max_el_deg: float, norads: list[int], names: list[str],
                               accept: Callable[[object], bool] = lambda p: True, min_el_deg: float = 0.0):
    """:func:`satellite_passing_between` for several windows at once (a soak's timetable):
    one (TLE text, elements, pass) per window, each of another orbit. All candidate
    orbits (inclination 70 deg, a grid of RAAN and mean anomaly) go through one
    vectorised pass search: a search per candidate would take minutes."""
    from ..tracking.elements import load_elements
    from ..tracking.passes import find_passes

    now = datetime.now(timezone.utc)
    grid = [(raan, ma) for raan in range(0, 360, 5) for ma in range(0, 360, 1)]
    path = work / "pick.tle"

    def orbit(i: int, sat_name: str, sat_norad: int) -> str:
        raan, ma = grid[i]
        return synthetic_tle(sat_name, sat_norad, now, inc_deg=70.0, raan_deg=raan, argp_deg=90.0, ma_deg=ma,
                             rev_per_day=15.2)
    path.write_text("".join(orbit(i, f"CAND {i}", i + 1) for i in range(len(grid))))
    t0 = time.time()
    end_s = max(w[1] for w in aos_windows_unix_s)
    found = find_passes(load_elements(path), station, t0, duration_s=max(0.0, end_s - t0) + 900.0,
                        min_el_deg=min_el_deg)
    used: set[int] = set()
    out = []
    for window, norad, name in zip(aos_windows_unix_s, norads, names):
        for p in found:
            if (p.norad_id not in used and window[0] <= p.aos_unix_s <= window[1]
                    and p.max_el_deg >= min_max_el_deg and not p.aos_clipped and not p.los_clipped and accept(p)):
                text = orbit(p.norad_id - 1, name, norad)
                path.write_text(text)
                es = load_elements(path)[0]
                mine = [q for q in find_passes(es, station, p.aos_unix_s - 60.0,
                                               duration_s=p.los_unix_s - p.aos_unix_s + 120.0, min_el_deg=min_el_deg)
                        if abs(q.aos_unix_s - p.aos_unix_s) < 1.0]
                if mine:
                    used.add(p.norad_id)
                    out.append((text, es, mine[0]))
                    break
        else:
            raise RuntimeError(f"no synthetic satellite with a pass in the window {window}")
    return out


def synthetic_catalog(n: int, first_norad: int = 10000, seed: int = 7) -> str:
    """``n`` random-but-deterministic LEO element sets of about today's epoch as 3LE text
    (NORAD ids ``first_norad`` ..): a big catalog for soaks and benches."""
    import random

    rng = random.Random(seed)
    now = datetime.now(timezone.utc).timestamp()
    out = []
    for i in range(n):
        epoch = datetime.fromtimestamp(now - rng.uniform(0.1, 1.0) * 86400.0, tz=timezone.utc)
        out.append(synthetic_tle(f"FILL {i}", first_norad + i, epoch, inc_deg=rng.uniform(0, 110),
                                 raan_deg=rng.uniform(0, 360), argp_deg=rng.uniform(0, 360),
                                 ma_deg=rng.uniform(0, 360), rev_per_day=rng.uniform(14.0, 16.0),
                                 ecc=rng.uniform(0.0001, 0.02)))
    return "".join(out)
