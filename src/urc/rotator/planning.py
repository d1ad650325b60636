"""Planning: what a command names, in the rotator's own frame, and how to get there.

Sky directions and mechanical poses, the one rule for azimuths outside 0..360, the wrap
turn and flip side chosen by the pass planner, routes round keep-out zones; validation
of the axis names and values every command shares. Reads the axes; changes nothing.
"""

from __future__ import annotations

import math
from dataclasses import replace

from ..control.geometry import Geometry, route_time_s, wrap360
from ..errors import CommandRejected
from .axis import AXES
from .core import Core
from ..model.settings import FIXED_EL_DEG, RotatorSettings
from ..angles import wrap180_deg


class Planner:
    def __init__(self, core: Core):
        self.core = core

    def no_el(self, el_deg: float) -> float:
        """A single-axis rotator takes any finite elevation in a two-axis command and
        leaves it aside (each protocol says whether it answers that as its original
        does, or refuses first); its pose keeps FIXED_EL_DEG."""
        if not (isinstance(el_deg, (int, float)) and math.isfinite(el_deg)):
            raise CommandRejected(f"elevation {el_deg!r} is not a finite number", "invalid")
        return FIXED_EL_DEG

    def require_el(self, what: str) -> None:
        if "el" not in self.core.axes:
            raise CommandRejected(f"{what}: this rotator has no elevation axis (azimuth only)", "no_axis")

    def explicit_pose(self, az_deg: float, el_deg: float) -> tuple[float, float] | None:
        """An azimuth outside 0..360 or an elevation past 90 names one mechanical pose.

        The one rule for azimuths outside 0..360, for every protocol (README): within the
        rotator's extended range (limits + offset) they name that wrap turn (-10 on a
        -90..450 rotator, 400 on 0..450); a negative azimuth down to -180 beyond the range
        is a compass bearing, -10 = 350 (clients in -180..180 mode send west negative);
        anything else outside the range is refused."""
        if 0.0 <= az_deg < 360.0 and el_deg <= 90.0:
            return None
        g = self.core.geometry
        pose = (az_deg - g.az_offset_deg, el_deg - g.el_offset_deg)
        if -180.0 <= az_deg < 0.0 and not g.az_min_deg <= pose[0] <= g.az_max_deg:
            if el_deg <= 90.0:
                return None  # a compass bearing: the planner picks the turn
            return self.explicit_pose(az_deg + 360.0, el_deg)
        if 0.0 <= az_deg < 360.0:
            # a flipped pose with a compass azimuth names the flip, not the wrap turn: the
            # turn nearest in travel, the overlap included (from 355/140, 6.9/137.4 is
            # 366.9, 12 deg on, not 7.0, 348 deg back)
            turns = [(pose[0] + 360.0 * k, pose[1]) for k in range(-2, 3)]
            legal = [p for p in turns if g.in_limits(*p)]
            if legal:
                start = self.core.current_pose()
                pose = min(legal, key=lambda p: route_time_s([start, p], self.core.rates()))
        if not g.in_limits(*pose):
            raise CommandRejected(
                f"position az {az_deg:g}, el {el_deg:g} outside the limits "
                f"az {g.az_min_deg + g.az_offset_deg:g}..{g.az_max_deg + g.az_offset_deg:g}, "
                f"el {g.el_min_deg + g.el_offset_deg:g}..{g.el_max_deg + g.el_offset_deg:g}", "limit")
        return pose

    def plan(self, az_deg: float, el_deg: float) -> list[tuple[float, float]]:
        for v, what in ((az_deg, "azimuth"), (el_deg, "elevation")):
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise CommandRejected(f"{what} {v!r} is not a finite number", "invalid")
        g = self.core.geometry
        start = self.core.current_pose()
        pose = self.explicit_pose(az_deg, el_deg)
        if pose is not None:
            route = self.route_to_pose(pose)
        else:
            if not (-90.0 <= el_deg <= 90.0):
                raise CommandRejected(f"elevation {el_deg:g} outside -90..90", "limit")
            if not g.candidates(wrap360(az_deg), el_deg):
                raise CommandRejected(
                    f"position az {az_deg:g}, el {el_deg:g} outside the limits "
                    f"el {g.el_min_deg + g.el_offset_deg:g}..{g.el_max_deg + g.el_offset_deg:g}", "limit")
            route = g.plan(start, wrap360(az_deg), el_deg, self.core.rates())
        if route is None:
            zones = ", ".join(z.name for z in g.zones) or "none"
            raise CommandRejected(f"no legal path to az {az_deg:g}, el {el_deg:g}: the target or every "
                                  f"path to it lies in a keep-out zone ({zones})", "keepout")
        return route

    def route_to_pose(self, pose: tuple[float, float]) -> list[tuple[float, float]] | None:
        """A legal route (round keep-out zones) to one mechanical pose, or None."""
        g, start = self.core.geometry, self.core.current_pose()
        route = g.plan(start, *g.to_sky(*pose), self.core.rates())
        route = None if route is None else route[:-1] + [pose]
        if route is not None and g.segment_clear((route[-2] if len(route) > 1 else start), pose, self.core.rates()):
            route = None
        return route

    def check_axis(self, axis: str) -> None:
        if axis not in AXES:
            raise CommandRejected(f"axis must be az or el, got {axis!r}")
        if axis == "el":
            self.require_el("elevation")

    def geometry_for(self, settings: RotatorSettings) -> Geometry:
        """The settings' geometry with the sensors' own pointing offsets added to the
        mount offsets: a constant that turns bearings, not the axis (the G4JNT pot's Z,
        the bearing of its end-stop reference; see PotSensor), kept within +-180 so the
        extended frame stays near the axis'."""
        extra = {}
        for name in self.core.axes:
            z = getattr(self.core.axes[name].hw.sensor, "pointing_offset_deg", None)
            if isinstance(z, (int, float)) and math.isfinite(z) and z:
                extra[f"{name}_offset_deg"] = getattr(settings, f"{name}_offset_deg") + \
                    wrap180_deg(float(z))
        return replace(settings, **extra).geometry() if extra else settings.geometry()
