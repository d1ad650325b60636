"""A pass's predicted sky track for step-track (urc.peaking.steptrack): interpolated
from the plan, its sky rate, and where the satellite is seen when it runs a time offset
behind its elements along its orbit (the Earth turning meanwhile)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..angles import wrap180_deg

#: the Earth's rotation rate (rad/s, sidereal)
EARTH_RATE_RAD_S = 7.2921159e-5


class Prediction:
    """The plan's sky track (UTC), interpolated; the sky rate in the tangent frame.

    ``range_km`` (at the plan's times) and ``station`` (a urc.tracking.station.Station)
    make :meth:`seen` exact for an orbit: without them a time offset is a shift along
    the sky track alone."""

    def __init__(self, plan: Any, *, range_km: Any = None, station: Any = None):
        self.t = np.asarray(plan.t_s, dtype=float)
        self.az = np.unwrap(np.asarray(plan.sky_az_deg, dtype=float), period=360.0)
        self.el = np.asarray(plan.sky_el_deg, dtype=float)
        self.range_km = None if range_km is None or station is None else np.asarray(range_km, dtype=float)
        if self.range_km is not None:
            self._site, self._enu = np.asarray(station.itrs_km, dtype=float), np.asarray(station.enu, dtype=float)

    def at(self, u: Any) -> tuple[Any, Any]:
        return np.interp(u, self.t, self.az) % 360.0, np.interp(u, self.t, self.el)

    def seen(self, u: Any, time_offset_s: float) -> tuple[Any, Any]:
        """Where the satellite is at UTC ``u`` when it runs ``time_offset_s`` behind its
        elements along its orbit: where the elements put it at u - time_offset_s, in
        space, seen from the Earth as it has turned by then. (The Earth turns 0.125 deg
        in 30 s: seen from the ground, an along-track error is not a pure shift of the
        sky track in time; taken as one, 30 s read as 31.3-31.9 s on the ISS from Tartu.)"""
        az, el = self.at(np.asarray(u, dtype=float) - time_offset_s)
        if self.range_km is None or time_offset_s == 0.0:
            return az, el
        r = np.interp(np.asarray(u, dtype=float) - time_offset_s, self.t, self.range_km)
        a, e = np.radians(az), np.radians(el)
        local = np.stack([np.sin(a) * np.cos(e), np.cos(a) * np.cos(e), np.sin(e)], axis=-1) * np.expand_dims(r, -1)
        x = self._site + local @ self._enu              # Earth-fixed at u - time_offset_s
        th = -EARTH_RATE_RAD_S * time_offset_s        # the Earth turned on by time_offset_s
        c, s = math.cos(th), math.sin(th)
        x = np.stack([c * x[..., 0] - s * x[..., 1], s * x[..., 0] + c * x[..., 1], x[..., 2]], axis=-1)
        d = (x - self._site) @ self._enu.T
        az1 = np.degrees(np.arctan2(d[..., 0], d[..., 1])) % 360.0
        el1 = np.degrees(np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1])))
        return (az1, el1) if np.ndim(u) else (float(az1), float(el1))

    def earth_turn(self, u: Any, time_offset_s: float) -> tuple[Any, Any]:
        """:meth:`seen` minus the sky track shifted in time, as a sky (dx, dy), deg."""
        az0, el0 = self.at(np.asarray(u, dtype=float) - time_offset_s)
        az1, el1 = self.seen(u, time_offset_s)
        return wrap180_deg(az1 - az0) * np.cos(np.radians(el1)), el1 - el0

    def rate(self, u: float) -> tuple[float, float]:
        """(dx/dt, dy/dt) deg/s on the sky at ``u`` (dx across elevation)."""
        h = 1.0
        a0, e0 = np.interp(u - h, self.t, self.az), np.interp(u - h, self.t, self.el)
        a1, e1 = np.interp(u + h, self.t, self.az), np.interp(u + h, self.t, self.el)
        c = math.cos(math.radians(0.5 * (e0 + e1)))
        return float((a1 - a0) * c / (2 * h)), float((e1 - e0) / (2 * h))


def orbit_prediction(job: Any, station: Any) -> Prediction:
    """The pass's :class:`Prediction` with the satellite's range (its elements' at the
    plan's times): a time offset then moves the satellite along its orbit."""
    from ..tracking.propagate import look_angles

    la = look_angles(job.target.elements, station, np.asarray(job.plan.t_s, dtype=float))
    return Prediction(job.plan, range_km=la.range_km, station=station)
