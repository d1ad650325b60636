"""The bridge backend on a single-axis rotator ([rotator] elevation = false): urc in
front of an azimuth-only controller (a Rot1Prog) or of a two-axis one whose elevation
is not used (a BIG-RAS with "Elevation: OFF" over GS-232B). Judged by the upstream
simulator's truth."""

from __future__ import annotations

import pytest

from urc.testing.bridged_rig import BridgedRig


@pytest.mark.parametrize("protocol", ["rot1prog", "gs232b", "rotctld"])
def test_the_azimuth_goes_and_the_elevation_is_never_driven(protocol, tmp_path):
    rig = BridgedRig(protocol, "bigras", tmp_path,
                     downstream_config={"rotator": {"profile": "bigras", "elevation": False}})
    el0 = rig.truth()[1]
    s = rig.downstream.status()
    assert s.axes == ("az",) and s.el is None
    rig.downstream.goto(100.0, 45.0)  # the elevation of a two-axis goto is left aside
    s = rig.run(120.0, until=lambda s: not s.moving and s.az.mode == "holding")
    assert not s.faults, (s.faults, s.events)
    az_t, el_t = rig.truth()
    assert abs(az_t - 100.0) <= 1.6 and abs(s.az_deg - az_t) <= 1.6, (az_t, s.az_deg)
    assert el_t == pytest.approx(el0, abs=0.2)  # nothing drove the controller's elevation
    assert s.el_deg is None
