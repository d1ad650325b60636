"""Issue 12.3: after a fault the tracker must not keep saying "tracking"; once the
fault is cleared, following resumes by itself."""

from __future__ import annotations

import pytest

from urc.status_text import format_tracking as _format_tracking
from urc.tracking.station import Station
from urc.tracking.targets import FixedTarget
from urc.tracking.tracker import Tracker


def test_tracking_says_plainly_that_it_stopped_and_resumes_after_clear(bench):
    b = bench("berkeley")
    tracker = Tracker(b.rot, Station(58.4, 26.7, 70.0), unix_at=lambda t: 1.7e9 + t)
    tracker.track(FixedTarget(120.0, 30.0), b.clock.now_s())
    b.run(1.0, on_tick=lambda s: tracker.step(s.t_s))
    st = tracker.status(b.clock.now_s())
    assert st["stopped"] is None and _format_tracking(st).startswith("tracking")
    b.world.inject("az", "sensor_dead")
    b.run(0.5, on_tick=lambda s: tracker.step(s.t_s))
    st = tracker.status(b.clock.now_s())
    assert st["stopped"].startswith("stopped: fault latched")
    assert _format_tracking(st).startswith("NOT tracking")
    b.world.clear("az")
    b.rot.clear_faults()
    s = b.run(60.0, on_tick=lambda s: tracker.step(s.t_s))
    assert tracker.status(b.clock.now_s())["stopped"] is None
    assert s.az_deg == pytest.approx(120.0, abs=0.5) and s.el_deg == pytest.approx(30.0, abs=0.5)
