"""urc.procedures.hub: the one shape the web hub drives (a calibration, a cross scan)."""

from __future__ import annotations

from urc.errors import CommandRejected
from urc.procedures.hub import HubProcedure


class _Rot:
    def __init__(self, stop_refused: bool = False):
        self.stops = 0
        self.stop_refused = stop_refused

    def stop(self) -> None:
        self.stops += 1
        if self.stop_refused:
            raise CommandRejected("local control holds it", "local")


class _Steps(HubProcedure):
    kind = "test"

    def __init__(self, rotator, raises: Exception | None = None):
        super().__init__(rotator, "el")
        self.raises = raises
        self.polled = 0
        self.ended: list[str] = []

    def _poll(self, status) -> None:
        self.polled += 1
        if self.raises is not None:
            raise self.raises

    def _fail(self, reason: str) -> None:
        self.ended.append(f"failed: {reason}")
        self.state = "failed"

    def _cancelled(self) -> None:
        self.ended.append("cancelled")
        self.state = "cancelled"


def test_a_refusal_in_a_step_fails_the_procedure_and_it_is_polled_no_more():
    p = _Steps(_Rot(), CommandRejected("limit", "limit"))
    p.poll(None)
    p.poll(None)
    assert p.polled == 1 and p.finished and p.ended == ["failed: limit"]


def test_cancel_stops_the_antenna_first_even_if_the_stop_is_refused_and_only_once():
    for refused in (False, True):
        rot = _Rot(stop_refused=refused)
        p = _Steps(rot)
        p.cancel()
        p.cancel()
        assert rot.stops == 1 and p.ended == ["cancelled"] and p.state == "cancelled"


def test_its_progress_as_the_hub_sends_it():
    p = _Steps(_Rot())
    p.progress, p.result = 0.12345, {"offset_deg": 0.5}
    assert p.as_dict() == {"kind": "test", "axis": "el", "state": "running", "step": "starting",
                           "progress": 0.123, "error": "", "result": {"offset_deg": 0.5}}
