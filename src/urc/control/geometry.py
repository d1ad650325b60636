"""Where the antenna may go: soft limits, cable wrap, flip, keep-out zones, and paths.

Two frames:

* mechanical (``az_m``, ``el_m``): what the axes and sensors know, the wrap range
  included (e.g. 0..450 deg), elevation up to 180 on rotators that can flip;
* sky (``az``, ``el``): compass azimuth 0..360 and elevation 0..90 where the beam points,
  after the mount offsets and the flip mapping (the boresight's direction), then the
  fitted pointing model (``pointing_deg``, issue 38; none by default): every command
  names, and every report gives, where the beam points.

Limits are mechanical (the axes' travel). Keep-out zones are regions of the sky, checked
where the beam points: the frame the user draws them in and sees every position in (the
model moves that frame by a degree or two at most; the zone margin is not meant to
absorb it). A path is checked by sampling the motion the axes
will really make (each axis at its own speed, so not a straight line), every sample
must stay inside the limits and out of every zone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from ..angles import wrap180_deg

#: path sampling step along the faster-changing axis, degrees.
PATH_STEP_DEG = 0.25
#: the pointing model's terms in tan E and sec E are taken at most at this elevation:
#: a first-order model is not meant for the zenith, where they grow without bound
#: (urc.pointing.model uses the same bound)
MODEL_MAX_EL_DEG = 85.0
#: the pointing model's terms in Geometry.pointing_deg's order (urc.pointing.model)
POINTING_TERMS = ("ia", "ie", "ca", "npae", "an", "aw", "tf")


def model_offsets_deg(terms: tuple[float, ...], az_deg: float, el_deg: float) -> tuple[float, float]:
    """The pointing model's (dA, dE) = boresight minus beam at the boresight's (az, el),
    ``terms`` = (IA, IE, CA, NPAE, AN, AW, TF) in degrees: urc.pointing.model's terms
    (that module's :func:`~urc.pointing.model.design` is the reference, with numpy; this
    is the scalar form the control loop uses, which must not import numpy)."""
    ia, ie, ca, npae, an, aw, tf = terms
    a = math.radians(az_deg)
    e = math.radians(min(max(el_deg, -MODEL_MAX_EL_DEG), MODEL_MAX_EL_DEG))
    sa, cos_a, te, ce = math.sin(a), math.cos(a), math.tan(e), math.cos(e)
    return (ia + ca / ce + npae * te + (an * sa + aw * cos_a) * te,
            ie + an * cos_a - aw * sa + tf * ce)


def _over_the_top(az_deg: float, el_deg: float) -> tuple[float, float]:
    """A direction past the zenith as the one it is: the other side, el below 90."""
    if el_deg > 90.0:
        az_deg, el_deg = az_deg + 180.0, 180.0 - el_deg
    return wrap360(az_deg), el_deg


def wrap360(az_deg: float) -> float:
    return az_deg % 360.0


@dataclass(frozen=True)
class KeepOut:
    name: str
    az_min_deg: float
    az_max_deg: float
    el_min_deg: float
    el_max_deg: float

    @property
    def az_width_deg(self) -> float:
        width = self.az_max_deg - self.az_min_deg
        return width + 360.0 if width <= 0.0 else width  # a sector across north (350..10)

    def contains(self, az_deg: float, el_deg: float, margin_deg: float = 0.0) -> bool:
        if not (self.el_min_deg - margin_deg <= el_deg <= self.el_max_deg + margin_deg):
            return False
        lo = wrap360(self.az_min_deg - margin_deg)
        width = self.az_width_deg + 2 * margin_deg
        if width >= 360.0:
            return True
        return (wrap360(az_deg) - lo) % 360.0 <= width

    def depth_deg(self, az_deg: float, el_deg: float, el_fixed: bool = False) -> float:
        """How far inside the zone a direction is (degrees to its nearest edge, along
        az or el); negative outside (minus the distance to the zone). ``el_fixed``: the
        elevation cannot move (a single-axis rotator), so only the azimuth can take the
        beam out of a zone whose elevation band holds it, and only it measures depth
        (on the band's edge, el 0 of a zone from the horizon, the depth was 0 whatever
        the azimuth: a turntable was let on deeper into a zone it stood in)."""
        width = self.az_width_deg
        rel = (wrap360(az_deg) - self.az_min_deg) % 360.0
        d_az = min(rel, width - rel) if rel <= width else -min(rel - width, 360.0 - rel)
        if self.el_min_deg <= el_deg <= self.el_max_deg:
            if el_fixed:
                return d_az
            d_el = min(el_deg - self.el_min_deg, self.el_max_deg - el_deg)
        else:
            d_el = -min(abs(el_deg - self.el_min_deg), abs(el_deg - self.el_max_deg))
        return min(d_az, d_el)


@dataclass(frozen=True)
class Geometry:
    az_min_deg: float
    az_max_deg: float
    el_min_deg: float
    el_max_deg: float
    az_offset_deg: float = 0.0
    el_offset_deg: float = 0.0
    #: a goto (or a track) of a sky direction may choose the flipped pose
    flip: bool = False
    #: the pass planner may fly a pass over the top (always when ``flip``)
    pass_flip: bool = False
    #: the sensors read a flipped pose as such (caps ``senses_flipped_pose``): a pass may
    #: then start on whichever side is reached sooner; else unflipped where as good
    flip_sensed: bool = False
    zones: tuple[KeepOut, ...] = field(default_factory=tuple)
    #: zones are grown by this much so sensor error and coasting cannot graze them.
    zone_margin_deg: float = 0.5
    #: the fitted pointing model (urc.pointing.model.TERMS order, degrees; () = none):
    #: where the beam points relative to the boresight
    pointing_deg: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.pointing_deg and not (len(self.pointing_deg) == 7 and all(
                isinstance(v, (int, float)) and math.isfinite(v) and abs(v) <= 10.0 for v in self.pointing_deg)):
            raise ValueError(f"pointing model: expected 7 finite terms within +-10 deg (IA IE CA NPAE AN AW TF), "
                             f"found {self.pointing_deg!r}")

    @property
    def can_fly_passes_flipped(self) -> bool:
        return self.flip or self.pass_flip

    # ---- frames -------------------------------------------------------------------
    def to_sky(self, az_m: float, el_m: float) -> tuple[float, float]:
        az, el = _over_the_top(az_m + self.az_offset_deg, el_m + self.el_offset_deg)
        return self.beam_of(az, el) if self.pointing_deg else (az, el)

    def beam_of(self, az_deg: float, el_deg: float) -> tuple[float, float]:
        """Where the beam points with the boresight at sky (az, el) (the model's forward)."""
        if not self.pointing_deg:
            return wrap360(az_deg), el_deg
        da, de = model_offsets_deg(self.pointing_deg, az_deg, el_deg)
        return _over_the_top(az_deg - da, el_deg - de)

    def boresight_of(self, az_deg: float, el_deg: float) -> tuple[float, float]:
        """The boresight's sky direction that puts the beam on sky (az, el): the model's
        inverse, the fixed point of b = beam + offsets(b) (a few iterations for terms of
        a few degrees; the terms' elevation bound keeps it contracting near the zenith)."""
        if not self.pointing_deg:
            return wrap360(az_deg), el_deg
        ab, eb = az_deg, el_deg
        for _ in range(50):
            da, de = model_offsets_deg(self.pointing_deg, ab, eb)
            nxt = (az_deg + da, el_deg + de)
            done = abs(nxt[0] - ab) < 1e-10 and abs(nxt[1] - eb) < 1e-10
            ab, eb = nxt
            if done:
                break
        return _over_the_top(ab, eb)

    def in_limits(self, az_m: float, el_m: float, slack_deg: float = 1e-6) -> bool:
        return (self.az_min_deg - slack_deg <= az_m <= self.az_max_deg + slack_deg
                and self.el_min_deg - slack_deg <= el_m <= self.el_max_deg + slack_deg)

    def zone_at(self, az_m: float, el_m: float, margin_deg: float | None = None) -> KeepOut | None:
        if not self.zones:
            return None
        az, el = self.to_sky(az_m, el_m)
        m = self.zone_margin_deg if margin_deg is None else margin_deg
        for z in self.zones:
            if z.contains(az, el, m):
                return z
        return None

    def deeper_into_zone(self, now: tuple[float, float], ahead: tuple[float, float],
                         margin_deg: float) -> KeepOut | None:
        """The zone that moving from pose ``now`` to pose ``ahead`` goes into: from
        outside into the zone grown by ``margin_deg``, or deeper into it from within."""
        sky_now, sky_ahead = self.to_sky(*now), self.to_sky(*ahead)
        el_fixed = self.el_min_deg == self.el_max_deg
        for z in self.zones:
            d_now, d_ahead = z.depth_deg(*sky_now, el_fixed), z.depth_deg(*sky_ahead, el_fixed)
            if d_ahead > -margin_deg and d_ahead > d_now + 1e-3:
                return z
        return None

    def candidates(self, az_deg: float, el_deg: float) -> list[tuple[float, float]]:
        """Every mechanical pose within the limits that points (the beam) at sky (az, el)."""
        az_deg, el_deg = self.boresight_of(az_deg, el_deg)
        poses = []
        options = [(az_deg, el_deg)]
        if self.flip:
            options.append((az_deg + 180.0, 180.0 - el_deg))
        for az_p, el_p in options:
            el_m = el_p - self.el_offset_deg
            if not (self.el_min_deg - 1e-9 <= el_m <= self.el_max_deg + 1e-9):
                continue
            base = az_p - self.az_offset_deg
            k = math.ceil((self.az_min_deg - base) / 360.0 - 1e-12)
            az_m = base + 360.0 * k
            while az_m <= self.az_max_deg + 1e-9:
                poses.append((min(max(az_m, self.az_min_deg), self.az_max_deg),
                              min(max(el_m, self.el_min_deg), self.el_max_deg)))
                az_m += 360.0
        return poses

    # ---- paths --------------------------------------------------------------------
    def segment_clear(self, start: tuple[float, float], end: tuple[float, float],
                      rates: tuple[float, float]) -> KeepOut | None:
        """The first zone the motion start->end enters (None if clear).

        Both axes start together at their own speeds. A start inside a zone is allowed
        as long as the motion leaves it and never enters one again.
        """
        if not self.zones:
            return None
        (a0, e0), (a1, e1) = start, end
        t_az, t_el = abs(a1 - a0) / rates[0], abs(e1 - e0) / rates[1]
        total = max(t_az, t_el)
        n = max(1, int(math.ceil(max(abs(a1 - a0), abs(e1 - e0)) / PATH_STEP_DEG)))
        been_outside = self.zone_at(a0, e0) is None
        # starting in a zone's safety margin (not in the zone itself) only allows leaving
        # the margin, never going into the zone
        start_in_core = self.zone_at(a0, e0, margin_deg=0.0) is not None
        for i in range(1, n + 1):
            t = total * i / n
            a = a0 + (a1 - a0) * (min(t, t_az) / t_az if t_az else 1.0)
            e = e0 + (e1 - e0) * (min(t, t_el) / t_el if t_el else 1.0)
            z = self.zone_at(a, e)
            if z is None:
                been_outside = True
            elif been_outside:
                return z
            elif not start_in_core and (core := self.zone_at(a, e, margin_deg=0.0)) is not None:
                return core
        return None

    def plan(self, start: tuple[float, float], az_deg: float, el_deg: float,
             rates: tuple[float, float]) -> list[tuple[float, float]] | None:
        """Fastest legal way to point at sky (az, el): a list of mechanical waypoints.

        Tries every wrap/flip pose, each flown directly, elevation first, azimuth first,
        or over the top of the zones in the way. None if nothing is legal.
        """
        inside = self.zone_at(*start, margin_deg=0.0)
        if inside is not None:
            # Starting inside a zone (switched on there, or pushed in): leave it straight
            # up, the least exposure, then plan from outside.
            exit_el = min(inside.el_max_deg - self.el_offset_deg + 2 * self.zone_margin_deg, self.el_max_deg)
            if exit_el <= start[1]:
                return None
            exit_pose = (start[0], exit_el)
            if self.zone_at(*exit_pose, margin_deg=0.0) is not None:
                return None
            rest = self.plan(exit_pose, az_deg, el_deg, rates)
            return None if rest is None else [exit_pose] + rest
        best: tuple[float, list[tuple[float, float]]] | None = None
        for pose in self.candidates(az_deg, el_deg):
            if self.zone_at(*pose, margin_deg=0.0) is not None:
                continue
            for route in self._routes(start, pose):
                if any(self.segment_clear(a, b, rates) for a, b in zip([start] + route, route)):
                    continue
                t = route_time_s([start] + route, rates)
                if pose[1] > 90.0:
                    t += 1e-3  # prefer the unflipped pose when it is just as fast
                if best is None or t < best[0] - 1e-9:
                    best = (t, route)
                break  # routes are tried simplest first
        return None if best is None else best[1]

    def _routes(self, start: tuple[float, float], end: tuple[float, float]):
        (a0, e0), (a1, e1) = start, end
        yield [end]
        yield [(a0, e1), end]
        yield [(a1, e0), end]
        top = max([z.el_max_deg for z in self.zones] + [e0, e1]) + 2 * self.zone_margin_deg + 1.0
        el_safe = min(top - self.el_offset_deg, self.el_max_deg)
        if el_safe > max(e0, e1):
            yield [(a0, el_safe), (a1, el_safe), end]

    def clear_until(self, start: tuple[float, float], axis: str, limit_deg: float) -> float:
        """Moving one axis from start towards limit_deg: how far it may go before a zone."""
        a0, e0 = start
        pos = a0 if axis == "az" else e0
        direction = 1.0 if limit_deg >= pos else -1.0
        n = int(abs(limit_deg - pos) / PATH_STEP_DEG)
        been_outside = self.zone_at(a0, e0) is None
        start_in_core = self.zone_at(a0, e0, margin_deg=0.0) is not None
        if start_in_core:
            # inside a zone: only the shortest way out, never deeper in
            lo, hi = (self.az_min_deg, self.az_max_deg) if axis == "az" else (self.el_min_deg, self.el_max_deg)
            here = self._exit_distance(start, axis, direction, hi if direction > 0 else lo)
            there = self._exit_distance(start, axis, -direction, lo if direction > 0 else hi)
            if here is None or (there is not None and there < here):
                return pos
        last_ok = pos
        for i in range(1, n + 2):
            p = pos + direction * min(i * PATH_STEP_DEG, abs(limit_deg - pos))
            pose = (p, e0) if axis == "az" else (a0, p)
            z = self.zone_at(*pose)
            if z is None:
                been_outside = True
                last_ok = p
            elif been_outside or (not start_in_core and self.zone_at(*pose, margin_deg=0.0) is not None):
                return last_ok
            else:
                last_ok = p
        return limit_deg

    def _exit_distance(self, start: tuple[float, float], axis: str, direction: float,
                       limit_deg: float) -> float | None:
        """How far one axis must move from inside a zone (core) to leave it, or None if
        it cannot before ``limit_deg``."""
        a0, e0 = start
        pos = a0 if axis == "az" else e0
        n = int(abs(limit_deg - pos) / PATH_STEP_DEG)
        for i in range(1, n + 2):
            d = min(i * PATH_STEP_DEG, abs(limit_deg - pos))
            p = pos + direction * d
            if self.zone_at(*((p, e0) if axis == "az" else (a0, p)), margin_deg=0.0) is None:
                return d
        return None


def route_time_s(points: list[tuple[float, float]], rates: tuple[float, float]) -> float:
    """Travel time along a route at full speed, both axes moving together."""
    return sum(max(abs(b[0] - a[0]) / rates[0], abs(b[1] - a[1]) / rates[1])
               for a, b in zip(points, points[1:]))


def declared_boresight(g: Geometry, values: dict, now: Any) -> dict:
    """A re-reference's declared beam directions (``values``: {"az", "el"}, None = not
    given) as the boresight's, under ``g``'s pointing model: the axis not given keeps
    where the beam points ``now`` (a Status), the azimuth its wrap turn. A flipped
    elevation (past 90) names a mechanical pose: taken as it is."""
    az = values["az"] if values["az"] is not None else now.az_deg
    el = values.get("el") if values.get("el") is not None else now.el_deg
    if az is None or el is None or not 0.0 <= el <= 90.0:
        return values
    b_az, b_el = g.boresight_of(wrap360(az), el)
    out = dict(values)
    if values["az"] is not None:
        out["az"] = values["az"] + wrap180_deg(b_az - wrap360(az))
    if values.get("el") is not None:
        out["el"] = b_el
    return out
