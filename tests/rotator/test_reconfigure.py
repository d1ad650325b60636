"""New limits, keep-out zones and offsets applied while running (the settings page)."""

from dataclasses import replace

import pytest

from urc.control.geometry import KeepOut
from urc.errors import CommandRejected
from urc.profiles import get_profile
from urc.model.settings import RotatorSettings


def test_narrower_limits_and_a_new_zone_apply_at_once(bench):
    b = bench("berkeley")
    b.rot.goto(100.0, 10.0)
    b.settle()
    new = replace(b.rot.settings, az_limits_deg=(0.0, 200.0),
                  zones=(KeepOut("mast", 140.0, 160.0, 0.0, 30.0),), az_faults=None)
    b.rot.reconfigure(new)
    b.run(0.1)
    with pytest.raises(CommandRejected, match="outside the limits"):
        b.rot.goto(250.0, 10.0)
    poses = []
    b.rot.goto(180.0, 10.0)  # beyond the new mast: over the top of it
    b.run(30.0, on_tick=lambda s: poses.append((s.sim_truth["az"]["deg"], s.sim_truth["el"]["deg"])))
    assert all(not (141.0 <= a <= 159.0 and e <= 29.0) for a, e in poses)
    assert poses[-1] == pytest.approx((180.0, 10.0), abs=0.5)
    assert any("new settings applied" in e for e in b.rot.status().events)


def test_refused_when_the_antenna_would_be_inside_a_new_zone_or_outside_limits(bench):
    b = bench("berkeley")
    b.rot.goto(150.0, 10.0)
    b.settle()
    with pytest.raises(CommandRejected, match="keep-out"):
        b.rot.reconfigure(replace(b.rot.settings, zones=(KeepOut("mast", 140.0, 160.0, 0.0, 30.0),)))
    with pytest.raises(CommandRejected, match="outside the new limits"):
        b.rot.reconfigure(replace(b.rot.settings, az_limits_deg=(0.0, 100.0), az_faults=None))
    with pytest.raises(CommandRejected, match="next start"):
        b.rot.reconfigure(RotatorSettings.from_caps(get_profile("g5500")))
    b.rot.goto(160.0, 10.0)  # the old rules still hold
    assert b.settle().az_deg == pytest.approx(160.0, abs=0.3)


def test_motion_in_progress_stops_on_new_settings(bench):
    b = bench("tartu-urc")
    b.rot.goto(200.0, 30.0)
    b.run(3.0)
    assert b.rot.status().moving
    b.rot.reconfigure(replace(b.rot.settings, az_offset_deg=2.0))
    s = b.settle()
    assert s.az.target_deg is None or abs(s.az_deg - 200.0) > 5.0
