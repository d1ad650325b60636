"""Shared fixtures of the tracking tests: the fixture files, a station, a fixed time."""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

import pytest

from urc.tracking.elements import load_elements
from urc.tracking.station import Station

FIXTURES = Path(__file__).parent / "fixtures"
#: the reference time: a few hours after the fixture epochs (never "now").
T0 = datetime(2024, 1, 1, 12, 0, tzinfo=timezone.utc)
T0_UNIX_S = T0.timestamp()
TARTU = Station(58.3780, 26.7290, 70.0, "Tartu")


@pytest.fixture(scope="session")
def leo_sets():
    return load_elements(FIXTURES / "leo.tle")


@pytest.fixture(scope="session")
def deep_sets():
    return load_elements(FIXTURES / "deep.tle")


@pytest.fixture(scope="session")
def station():
    return TARTU


def synthetic_tle(n: int, seed: int = 7) -> str:
    """``n`` random-but-deterministic LEO element sets as 3LE text (like the benchmark's)."""
    import math
    import random

    from sgp4.api import WGS72, Satrec
    from sgp4.exporter import export_tle

    rng = random.Random(seed)
    xpdotp = 1440.0 / (2.0 * math.pi)
    epoch_days = (T0 - datetime(1949, 12, 31, tzinfo=timezone.utc)).total_seconds() / 86400.0
    out = []
    for i in range(n):
        sat = Satrec()
        sat.sgp4init(WGS72, "i", 80000 + i, epoch_days - rng.uniform(0.1, 1.0),
                     rng.uniform(1e-5, 3e-4), 0.0, 0.0, rng.uniform(0.0001, 0.02),
                     math.radians(rng.uniform(0, 360)), math.radians(rng.uniform(0, 110)),
                     math.radians(rng.uniform(0, 360)), rng.uniform(14.0, 16.0) / xpdotp,
                     math.radians(rng.uniform(0, 360)))
        sat.intldesg, sat.classification, sat.elnum, sat.revnum, sat.ephtype = \
            "24001A", "U", 999, 100, 0
        out += [f"SYNTH {i}", *export_tle(sat)]
    return "\n".join(out) + "\n"
