"""What the web hub drives of a procedure that takes time (urc.web.live.Hub): a
calibration (:mod:`.calibration`) or a cross scan (urc.peaking.procedure). One shape for
both: its state, a poll with each new status, a cancel, its progress as a dict."""

from __future__ import annotations

import abc
from typing import Any

from ..errors import CommandRejected


class HubProcedure(abc.ABC):
    """Subclasses write :meth:`_poll` (one step from a new status), :meth:`_fail` and
    :meth:`_cancelled` (the antenna is stopped already), and may narrow :meth:`_summary`."""

    kind = "procedure"
    #: what a step may raise to end the procedure as failed (its text the reason)
    FAILS_ON: tuple[type[Exception], ...] = (CommandRejected,)

    def __init__(self, rotator: Any, axis: str):
        self.rotator = rotator
        self.axis = axis
        self.state = "running"          # running | done | failed | cancelled
        self.step = "starting"
        self.progress = 0.0
        self.error = ""
        self.result: dict[str, Any] = {}

    @property
    def finished(self) -> bool:
        return self.state != "running"

    def poll(self, status: Any) -> None:
        if self.finished:
            return
        try:
            self._poll(status)
        except self.FAILS_ON as exc:
            self._fail(str(exc))

    def cancel(self) -> None:
        if self.finished:
            return
        self._stop_antenna()
        self._cancelled()

    def as_dict(self) -> dict[str, Any]:
        """The hub's progress (in every live frame)."""
        return {"kind": self.kind, "axis": self.axis, "state": self.state, "step": self.step,
                "progress": round(self.progress, 3), "error": self.error, "result": self._summary()}

    def _summary(self) -> dict[str, Any]:
        return self.result

    def _stop_antenna(self) -> None:
        try:
            self.rotator.stop()
        except CommandRejected:  # (a fault or local control holds it: stopped already)
            pass

    @staticmethod
    def _still(status: Any) -> bool:
        return not status.moving and all(a is None or a.mode in ("holding", "idle") for a in (status.az, status.el))

    @abc.abstractmethod
    def _poll(self, status: Any) -> None:
        """One step from a new status."""

    @abc.abstractmethod
    def _fail(self, reason: str) -> None:
        """End as failed, for ``reason`` (the antenna is not stopped yet)."""

    @abc.abstractmethod
    def _cancelled(self) -> None:
        """End as cancelled (the antenna is stopped already)."""
