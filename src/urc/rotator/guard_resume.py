"""A second approach after the guard cut a drive short of a limit on a prediction.

The guard (``Rotator._guard``) cuts drive that would carry an axis past a limit, judged
by where the axis would come to rest. Under load that prediction can be wrong: a late
tick parts the law's reference from the measurement, so the law's own braking plan is
not used, and the measured speed (a slope over a window) lags a braking axis. An
approach to a target at the limit (a park at az 0) was then cut 0.35-0.65 deg short and
held there: "guard: az stopped at 0.65 deg before its limit", ``parked`` never true, no
retry (issue 21).

The guard still cuts and holds where the axis is. When the cut was for the prediction
alone (the axis inside its limits, no limit switch pressed) and the command was a
standing target inside the limits (a goto, a park; not a track point or a jog), that
target is approached once more as soon as the axis rests on the guard's hold: from
rest no speed estimate lags. A cut of that second approach is final. Any other command
meanwhile (it changes the setpoint) drops the retry.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..control import law


@dataclass(frozen=True)
class _Pending:
    hold_seq: int      # the guard's hold setpoint: the retry waits for the axis to rest on it
    target_deg: float  # the standing target the cut drive was heading for


class GuardRetry:
    """Per axis: the target to approach again once the axis rests after a guard cut."""

    def __init__(self) -> None:
        self._pending: dict[str, _Pending] = {}
        self._retry_seq: dict[str, int] = {}  # the setpoint of a retry: not retried again

    def cut(self, axis: str, cut_sp: law.Setpoint | None, hold_seq: int, limits: tuple[float, float], *,
            predicted_only: bool) -> bool:
        """The guard replaced ``cut_sp`` by its hold (``hold_seq``). True if the target
        will be approached again."""
        self._pending.pop(axis, None)
        lo, hi = limits
        if not predicted_only or cut_sp is None or self._retry_seq.get(axis) == cut_sp.seq \
                or cut_sp.rate_deg_per_s != 0.0 or cut_sp.speed_cap_deg_per_s is not None \
                or not lo <= cut_sp.target_deg <= hi:
            return False
        self._pending[axis] = _Pending(hold_seq, cut_sp.target_deg)
        return True

    def due(self, axis: str, sp: law.Setpoint | None, state: law.AxisState, still: bool) -> float | None:
        """The target to approach now (once: the caller sets it, then calls
        ``retrying``), or None: not yet, or nothing to retry."""
        p = self._pending.get(axis)
        if p is None:
            return None
        if sp is None or sp.seq != p.hold_seq:
            del self._pending[axis]  # another command (or a fault) came first
            return None
        if state.mode != "holding" or state.seq != p.hold_seq or not still:
            return None
        del self._pending[axis]
        return p.target_deg

    def retrying(self, axis: str, seq: int) -> None:
        self._retry_seq[axis] = seq
