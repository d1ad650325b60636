"""Things the antenna can follow, all with one interface.

Every target has a ``name`` and answers ``position(t) -> (az_deg, el_deg)`` and
``rate(t) -> (az_rate_deg_per_s, el_rate_deg_per_s)`` for a time ``t`` in any form
:func:`urc.tracking.sky.unix_s` accepts (POSIX seconds, aware datetime, skyfield Time).
Azimuth is compass degrees 0..360; the rotator service maps it onto its own range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from .. import geodesy
from . import sky
from .elements import Catalog, ElementSet
from .errors import StationError, TargetError
from .propagate import LookAngles, look_angles, moon_look_angles, sun_look_angles
from .station import Station
from ..angles import wrap180_deg

__all__ = ["FixedTarget", "GeoPointTarget", "GeoReport", "MoonTarget", "NmeaTarget",
           "SatelliteTarget", "SunTarget", "Target", "parse_target"]


@runtime_checkable
class Target(Protocol):
    name: str

    def position(self, t: Any) -> tuple[float, float]:
        """``(az_deg, el_deg)`` at ``t``."""

    def rate(self, t: Any) -> tuple[float, float]:
        """``(az_rate_deg_per_s, el_rate_deg_per_s)`` at ``t``."""


def _pair(la: LookAngles) -> tuple[float, float]:
    return float(la.az_deg), float(la.el_deg)


class SatelliteTarget:
    """A satellite by its element set, propagated with SGP4."""

    def __init__(self, elements: ElementSet, station: Station, *, refraction: bool = False):
        self.elements = elements
        self.station = station
        self.refraction = refraction
        self.name = elements.label

    @classmethod
    def from_catalog(cls, catalog: Catalog, key: str | int, station: Station,
                     **kw: Any) -> SatelliteTarget:
        """By name (any case, unique prefix) or NORAD id."""
        return cls(catalog.get(key), station, **kw)

    def look(self, t: Any) -> LookAngles:
        la = look_angles(self.elements, self.station, t, refraction=self.refraction)
        if np.any(la.error):
            raise TargetError(f"{self.name}: sgp4 cannot propagate to this time: "
                              f"{', '.join(sorted(la.error_messages()))}")
        return la

    def position(self, t: Any) -> tuple[float, float]:
        return _pair(self.look(t))

    def rate(self, t: Any) -> tuple[float, float]:
        la = self.look(t)
        return float(la.az_rate_deg_per_s), float(la.el_rate_deg_per_s)


#: The Sun and the Moon are followed from a table of their look angles, made in one
#: vectorised skyfield call: one apparent place costs ~8 ms on a PC and ~10x that on a Pi
#: Zero, and the tracker asks for a position and a rate every 0.2 s on the I/O
#: process's event loop. Knots every BODY_KNOT_S (aligned to UTC, so a time on a knot is
#: skyfield's own answer), a new table every BODY_TABLE_S; between knots a cubic Hermite
#: through the angles and the rates skyfield gives with them (numpy by hand: scipy's
#: CubicHermiteSpline would be a 40 MB dependency for these few lines). Great-circle
#: error under 1e-5 deg, rates under 1e-6 deg/s (tests/tracking/test_targets.py).
BODY_KNOT_S = 10.0
BODY_TABLE_S = 600.0


class _BodyTable:
    """Look angles of a body at knots ``t0_s + k * BODY_KNOT_S``; ``at(u)`` interpolates."""

    def __init__(self, look, u: float):
        self.t0_s = math.floor(u / BODY_KNOT_S) * BODY_KNOT_S
        t = self.t0_s + BODY_KNOT_S * np.arange(int(BODY_TABLE_S / BODY_KNOT_S) + 1)
        la = look(t)
        self.end_s = float(t[-1])
        # the azimuth unwrapped along the table (a body crossing north stays continuous)
        self.az = np.unwrap(np.asarray(la.az_deg, dtype=float), period=360.0)
        self.el = np.asarray(la.el_deg, dtype=float)
        self.az_rate = np.asarray(la.az_rate_deg_per_s, dtype=float)
        self.el_rate = np.asarray(la.el_rate_deg_per_s, dtype=float)

    def covers(self, u: float) -> bool:
        return self.t0_s <= u <= self.end_s

    def at(self, u: float) -> tuple[float, float, float, float]:
        """``(az_deg, el_deg, az_rate_deg_per_s, el_rate_deg_per_s)`` at ``u``."""
        h = BODY_KNOT_S
        k = min(int((u - self.t0_s) // h), len(self.az) - 2)
        s = (u - self.t0_s - k * h) / h
        az, az_rate = _hermite(self.az[k], self.az[k + 1], self.az_rate[k], self.az_rate[k + 1], s, h)
        el, el_rate = _hermite(self.el[k], self.el[k + 1], self.el_rate[k], self.el_rate[k + 1], s, h)
        return az % 360.0, el, az_rate, el_rate


def _hermite(p0: float, p1: float, m0: float, m1: float, s: float, h: float) -> tuple[float, float]:
    """The cubic through values ``p0``, ``p1`` with slopes ``m0``, ``m1`` (per second) at
    the ends of a knot interval ``h`` s long, at fraction ``s``: value and slope."""
    s2, s3 = s * s, s * s * s
    value = (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * h * m0 + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * h * m1
    slope = ((6 * s2 - 6 * s) * p0 + (3 * s2 - 4 * s + 1) * h * m0 + (-6 * s2 + 6 * s) * p1
             + (3 * s2 - 2 * s) * h * m1) / h
    return float(value), float(slope)


class _Body:
    body = ""

    def __init__(self, station: Station, *, refraction: bool = False):
        self.station = station
        self.refraction = refraction
        self.name = self.body.capitalize()
        self._table: _BodyTable | None = None

    def look(self, t: Any) -> LookAngles:
        """skyfield's own answer at ``t`` (any shape): for plans over many times."""
        fn = sun_look_angles if self.body == "sun" else moon_look_angles
        return fn(self.station, t, refraction=self.refraction)

    def _at(self, t: Any) -> tuple[float, float, float, float]:
        u = sky.unix_s(t)
        if not isinstance(u, float):
            la = self.look(u)
            return (float(la.az_deg), float(la.el_deg), float(la.az_rate_deg_per_s),
                    float(la.el_rate_deg_per_s))
        if self._table is None or not self._table.covers(u):
            self._table = _BodyTable(self.look, u)
        return self._table.at(u)

    def position(self, t: Any) -> tuple[float, float]:
        return self._at(t)[:2]

    def rate(self, t: Any) -> tuple[float, float]:
        return self._at(t)[2:]


class SunTarget(_Body):
    """The Sun (apparent place, from the offline JPL ephemeris)."""

    body = "sun"


class MoonTarget(_Body):
    """The Moon (apparent place, from the offline JPL ephemeris); for EME work."""

    body = "moon"


class FixedTarget:
    """A fixed direction (a beacon, a test tower, the park position)."""

    def __init__(self, az_deg: float, el_deg: float, name: str = ""):
        if not (math.isfinite(az_deg) and math.isfinite(el_deg) and -90.0 <= el_deg <= 180.0):
            raise TargetError(f"fixed target: expected finite az and el in -90..180 degrees, "
                              f"found az {az_deg!r}, el {el_deg!r}")
        self.az_deg = float(az_deg) % 360.0
        self.el_deg = float(el_deg)
        self.name = name or f"az {self.az_deg:g} el {self.el_deg:g}"

    def position(self, t: Any = None) -> tuple[float, float]:
        return self.az_deg, self.el_deg

    def rate(self, t: Any = None) -> tuple[float, float]:
        return 0.0, 0.0


def _look_at_point(station: Station, itrs_km: np.ndarray) -> tuple[float, float, float]:
    return geodesy.look_at(station.itrs_km, station.enu, itrs_km)


class GeoPointTarget:
    """A place on or above the Earth (a repeater, a mountain top, another station)."""

    def __init__(self, station: Station, lat_deg: float, lon_deg: float, alt_m: float = 0.0,
                 name: str = ""):
        try:
            Station(lat_deg, lon_deg, alt_m)  # same range checks as a station
        except StationError as exc:
            raise TargetError(f"geographic target: {exc}") from None
        self.station = station
        self.lat_deg, self.lon_deg, self.alt_m = float(lat_deg), float(lon_deg), float(alt_m)
        self.name = name or f"{lat_deg:.5f},{lon_deg:.5f}"
        self.az_deg, self.el_deg, self.range_km = _look_at_point(
            station, geodesy.itrs_km(lat_deg, lon_deg, alt_m))

    def position(self, t: Any = None) -> tuple[float, float]:
        return self.az_deg, self.el_deg

    def rate(self, t: Any = None) -> tuple[float, float]:
        return 0.0, 0.0


@dataclass(frozen=True)
class GeoReport:
    """One position report of a moving target."""

    t_unix_s: float
    lat_deg: float
    lon_deg: float
    alt_m: float


class NmeaTarget:
    """A moving target (a balloon) reporting NMEA GGA sentences; sans-I/O.

    ``feed`` takes the bytes as they arrive with the system time; ``position(t)`` predicts
    linearly (in Earth-fixed coordinates) from the last two reports, at most
    ``max_extrapolation_s`` past the last one. The GGA time of day is the fix time; its
    date is the one that puts it nearest to the receive time.
    """

    def __init__(self, station: Station, *, max_extrapolation_s: float = 60.0,
                 name: str = "NMEA target"):
        self.station = station
        self.max_extrapolation_s = float(max_extrapolation_s)
        self.name = name
        self.reports: list[GeoReport] = []
        self._buf = b""
        self.bad_sentences = 0
        self.last_error = ""

    def feed(self, data: bytes | str, received_unix_s: float) -> list[GeoReport]:
        import pynmea2

        if isinstance(data, str):
            data = data.encode("ascii", "replace")
        self._buf += data
        new = []
        while b"\n" in self._buf:
            raw, self._buf = self._buf.split(b"\n", 1)
            text = raw.strip(b"\r\x00 ").decode("ascii", "replace")
            start = text.find("$")
            if start < 0:
                continue
            try:
                msg = pynmea2.parse(text[start:], check=True)
            except (pynmea2.ParseError, ValueError) as exc:
                self.bad_sentences += 1
                why = exc.args[0] if exc.args else exc
                self.last_error = f"{text[start:start + 20]!r}...: {why}"
                continue
            if getattr(msg, "sentence_type", "") != "GGA" or not int(msg.gps_qual or 0) \
                    or not msg.lat or msg.timestamp is None:
                continue
            rep = GeoReport(_fix_time(msg.timestamp, received_unix_s), msg.latitude,
                            msg.longitude, float(msg.altitude or 0.0))
            if self.reports and rep.t_unix_s <= self.reports[-1].t_unix_s:
                continue  # a repeat or out of order: keep time moving forward
            self.reports = (self.reports + [rep])[-2:]
            new.append(rep)
        if len(self._buf) > 200:
            self._buf = b""
        return new

    def _predict_km(self, t_unix_s: float) -> np.ndarray:
        if not self.reports:
            raise TargetError(f"{self.name}: no position report yet")
        last = self.reports[-1]
        age_s = t_unix_s - last.t_unix_s
        if age_s > self.max_extrapolation_s:
            raise TargetError(f"{self.name}: the last report is {age_s:.0f} s old; not "
                              f"predicting more than {self.max_extrapolation_s:g} s ahead")
        p1 = geodesy.itrs_km(last.lat_deg, last.lon_deg, last.alt_m)
        if len(self.reports) < 2:
            return p1
        prev = self.reports[0]
        p0 = geodesy.itrs_km(prev.lat_deg, prev.lon_deg, prev.alt_m)
        v = (p1 - p0) / (last.t_unix_s - prev.t_unix_s)
        return p1 + v * age_s

    def position(self, t: Any) -> tuple[float, float]:
        az, el, _ = _look_at_point(self.station, self._predict_km(float(sky.unix_s(t))))
        return az, el

    def range_km(self, t: Any) -> float:
        return _look_at_point(self.station, self._predict_km(float(sky.unix_s(t))))[2]

    def rate(self, t: Any) -> tuple[float, float]:
        u = float(sky.unix_s(t))
        az0, el0, _ = _look_at_point(self.station, self._predict_km(u - 0.5))
        az1, el1, _ = _look_at_point(self.station, self._predict_km(u + 0.5))
        return wrap180_deg(az1 - az0), el1 - el0


def _fix_time(tod, received_unix_s: float) -> float:
    """POSIX time of GGA time-of-day ``tod`` on the date nearest the receive time."""
    day_s = math.floor(received_unix_s / 86400.0) * 86400.0
    t = day_s + tod.hour * 3600 + tod.minute * 60 + tod.second + tod.microsecond / 1e6
    return min((t - 86400.0, t, t + 86400.0), key=lambda c: abs(c - received_unix_s))


def parse_target(spec: str, station: Station, catalog: Catalog | None = None) -> Target:
    """A target from a short text: ``sun``, ``moon``, ``azel:AZ,EL``,
    ``geo:LAT,LON[,ALT_M]``, or a satellite name / NORAD id (``sat:`` optional)."""
    text = spec.strip()
    low = text.lower()
    if low in ("sun", "moon"):
        return SunTarget(station) if low == "sun" else MoonTarget(station)
    kind, _, rest = text.partition(":")
    kind = kind.lower()
    if kind in ("azel", "geo"):
        try:
            nums = [float(x) for x in rest.split(",")]
        except ValueError:
            nums = []
        if kind == "azel" and len(nums) == 2:
            return FixedTarget(nums[0], nums[1])
        if kind == "geo" and len(nums) in (2, 3):
            return GeoPointTarget(station, nums[0], nums[1], nums[2] if len(nums) == 3 else 0.0)
        form = "azel:AZ,EL" if kind == "azel" else "geo:LAT,LON[,ALT_M]"
        raise TargetError(f"target {spec!r}: expected {form} with numbers, found {rest!r}")
    name = rest if kind == "sat" else text
    if catalog is None:
        raise TargetError(f"target {spec!r}: a satellite needs a catalog; expected sun, moon, "
                          "azel:AZ,EL or geo:LAT,LON[,ALT_M] otherwise")
    return SatelliteTarget.from_catalog(catalog, name, station)
