"""The ground station's position: from values, or from a GPS receiver's NMEA 0183 stream.

:class:`NmeaStation` is sans-I/O (h11 style): feed it whatever bytes the serial port gave
(any chunking, one byte at a time is fine) with the system time they arrived at; it
returns the fixes it completed, says whether the fix is valid and whether the system
clock agrees with GPS time. pynmea2 parses and checks each sentence.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, time as dtime, timedelta, timezone
from functools import cached_property

import numpy as np

from .. import geodesy
from .errors import StationError

__all__ = ["GpsFix", "NmeaStation", "Station"]

#: NMEA 0183 allows 82 characters a sentence; anything much longer is line noise.
_MAX_LINE = 200


@dataclass(frozen=True)
class Station:
    """A point on the WGS84 ellipsoid: geodetic latitude/longitude, height above it."""

    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0
    name: str = ""

    def __post_init__(self) -> None:
        problem = geodesy.position_problem(self.lat_deg, self.lon_deg, self.alt_m)
        if problem is not None:
            raise StationError(f"station {problem}")

    @cached_property
    def skyfield(self):
        """The station as a skyfield ``GeographicPosition`` (wgs84)."""
        from skyfield.api import wgs84

        return wgs84.latlon(self.lat_deg, self.lon_deg, elevation_m=self.alt_m)

    @cached_property
    def itrs_km(self) -> np.ndarray:
        """Earth-fixed (ITRS) position in km, from skyfield's WGS84 model."""
        return np.asarray(self.skyfield.itrs_xyz.km, dtype=float)

    @cached_property
    def enu(self) -> np.ndarray:
        """Rows: east, north, up unit vectors (ITRS) of the geodetic horizon."""
        return geodesy.enu_rows(self.lat_deg, self.lon_deg)

    @classmethod
    def from_fix(cls, fix: GpsFix, name: str = "") -> Station:
        if not fix.valid or fix.lat_deg is None or fix.lon_deg is None:
            raise StationError("the GPS has no valid fix yet (quality 0 / status V)")
        if fix.alt_m is None:
            raise StationError("the GPS fix has no altitude (RMC only); wait for a GGA sentence")
        return cls(fix.lat_deg, fix.lon_deg, fix.alt_m, name)


@dataclass(frozen=True)
class GpsFix:
    """One position report from the receiver (a GGA, or an RMC where no GGA came)."""

    lat_deg: float | None
    lon_deg: float | None
    alt_m: float | None
    #: the receiver says the position is usable (GGA quality > 0, RMC status A).
    valid: bool
    #: GPS time of the fix; None until a valid RMC has given the date.
    gps_time: datetime | None
    #: system clock (POSIX s) when the sentence arrived; None if the caller gave none.
    received_unix_s: float | None
    sentence: str = "GGA"
    quality: int | None = None
    num_sats: int | None = None
    hdop: float | None = None

    @property
    def clock_offset_s(self) -> float | None:
        """System clock minus GPS time (positive: the system clock is ahead)."""
        if self.gps_time is None or self.received_unix_s is None or not self.valid:
            return None
        return self.received_unix_s - self.gps_time.timestamp()

    def clock_ok(self, tolerance_s: float) -> bool | None:
        """True if the system clock agrees with GPS time within ``tolerance_s``; None if unknown."""
        off = self.clock_offset_s
        return None if off is None else abs(off) <= tolerance_s


@dataclass
class _Stats:
    sentences: int = 0
    bad: int = 0
    ignored: int = 0
    last_error: str = ""
    errors: list = field(default_factory=list)


class NmeaStation:
    """Sans-I/O NMEA 0183 reader giving the station position and a clock check.

    ``clock_tolerance_s`` allows for the receiver's output latency: sentences leave the
    receiver a few hundred milliseconds after the fix epoch and a 4800-baud burst takes
    up to a second.
    """

    def __init__(self, *, clock_tolerance_s: float = 2.0):
        self.clock_tolerance_s = float(clock_tolerance_s)
        self._buf = b""
        self._rmc_time: datetime | None = None
        self.last_fix: GpsFix | None = None
        self.last_valid_fix: GpsFix | None = None
        self.stats = _Stats()

    # -- input ---------------------------------------------------------------------

    def feed(self, data: bytes | str, received_unix_s: float | None = None) -> list[GpsFix]:
        """Take bytes from the receiver; return the fixes completed by them."""
        if isinstance(data, str):
            data = data.encode("ascii", "replace")
        self._buf += data
        fixes = []
        while b"\n" in self._buf:
            raw, self._buf = self._buf.split(b"\n", 1)
            fix = self._line(raw, received_unix_s)
            if fix is not None:
                fixes.append(fix)
        if len(self._buf) > _MAX_LINE:
            self._error(f"no end of line after {len(self._buf)} bytes; dropped them")
            self._buf = b""
        return fixes

    def _error(self, message: str) -> None:
        self.stats.bad += 1
        self.stats.last_error = message
        self.stats.errors = (self.stats.errors + [message])[-20:]

    def _line(self, raw: bytes, received_unix_s: float | None) -> GpsFix | None:
        import pynmea2

        text = raw.strip(b"\r\x00 ").decode("ascii", "replace")
        if not text:
            return None
        start = text.find("$")
        if start < 0:
            self._error(f"expected a sentence starting with '$', found {text[:30]!r}")
            return None
        text = text[start:]
        self.stats.sentences += 1
        try:
            msg = pynmea2.parse(text, check=True)
        except pynmea2.ChecksumError as exc:
            self._error(f"{text[:20]!r}...: {exc.args[0]}")
            return None
        except (pynmea2.ParseError, ValueError) as exc:
            self._error(f"{text[:20]!r}...: cannot parse: {exc.args[0] if exc.args else exc}")
            return None
        kind = getattr(msg, "sentence_type", "")
        try:
            if kind == "RMC":
                return self._rmc(msg, received_unix_s)
            if kind == "GGA":
                return self._gga(msg, received_unix_s)
        except (ValueError, TypeError) as exc:
            self._error(f"{text[:20]!r}...: bad field: {exc}")
            return None
        self.stats.ignored += 1
        return None

    def _rmc(self, msg, received_unix_s: float | None) -> GpsFix | None:
        valid = msg.status == "A"
        when = None
        if msg.datestamp is not None and msg.timestamp is not None:
            when = datetime.combine(msg.datestamp, _as_utc(msg.timestamp))
            if valid:
                self._rmc_time = when
        has_pos = bool(msg.lat) and bool(msg.lon)
        fix = GpsFix(msg.latitude if has_pos else None, msg.longitude if has_pos else None,
                     None, valid and has_pos, when, received_unix_s, "RMC")
        # A GGA carries the altitude; an RMC only stands in while no GGA has been seen.
        if self.last_fix is None or self.last_fix.sentence == "RMC":
            self._keep(fix)
        elif fix.valid and fix.gps_time is not None and self.last_valid_fix is not None:
            # refresh the clock check without losing the GGA altitude
            self._keep(GpsFix(fix.lat_deg, fix.lon_deg, self.last_valid_fix.alt_m, True,
                              fix.gps_time, received_unix_s, "RMC+GGA",
                              self.last_valid_fix.quality, self.last_valid_fix.num_sats,
                              self.last_valid_fix.hdop))
        return fix

    def _gga(self, msg, received_unix_s: float | None) -> GpsFix:
        quality = int(msg.gps_qual or 0)
        has_pos = bool(msg.lat) and bool(msg.lon)
        valid = quality > 0 and has_pos
        when = None
        if msg.timestamp is not None and self._rmc_time is not None:
            # GGA has no date: take the last valid RMC's, across midnight if need be. The
            # system clock is never used for it, or a clock a day off would look right.
            when = datetime.combine(self._rmc_time.date(), _as_utc(msg.timestamp))
            gap_s = (when - self._rmc_time).total_seconds()
            if gap_s < -43200:
                when += timedelta(days=1)
            elif gap_s > 43200:
                when -= timedelta(days=1)
        fix = GpsFix(msg.latitude if has_pos else None, msg.longitude if has_pos else None,
                     float(msg.altitude) if msg.altitude is not None and valid else None,
                     valid, when, received_unix_s, "GGA", quality,
                     int(msg.num_sats) if msg.num_sats else None,
                     float(msg.horizontal_dil) if msg.horizontal_dil else None)
        self._keep(fix)
        return fix

    def _keep(self, fix: GpsFix) -> None:
        self.last_fix = fix
        if fix.valid:
            self.last_valid_fix = fix

    # -- answers ---------------------------------------------------------------------

    @property
    def has_fix(self) -> bool:
        return self.last_fix is not None and self.last_fix.valid

    def station(self, name: str = "") -> Station:
        """The station at the last valid fix with an altitude."""
        fix = self.last_valid_fix
        if fix is None:
            raise StationError("no valid GPS fix yet"
                               + (f" ({self.stats.bad} bad sentences; last: "
                                  f"{self.stats.last_error})" if self.stats.bad else ""))
        return Station.from_fix(fix, name)

    @property
    def clock_offset_s(self) -> float | None:
        fix = self.last_valid_fix
        return None if fix is None else fix.clock_offset_s

    @property
    def clock_trustworthy(self) -> bool | None:
        """Whether the system clock agrees with GPS time; None when there is no valid time."""
        fix = self.last_valid_fix
        return None if fix is None else fix.clock_ok(self.clock_tolerance_s)


def _as_utc(t: dtime) -> dtime:
    return t if t.tzinfo is not None else t.replace(tzinfo=timezone.utc)
