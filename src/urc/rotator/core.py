"""What every part of the rotator shares: its settings and geometry, its axes, and what
it is doing now (the route being flown, a track, a park, the target), the latched faults
and the recent events.

One :class:`Core` per :class:`~urc.rotator.rotator.Rotator`; its parts (commands,
planning, guard, records, status) each hold it and change only what their concern is
about. It holds state and the few readings of it that every part needs; no decisions.
"""

from __future__ import annotations

import collections
import logging
import math
from typing import Any

from ..angles import great_circle_1_deg
from ..clock import Clock
from ..control.faults import Fault
from ..control.geometry import Geometry, wrap360
from .axis import Axis
from ..model.settings import FIXED_EL_DEG, RotatorSettings

log = logging.getLogger("urc.rotator.rotator")


#: a sky goto this close to where the pass program in flight points now does not replace
#: it (Core.agrees_with_program): a client tracking the same satellite with the same
#: elements asks for the same direction, within its own poll's lag
PROGRAM_AGREE_DEG = 2.0


class Core:
    def __init__(self, settings: RotatorSettings, hw: Any, clock: Clock, axes: dict[str, Axis]):
        self.settings = settings
        self.caps = settings.caps
        self.hw = hw
        self.clock = clock
        # (replaced once the state is restored: a sensor constant restored with it may
        # turn bearings; see Planner.geometry_for)
        self.geometry: Geometry = settings.geometry()
        #: a single-axis rotator has no elevation Axis at all: its beam stays at
        #: FIXED_EL_DEG, which the pose maths stand in for
        self.axes = axes
        self.faults: list[Fault] = []
        self.events: collections.deque[str] = collections.deque(maxlen=20)
        #: the waypoints of the route being flown (the first is the one aimed at now)
        self.route: list[tuple[float, float]] = []
        self.tracking = False
        self.parked = False
        #: a park accepted and under way: parked once both axes hold at the park pose
        self.parking = False
        self.target_sky: tuple[float, float] | None = None
        self.seq = 0
        self.last_command_t_s = clock.now_s()
        #: the motion command being flown ("goto", "park", "track", "move", "program", ...;
        #: None at rest): what a stop by a health rule says it interrupted, and whether
        #: that motion is bounded (it runs to its end without the I/O process) or not
        self.motion: str | None = None
        #: the pass program being flown (urc.model.program), its state (waiting,
        #: prepositioning, tracking) and how the last one ended ({"id", "why", "t_s"})
        self.program: Any = None
        self.program_state = ""
        self.program_end: dict[str, Any] | None = None
        #: the last stop that was not asked for by a client's motion command: who stopped
        #: what and why ({"kind", "reason", "command", "t_s", "resumes"}); see Status.last_stop
        self.last_stop: dict[str, Any] | None = None
        #: status' ``program``: made once per program and state (program_view)
        self._program_view_key: tuple[int, str] | None = None
        self._program_view: dict[str, Any] | None = None

    def event(self, text: str) -> None:
        """Logged, and kept among status' recent events."""
        log.warning("%s", text)
        self.events.append(text)

    def next_seq(self) -> int:
        self.seq += 1
        return self.seq

    def abandon_motion(self) -> None:
        """No route, track, park or target any more (a fault, a zone ahead). A pass
        program stays loaded: it flies on once the faults are cleared (where the
        satellite is then), as the tracker's updates used to."""
        self.route = []
        self.tracking = False
        self.parking = False
        self.target_sky = None
        self.motion = None

    def note_stop(self, kind: str, reason: str, resumes: bool, command: str | None = None) -> None:
        """Record a stop that a client did not ask for (kind: "health", "fault",
        "safety", "rotator"), said as an event too: never a silent idle."""
        self.last_stop = {"kind": kind, "reason": reason, "command": command or self.motion,
                          "t_s": self.clock.now_s(), "resumes": resumes}
        self.event(f"stopped ({kind}): {reason}" + (f"; interrupted {self.last_stop['command']}"
                                                     if self.last_stop["command"] else "")
                   + ("; resumes once healthy" if resumes else ""))

    def agrees_with_program(self, az_deg: float, el_deg: float) -> tuple[float, float] | None:
        """A sky goto within PROGRAM_AGREE_DEG of where the pass program in flight points
        now is what that program does (Gpredict, SatNOGS or a script tracking the same
        satellite beside urc's own tracker): the program flies on rather than be replaced
        by a track that is its own copy, late by a client's poll. Its pose now, else None."""
        p = self.program
        if p is None or self.program_state not in ("prepositioning", "tracking") or \
                not (math.isfinite(az_deg) and math.isfinite(el_deg)):
            return None
        az_m, el_m, _, _ = p.pose_at(self.clock.now_s())
        if great_circle_1_deg(wrap360(az_deg), el_deg, *self.geometry.to_sky(az_m, el_m)) > PROGRAM_AGREE_DEG:
            return None
        return (az_m, el_m)

    def program_view(self) -> dict[str, Any] | None:
        """Status' ``program``: one dict per program and state (not one per tick)."""
        p = self.program
        if p is None:
            return None
        key = (p.program_id, self.program_state)
        if self._program_view_key != key:
            self._program_view_key = key
            self._program_view = {"id": p.program_id, "name": p.name, "state": self.program_state,
                                  "aos_s": p.aos_s, "los_s": p.los_s}
        return self._program_view

    def end_program(self, why: str) -> None:
        """The pass program is over (flown, replaced, stopped); said in status."""
        if self.program is None:
            return
        self.program_end = {"id": self.program.program_id, "name": self.program.name, "why": why,
                            "t_s": self.clock.now_s()}
        self.program, self.program_state = None, ""
        if self.motion == "program":
            self.motion = None

    def rates(self) -> tuple[float, float]:
        el = self.axes.get("el")  # (no elevation axis: its pose never changes; any rate)
        return (self.axes["az"].tuning.max_rate_deg_per_s, el.tuning.max_rate_deg_per_s if el else 1.0)

    def current_pose(self) -> tuple[float, float]:
        el = self.axes.get("el")
        return (self.axes["az"].meas_deg, el.meas_deg if el else FIXED_EL_DEG)

    # (these two run every tick: loops, not any() over a generator)
    def position_uncertain(self) -> bool:
        for ax in self.axes.values():
            if ax.uncertainty_deg > 0:
                return True
        return False

    def moving(self) -> bool:
        # coasting counts as moving; sensor noise on a standing axis does not. An axis
        # whose sensor is dead shows no motion: its speed is the last one measured (a
        # bridge link outage said "moving" over a frozen position); its fault says why.
        # (Records still see that speed: a restart must not trust a position at rest.)
        for ax in self.axes.values():
            if (ax.law.mode in ("driving", "releasing") or abs(ax.rate_deg_per_s) > ax.still_rate_deg_per_s) \
                    and not self.sensor_dead(ax):
                return True
        return False

    def sensor_dead(self, ax: Axis) -> bool:
        return not ax.sensor_ok and any(f.kind == "sensor_dead" and f.axis == ax.name for f in self.faults)
