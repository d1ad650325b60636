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
    satisfies ``accept(pass)``."""
    from ..tracking.elements import load_elements
    from ..tracking.passes import find_passes

    now = datetime.now(timezone.utc)
    path = work / "pick.tle"
    for raan in range(0, 360, 15):
        for ma in range(0, 360, 5):
            text = synthetic_tle(name, norad, now, inc_deg=70.0, raan_deg=raan, argp_deg=90.0, ma_deg=ma,
                                 rev_per_day=15.2)
            path.write_text(text)
            es = load_elements(path)[0]
            t0 = time.time()
            for p in find_passes(es, station, t0, duration_s=lead_s[1] + 1200.0, min_el_deg=0.0):
                if lead_s[0] <= p.aos_unix_s - t0 <= lead_s[1] and p.max_el_deg >= min_max_el_deg and accept(p):
                    return text, es, p
    raise RuntimeError("no synthetic satellite with a pass in the window")
