"""Program track: a whole planned pass, flown by the control process on its own clock.

The tracker (I/O process) plans a satellite pass before it starts (wrap, flip, rate
limits, keep-out: urc.tracking.planner) and uploads the result as one
:class:`PassProgram`: time-tagged mechanical poses on the control loop's clock
(CLOCK_MONOTONIC), when to leave for the AOS pose, and what to do after LOS. From then on
the control process flies the pre-position, the pass and the end by itself, as a
professional antenna control unit runs program track from an uploaded predict table; the
I/O process only watches, and may replace or cancel the program. So a pass survives a
silent, starved or stopped I/O process (issue 33: a 1.5 s pause during the pre-position
move lost the first 49 s of a pass when the tracker sent that move once and the silence
stopped it).

A program is a *bounded* motion: every pose it may fly is checked against the limits and
the keep-out zones when it is accepted, and the guard enforces both on every tick. It
ends at LOS (park, or hold the LOS pose), or when any other motion command or a stop
replaces it.

Here the program itself, what the tracker uploads (``FlyProgram``) and the status shows;
the control process's flight of it is :mod:`urc.rotator.program_flight`.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import Any, Callable

from ..control.geometry import route_time_s

#: what a program does after LOS
END_ACTIONS = ("park", "hold")


def rejoin_aim(g: Any, here: tuple[float, float], pose: tuple[float, float], rates: tuple[float, float],
               pose_after: Callable[[float], tuple[float, float]]) -> tuple[float, float] | None:
    """Where to fly round a keep-out zone to rejoin a track (it came out from behind one,
    a pre-positioning move): None while the straight way from ``here`` to ``pose`` is
    clear, else the track's pose once the route round the zone is flown
    (``pose_after(seconds from now)``). The one rule of the control process's program
    flight and the tracker's own motion (geometry ``g``: mechanical poses)."""
    if not g.zones or g.segment_clear(here, pose, rates) is None:
        return None
    route = g.plan(here, *g.to_sky(*pose), rates) or [pose]
    return pose_after(route_time_s([here] + route, rates))


@dataclass(frozen=True)
class PassProgram:
    """One pass to fly: mechanical poses (wrap turn and flip applied) at times on the
    control loop's clock. ``blocked`` samples lie in a keep-out zone: the antenna waits
    at the zone's edge meanwhile."""
    program_id: int
    name: str
    t_s: tuple[float, ...]
    az_deg: tuple[float, ...]
    el_deg: tuple[float, ...]
    blocked: tuple[bool, ...]
    preposition_start_s: float
    end: str = "park"

    @property
    def aos_s(self) -> float:
        return self.t_s[0]

    @property
    def los_s(self) -> float:
        return self.t_s[-1]

    @property
    def aos_pose(self) -> tuple[float, float]:
        return self.az_deg[0], self.el_deg[0]

    @property
    def los_pose(self) -> tuple[float, float]:
        return self.az_deg[-1], self.el_deg[-1]

    def index_at(self, t_s: float) -> int:
        """The sample in force at ``t_s`` (the first at or after it, as the tracker took)."""
        return min(max(bisect.bisect_left(self.t_s, t_s), 0), len(self.t_s) - 1)

    def pose_at(self, t_s: float) -> tuple[float, float, float, float]:
        """Mechanical (az, el, az_rate, el_rate) at ``t_s``, interpolated (rates 0
        outside the pass). Pure Python: it runs in the control loop, where a numpy call
        on one number costs more than this whole function."""
        t, n = self.t_s, len(self.t_s)
        tc = min(max(t_s, t[0]), t[-1])
        i = min(max(bisect.bisect_left(t, tc) - 1, 0), n - 2)
        dt = t[i + 1] - t[i]
        f = (tc - t[i]) / dt
        az = self.az_deg[i] + f * (self.az_deg[i + 1] - self.az_deg[i])
        el = self.el_deg[i] + f * (self.el_deg[i + 1] - self.el_deg[i])
        if not t[0] <= t_s <= t[-1]:
            return az, el, 0.0, 0.0
        return az, el, (self.az_deg[i + 1] - self.az_deg[i]) / dt, (self.el_deg[i + 1] - self.el_deg[i]) / dt

    def problem(self) -> str:
        """Why this program is malformed ("" if it is well formed): checked before any
        pose is looked at, since the control process must never fly garbage."""
        n = len(self.t_s)
        if n < 2:
            return "a program needs at least two samples"
        if not len(self.az_deg) == len(self.el_deg) == len(self.blocked) == n:
            return "a program's samples differ in length"
        if self.end not in END_ACTIONS:
            return f"a program ends with one of {', '.join(END_ACTIONS)}, not {self.end!r}"
        values = (*self.t_s, *self.az_deg, *self.el_deg, self.preposition_start_s)
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
            return "a program's times and poses must be finite numbers"
        if any(b <= a for a, b in zip(self.t_s, self.t_s[1:])):
            return "a program's times must increase"
        if self.preposition_start_s > self.t_s[0]:
            return "a program's pre-positioning must start before its AOS"
        return ""
