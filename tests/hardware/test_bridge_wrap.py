"""urc in front of urc unwinds the cable (issue 21): a set azimuth names its pose on a
protocol that speaks the controller's own (mechanical) azimuth; on a compass protocol
the bridge gets there through turns the far end cannot take the other way."""

from __future__ import annotations

import pytest

from urc.hardware.bridge import BRIDGE_PROTOCOLS
from urc.hardware.bridge.simlink import BridgedRig

#: tartu-urc: 0..400 deg of azimuth, park at 0
PROFILE = "tartu-urc"
AZ_ONLY = {"rot1prog"}


def settled(s) -> bool:
    return not s.moving and all(a is None or a.mode in ("holding", "idle") for a in (s.az, s.el))


@pytest.mark.parametrize("protocol", BRIDGE_PROTOCOLS)
def test_park_from_the_overlap_unwinds_through_the_bridge(protocol, tmp_path):
    kw = {"downstream_config": {"limits": {"el": {"min_deg": 0.0, "max_deg": 1.0}}, "park": {"el_deg": 0.0}}} \
        if protocol in AZ_ONLY else {}
    rig = BridgedRig(protocol, PROFILE, tmp_path, **kw)
    el = 0.0 if protocol in AZ_ONLY else 20.0
    rig.downstream.goto_pose(370.0, el)
    s = rig.run(120.0, until=settled)
    assert not s.faults, s.faults
    assert rig.upstream.status().az.pos_deg == pytest.approx(370.0, abs=2.0)
    rig.downstream.park()
    s = rig.run(240.0, until=lambda s: s.parked or bool(s.faults))
    assert not s.faults, (s.faults, s.events[-5:])
    assert s.parked
    up = rig.upstream.status()
    assert up.az.pos_deg == pytest.approx(rig.downstream.settings.park_az_deg, abs=2.0), \
        "the controller's own axis unwound to the park turn"
