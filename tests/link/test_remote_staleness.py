"""How old a published status may be before the I/O process stops giving its position
as current (link/remote.py): sooner while the axes were moving."""

from __future__ import annotations

import dataclasses

import pytest

from urc.clock import RealClock
from urc.link.client import ControlUnavailable
from urc.link.remote import MOVING_STATUS_STALE_S, STATUS_STALE_S, RemoteRotator


class _Link:
    """What RemoteRotator reads of its link: the latest status, and whether it is lost."""

    def __init__(self):
        self.status = None
        self.lost = ""

    def offer_status(self, status):   # (as ControlLink: only a newer status replaces it)
        if self.status is None or status.t_s >= self.status.t_s:
            self.status = status

    def current(self):   # (no shared-memory record here: the last status as it came)
        return self.status


@pytest.fixture
def remote(bench):
    b = bench("tartu-urc")
    status = b.rot.status()
    link = _Link()
    info = {"pid": 0, "hardware": None, "status": status, "settings": b.rot.settings,
            "caps": b.rot.caps, "geometry": b.rot.geometry}
    rot = RemoteRotator(link, info)

    def aged(age_s: float, moving: bool):
        # (statuses carry the control process's CLOCK_MONOTONIC, as RemoteRotator's clock)
        link.status = dataclasses.replace(status, t_s=RealClock().now_s() - age_s, moving=moving)
        return rot
    return aged


@pytest.mark.parametrize("moving, limit_s", [(True, MOVING_STATUS_STALE_S), (False, STATUS_STALE_S)])
def test_a_position_is_current_until_its_limit_then_no_session_is_given_it(remote, moving, limit_s):
    fresh = remote(0.8 * limit_s, moving)
    assert not any(f.kind == "control" for f in fresh.status().faults)
    assert fresh.for_sessions().status().t_s == fresh.status().t_s

    stale = remote(1.2 * limit_s, moving)
    assert any(f.kind == "control" and "silent" in f.reason for f in stale.status().faults)
    with pytest.raises(ControlUnavailable, match="position unknown"):
        stale.for_sessions().status()


def test_a_moving_position_goes_stale_sooner_than_one_at_rest(remote):
    age_s = (MOVING_STATUS_STALE_S + STATUS_STALE_S) / 2
    assert not any(f.kind == "control" for f in remote(age_s, moving=False).status().faults)
    assert any(f.kind == "control" for f in remote(age_s, moving=True).status().faults)
