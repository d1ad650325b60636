"""How an accepted MQTT goto or park ended (urc.mqtt.outcomes, issue 33): one more
cmd/result per command, from the statuses alone: done, stopped (with the stop's kind and
reason; one that resumes is followed by the end), replaced."""

from __future__ import annotations

from urc.mqtt.outcomes import MotionOutcomes


def status(t_s, az, el, *, moving=True, target=(100.0, 30.0), last_stop=None, faults=(), parked=False):
    return {"t_s": t_s, "az_deg": az, "el_deg": el, "moving": moving, "parked": parked,
            "target_az_deg": target[0] if target else None, "target_el_deg": target[1] if target else None,
            "last_stop": last_stop, "faults": list(faults)}


def test_a_goto_stopped_by_a_stall_that_resumes_then_arrives():
    w = MotionOutcomes()
    w.accepted("g", "goto", (100.0, 30.0), status(10.0, 0.0, 0.0, moving=False, target=None), 1000.0)
    assert w.update(status(10.0, 0.0, 0.0, moving=False, target=None), 1000.0) == []   # (the tick before it)
    assert w.update(status(11.0, 20.0, 10.0), 1001.0) == []
    stall = {"kind": "health", "reason": "a tick 0.6 s late", "command": "goto", "t_s": 11.5, "resumes": True}
    out = w.update(status(11.6, 22.0, 11.0, moving=False, last_stop=stall), 1001.6)
    assert out == [{"id": "g", "ok": False, "command": "goto", "state": "stopped", "kind": "health",
                    "reason": "a tick 0.6 s late", "resumes": True}]
    assert w.update(status(12.0, 22.0, 11.0, moving=False, last_stop=stall), 1002.0) == []  # said once
    out = w.update(status(30.0, 99.8, 30.1, moving=False, last_stop=stall), 1020.0)
    assert out == [{"id": "g", "ok": True, "command": "goto", "state": "done"}]
    assert len(w) == 0


def test_a_fault_ends_it_and_another_command_replaces_it():
    w = MotionOutcomes()
    w.accepted(1, "goto", (100.0, None), status(5.0, 0.0, 0.0, moving=False, target=None), 0.0)
    w.accepted(2, "park", None, status(5.1, 1.0, 0.0), 0.1)
    out = w.update(status(6.0, 3.0, 0.0, faults=[{"kind": "stall", "axis": "az", "reason": "az stalled"}]), 1.0)
    assert [(r["id"], r["state"]) for r in out] == [(1, "replaced"), (2, "stopped")]
    assert out[1]["kind"] == "fault" and out[1]["reason"] == "az stalled" and out[1]["ok"] is False


def test_a_target_changed_by_another_client_is_replaced():
    w = MotionOutcomes()
    w.accepted("m", "goto", (100.0, 30.0), status(1.0, 0.0, 0.0, moving=False, target=None), 0.0)
    out = w.update(status(2.0, 10.0, 5.0, target=(250.0, 40.0)), 1.0)
    assert out[0]["state"] == "replaced" and out[0]["ok"] is False
