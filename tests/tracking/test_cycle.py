"""The Berkeley state machine (seed 004) as a view of urc's own state: setup ->
PROCESS_TLE -> PREDICT -> TRACK_MOTOR -> UPDATE_SERVER, in the status JSON, ``urc
status`` and the dashboard."""

from __future__ import annotations

import pytest

from urc.status_text import format_status as _format_status
from urc.tracking.cycle import cycle_state
from urc.tracking.passes import find_passes
from urc.tracking.station import Station
from urc.tracking.tracker import Tracker
from urc.web.history import pointing_error_deg

from .conftest import T0_UNIX_S

BERKELEY = Station(37.8716, -122.2727, 52.0, "Berkeley")


def _status(**kw):
    base = {"faults": [], "position_known": True, "tracking": None, "target_az_deg": None}
    return {**base, **kw}


@pytest.mark.parametrize("status, error, state", [
    (_status(position_known=False), None, "setup"),
    (_status(faults=[{"kind": "stall"}], tracking={"state": "tracking"}), 0.1, "setup"),
    (_status(), None, "process_tle"),
    # a GPS station, nothing tracked: the tracking block holds only the receiver's state
    # (it read "PREDICT ... waiting for the pass")
    (_status(tracking={"gps": {"source": "/dev/ttyACM0", "fix": True}}), None, "process_tle"),
    (_status(tracking={"state": "waiting"}), None, "predict"),
    (_status(tracking={"state": "prepositioning"}, target_az_deg=10.0), 40.0, "predict"),
    (_status(tracking={"target": "sun", "error": "sun is below 0 deg elevation"}), None, "predict"),
    (_status(tracking={"state": "tracking"}, target_az_deg=10.0), 2.0, "track"),
    (_status(tracking={"state": "tracking"}, target_az_deg=10.0), 0.2, "report"),
])
def test_mapping(status, error, state):
    c = cycle_state(status, error)
    assert c["state"] == state and c["why"]
    assert c["document"] == {"setup": "setup", "process_tle": "PROCESS_TLE", "predict": "PREDICT",
                             "track": "TRACK_MOTOR", "report": "UPDATE_SERVER"}[state]


def test_a_pass_on_the_berkeley_profile_goes_through_the_documents_states(bench, leo_sets):
    """A real tracker flying the ISS over Berkeley on the simulator, taken up when the
    pass is already under way: the status says PROCESS_TLE before anything is tracked,
    then TRACK_MOTOR while the antenna catches up, then UPDATE_SERVER once on the
    target. (Taken up before the pass, urc waits pre-positioned in PREDICT and is on
    the target from the rise: PREDICT -> UPDATE_SERVER.)"""
    b = bench("berkeley")
    es = next(e for e in leo_sets if e.norad_id == 25544)
    p = next(p for p in find_passes(es, BERKELEY, T0_UNIX_S, duration_s=86400, min_el_deg=10))
    t0 = b.clock.now_s()
    start_u = p.aos_unix_s + 30.0

    def unix_at(now_s):
        return start_u + (now_s - t0)

    def cycle():
        d = b.rot.status().as_dict()
        d["tracking"] = tracker.status(b.clock.now_s()) if tracker is not None else None
        return cycle_state(d, pointing_error_deg(d))

    tracker = None
    first = cycle()
    assert first["state"] == "process_tle"
    assert "cycle     PROCESS_TLE (process_tle)" in _format_status({**b.rot.status().as_dict(), "cycle": first})
    tracker = Tracker(b.rot, BERKELEY, unix_at, park_after_pass=False)
    tracker.track_pass(es, p, b.clock.now_s())
    seen, ticks = [], [0]

    def on_tick(st):
        tracker.step(st.t_s)
        ticks[0] += 1
        if ticks[0] % 10:        # a status is costly (plan, ground track): 5 a second
            return
        state = cycle()["state"]
        if not seen or seen[-1] != state:
            seen.append(state)
    b.run(40.0, on_tick=on_tick)
    assert "track" in seen and "report" in seen and seen.index("track") < seen.index("report"), seen
    assert "setup" not in seen and "process_tle" not in seen


def test_status_with_only_a_gps_says_not_tracking_and_shows_the_fix():
    """`urc status` printed "tracking  None" for a GPS station with nothing tracked."""
    gps = {"source": "/dev/ttyACM0", "fix": True, "clock_offset_s": 0.012, "clock_trustworthy": True,
           "lat_deg": 37.8716, "lon_deg": -122.2727, "alt_m": 52.0}
    from urc.status_text import format_tracking as _format_tracking
    text = _format_tracking({"gps": gps})
    assert text == "not tracking\ngps       /dev/ttyACM0: fix 37.87160 -122.27270 52 m, clock offset +0.012 s"
    assert "None" not in text
    assert _format_tracking({"gps": {"source": "tcp:gps:2947", "fix": False, "clock_offset_s": None}}) == \
        "not tracking\ngps       tcp:gps:2947: no fix yet"
