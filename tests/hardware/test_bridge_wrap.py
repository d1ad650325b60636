"""urc in front of urc unwinds the cable (issue 21): a set azimuth names its pose on a
protocol that speaks the controller's own (mechanical) azimuth; on a compass protocol
the bridge gets there through turns the far end cannot take the other way."""

from __future__ import annotations

import pytest

from urc.hardware.bridge import BRIDGE_PROTOCOLS
from urc.protocols.registry import PROTOCOLS
from urc.testing.bridged_rig import BridgedRig

#: tartu-urc: 0..400 deg of azimuth, park at 0
PROFILE = "tartu-urc"
AZ_ONLY = {"rot1prog"}

#: the protocols urc also serves as a controller (a device session to bridge to); the
#: SatNOGS firmware's dialect is tested against its own emulation (test_bridge_satnogs.py)
URC_SPEAKS = [p for p in BRIDGE_PROTOCOLS if p in PROTOCOLS]


def settled(s) -> bool:
    return not s.moving and all(a is None or a.mode in ("holding", "idle") for a in (s.az, s.el))


@pytest.mark.parametrize("protocol", URC_SPEAKS)
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


@pytest.mark.parametrize("protocol", ["gs232b", "easycomm3", "rotctld"])
def test_a_link_drop_is_one_fault_that_clears_itself(protocol, tmp_path):
    """Issue 21: after a link drop sensor_dead stayed latched, a stall was invented, and
    a controller that came back elsewhere (restarted) added runaway and sensor_jump. Now:
    one link fault, cleared once the controller answers and its position is re-read."""
    rig = BridgedRig(protocol, "g5500", tmp_path)
    rig.downstream.goto(100.0, 30.0)
    rig.run(3.0)
    rig.link.cut("cable pulled", rig.clock.now_s())
    s = rig.run(5.0, until=lambda s: bool(s.faults))
    assert [f.kind for f in s.faults] and {f.kind for f in s.faults} == {"sensor_dead"}, s.faults
    # meanwhile the controller is moved by hand (or restarted elsewhere) 40 deg away
    rig.upstream.stop()
    rig.run(3.0)
    rig.upstream.goto(rig.upstream.status().az_deg - 40.0, 20.0)
    for _ in range(2000):
        rig.upstream.tick()
        rig.clock.advance(1.0 / rig.upstream.caps.loop_hz)
        if not rig.upstream.status().moving:
            break
    rig.link.mend(rig.clock.now_s())
    s = rig.run(10.0, until=lambda s: not s.faults)
    assert not s.faults, (s.faults, s.events[-4:])
    assert any("link fault cleared" in e for e in s.events)
    rig.run(5.0)
    s = rig.downstream.status()
    assert not s.faults, s.faults   # no stall, runaway or jump invented from the gap
    truth = rig.upstream.status()
    assert s.az_deg == pytest.approx(truth.az_deg, abs=1.5)
    rig.downstream.goto(150.0, 40.0)   # and it flies again
    s = rig.run(90.0, until=settled)
    assert not s.faults and s.az_deg == pytest.approx(150.0, abs=1.5)
