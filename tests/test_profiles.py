"""Profile numbers taken from the seed documents, flown on the simulator."""

from __future__ import annotations

import pytest

from urc.errors import CommandRejected
from urc.profiles import PROFILES


def test_berkeley_elevation_spans_270_deg(bench):
    """Seed 004: "limited to a ~270 degree range" from level-forward zero: -45..225 here.
    Past the zenith (a sky elevation over 90 names the pose over the top) and below the
    level both work; beyond the range is refused."""
    el = PROFILES["berkeley"].el
    assert (el.min_deg, el.max_deg) == (-45.0, 225.0)
    b = bench("berkeley")
    for az, el_deg, truth_el in ((10.0, 150.0, 150.0), (10.0, -30.0, -30.0)):
        b.rot.goto(az, el_deg)
        b.settle()
        assert b.truth("el") == pytest.approx(truth_el, abs=0.5)
    with pytest.raises(CommandRejected) as exc:
        b.rot.goto(10.0, -60.0)
    assert exc.value.reason == "limit"
