"""Status payloads, when they are due (deadband, rate cap, refresh), events."""

from __future__ import annotations

import json

from urc.mqtt.telemetry import EventWatcher, StatusGate, status_payload


def snap(az_deg=10.0, el_deg=20.0, **kw):
    s = {"az_deg": az_deg, "el_deg": el_deg, "target_az_deg": None, "target_el_deg": None, "moving": False,
         "parked": False, "position_known": True, "faults": [], "local_control": [], "events": [],
         "az": {"uncertainty_deg": 0.0}, "el": {"uncertainty_deg": 0.0}, "tracking": None}
    s.update(kw)
    return s


def payload(**kw):
    return status_payload(snap(**kw), "dish", 1000.0)


def test_payload_fields_and_state():
    p = payload(az_deg=123.456789, el_deg=45.0)
    assert p["az_deg"] == 123.46 and p["state"] == "idle" and p["station"] == "dish"
    assert payload(moving=True)["state"] == "moving"
    assert payload(parked=True)["state"] == "parked"
    assert payload(position_known=False, az={"uncertainty_deg": 3.0})["state"] == "uncertain"
    assert payload(position_known=False, az={"uncertainty_deg": 3.0})["uncertainty_deg"] == 3.0
    assert payload(local_control=["panel cw"])["state"] == "local"
    f = {"kind": "stall", "axis": "az", "reason": "az stalled", "t_s": 1.0}
    assert payload(faults=[f], moving=True)["state"] == "fault"
    trk = {"target": "NOAA 19", "state": "tracking", "az_deg": 1.0, "el_deg": 2.0, "stopped": None,
           "plan": {"aos": "2026-01-01T00:00:00+00:00", "los": "2026-01-01T00:10:00+00:00", "max_el_deg": 61.234,
                    "track": [[0, 1, 2]] * 200}}
    p = payload(tracking=trk)
    assert p["state"] == "tracking" and p["tracking"]["target"] == "NOAA 19"
    assert p["next_pass"] == {"aos": "2026-01-01T00:00:00+00:00", "los": "2026-01-01T00:10:00+00:00",
                              "max_el_deg": 61.23}
    assert len(json.dumps(p)) < 700, "the plan's track stays out of the status"
    assert payload(tracking={**trk, "stopped": "stopped: fault latched"})["state"] == "idle"


def test_gate_deadband_rate_cap_and_refresh():
    g = StatusGate(deadband_deg=0.1, max_rate_hz=4.0, refresh_s=10.0)
    p = payload(az_deg=10.0)
    assert g.due(p, 0.0)
    g.sent(p, 0.0)
    assert not g.due(payload(az_deg=10.05), 1.0), "inside the deadband"
    assert not g.due(payload(az_deg=10.5), 0.1), "rate cap: 4 Hz"
    assert g.due(payload(az_deg=10.5), 0.25)
    assert g.due(payload(az_deg=359.95), 0.25), "a real move"
    g.sent(payload(az_deg=359.95), 0.3)
    assert not g.due(payload(az_deg=0.0), 1.0), "0.05 deg across north is inside the deadband"
    assert g.due(payload(az_deg=359.95, moving=True), 1.0), "anything else that changes goes out"
    assert g.due(payload(az_deg=359.95), 10.3), "refresh"
    g.forget()
    assert g.due(payload(az_deg=359.95), 10.31), "a new connection publishes at once"


def test_gate_ignores_the_target_moving_inside_the_deadband_while_tracking():
    g = StatusGate(deadband_deg=0.1, max_rate_hz=4.0, refresh_s=10.0)
    t = {"target": "Sun", "state": None, "az_deg": 100.0, "el_deg": 10.0}
    g.sent(payload(tracking=t), 0.0)
    assert not g.due(payload(tracking={**t, "az_deg": 100.3}), 1.0)
    assert g.due(payload(tracking={**t, "error": "Sun is below 0 deg"}), 1.0)


def test_events():
    w = EventWatcher()
    f = {"kind": "stall", "axis": "az", "reason": "az stalled", "t_s": 1.0}
    s0 = snap(events=["old notice"])
    assert w.events(s0, status_payload(s0, "d", 0), None) == []
    s1 = snap(faults=[f], events=["old notice", "guard stop: az limit"])
    assert w.events(s1, status_payload(s1, "d", 0), None) == [
        {"type": "fault", "kind": "stall", "axis": "az", "reason": "az stalled"},
        {"type": "notice", "text": "guard stop: az limit"}]
    s2 = snap(events=["old notice", "guard stop: az limit"],
              tracking={"target": "NOAA 19", "state": "waiting", "plan": {"aos": "A", "los": "L", "max_el_deg": 40}})
    assert w.events(s2, status_payload(s2, "d", 0), {"kind": "homing", "state": "running", "error": ""}) == [
        {"type": "faults_cleared"}, {"type": "tracking_started", "target": "NOAA 19"},
        {"type": "procedure", "kind": "homing", "state": "running", "error": ""}]
    s3 = snap(tracking={"target": "NOAA 19", "state": "tracking", "plan": {"aos": "A", "los": "L", "max_el_deg": 40}})
    assert w.events(s3, status_payload(s3, "d", 0), {"kind": "homing", "state": "running", "error": ""}) == [
        {"type": "pass_started", "target": "NOAA 19", "aos": "A", "los": "L", "max_el_deg": 40}]
    s4 = snap()
    assert w.events(s4, status_payload(s4, "d", 0), {"kind": "homing", "state": "done", "error": ""}) == [
        {"type": "tracking_stopped", "target": "NOAA 19"}, {"type": "pass_ended", "target": "NOAA 19"},
        {"type": "procedure", "kind": "homing", "state": "done", "error": ""}]


def test_a_stop_urc_made_by_itself_is_an_event_once():
    """Issue 33: a stop by a health rule was a bare notice; it is a `stopped` event with
    its kind, reason, the command it cut and whether it resumes, sent once."""
    w = EventWatcher()
    s0 = snap()
    assert w.events(s0, status_payload(s0, "d", 0), None) == []
    stop = {"kind": "health", "reason": "the I/O process was silent for 1.2 s", "command": "move", "t_s": 5.0,
            "resumes": False}
    s1 = snap(last_stop=stop)
    assert w.events(s1, status_payload(s1, "d", 0), None) == [{"type": "stopped", **stop}]
    assert w.events(s1, status_payload(s1, "d", 0), None) == []
