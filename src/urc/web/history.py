"""Status history for the charts: a ring buffer of samples plus the current and last pass.

A "pass" is one tracking session (the status' ``tracking`` object present, same target);
the last finished one is kept whole after the ring buffer has moved on. Samples hold the
pointing (where the antenna points), the setpoint (where it is told to point) and the
great-circle pointing error between them.
"""

from __future__ import annotations

import collections
import math
import threading
from dataclasses import dataclass
from typing import Any

from ..angles import great_circle_1_deg, wrap180_deg

#: sample fields, in order (also the keys of the arrays the endpoint returns)
FIELDS = ("t_wall_s", "az_deg", "el_deg", "target_az_deg", "target_el_deg", "error_deg",
          "az_mech_deg", "az_target_mech_deg")


def setpoint(status: dict[str, Any]) -> tuple[float | None, float | None]:
    """Where the antenna is told to point: the rotator's target, updated every tick, also
    while tracking (the tracked object itself may be below the horizon, waiting)."""
    return status.get("target_az_deg"), status.get("target_el_deg")


def _round4(v: float | None) -> float | None:
    return None if v is None else round(v, 4)


def pointing_error_deg(status: dict[str, Any]) -> float | None:
    taz, tel = setpoint(status)
    if taz is not None and status.get("el_deg") is None:  # azimuth only: the azimuth error
        return abs(wrap180_deg(status["az_deg"] - taz))
    if taz is None or tel is None:
        return None
    return great_circle_1_deg(status["az_deg"], status["el_deg"], taz, tel)


@dataclass
class Segment:
    label: str
    samples: list[tuple]


class History:
    """Written by the event loop (``add``), read by GET /api/history in a worker thread
    (``select``): a reader copies what it needs under the lock and works on the copy, as
    a deque raises "mutated during iteration" if the loop appends while a thread walks
    it. The loop waits at most for one copy (36 000 references)."""

    def __init__(self, capacity: int = 36_000, max_pass_samples: int = 36_000):
        self._lock = threading.Lock()
        self.recent: collections.deque[tuple] = collections.deque(maxlen=capacity)
        self.current: Segment | None = None
        self.last: Segment | None = None
        self.max_pass_samples = max_pass_samples

    def add(self, t_wall_s: float, status: dict[str, Any], error_deg: float | None) -> None:
        taz, tel = setpoint(status)
        sample = (round(t_wall_s, 3), round(status["az_deg"], 4), _round4(status["el_deg"]),
                  None if taz is None else round(taz, 4), None if tel is None else round(tel, 4),
                  None if error_deg is None else round(error_deg, 5),
                  round(status["az"]["pos_deg"], 4),
                  None if status["az"]["target_deg"] is None else round(status["az"]["target_deg"], 4))
        trk = status.get("tracking")
        label = str(trk.get("target", "tracking")) if trk else None
        with self._lock:
            self.recent.append(sample)
            if self.current is not None and label != self.current.label:
                self.last, self.current = self.current, None
            if label is not None:
                if self.current is None:
                    self.current = Segment(label, [])
                if len(self.current.samples) < self.max_pass_samples:
                    self.current.samples.append(sample)

    def select(self, which: str, seconds: float | None = None, since_wall_s: float | None = None,
               max_points: int = 3000) -> dict[str, Any]:
        """Arrays for one window: ``recent`` (the ring, optionally the last ``seconds``),
        ``current`` or ``last`` pass. ``since_wall_s`` returns only newer samples."""
        label = "recent"
        with self._lock:
            if which in ("current", "last"):
                seg = self.current if which == "current" else self.last
                rows = list(seg.samples) if seg else []
                label = seg.label if seg else ""
            else:
                rows = list(self.recent)
        if which not in ("current", "last") and seconds is not None and rows:
            t_min = rows[-1][0] - seconds
            rows = [s for s in rows if s[0] >= t_min]
        if since_wall_s is not None:
            rows = [s for s in rows if s[0] > since_wall_s]
        if len(rows) > max_points > 0:
            step = math.ceil(len(rows) / max_points)
            rows = rows[::step] + ([rows[-1]] if (len(rows) - 1) % step else [])
        out: dict[str, Any] = {"which": which, "label": label, "count": len(rows)}
        for i, name in enumerate(FIELDS):
            out[name] = [r[i] for r in rows]
        return out
