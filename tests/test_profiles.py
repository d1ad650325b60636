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


def test_berkeley_slews_at_the_documents_usable_speed(bench):
    """Seed 004: the worm gearing is usable only between ~15 % and ~18 % duty of its
    ~240 deg/s (36-43 deg/s; stalls below, overshoots above). A long goto cruises in that
    band on both axes, arrives within the tolerance and then holds with the motors off."""
    b = bench("berkeley")
    top = {"az": 0.0, "el": 0.0}

    def peak(s):
        for axis in top:
            top[axis] = max(top[axis], abs(s.sim_truth[axis]["rate_deg_per_s"]))
    b.rot.goto(300.0, 200.0)
    b.run(30.0, on_tick=peak)
    s = b.settle()
    assert 36.0 <= top["az"] <= 43.0 and 36.0 <= top["el"] <= 43.0, top
    for axis, want in (("az", 300.0), ("el", 200.0)):
        c = b.rot.caps.axis(axis)
        assert abs(getattr(s, axis).pos_deg - want) <= c.tolerance_deg + c.sensor.resolution_deg
    on = []
    b.run(20.0, on_tick=lambda s: on.append(s.az.duty != 0 or s.el.duty != 0))
    assert not any(on) and not b.rot.status().faults
