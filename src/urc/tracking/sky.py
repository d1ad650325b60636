"""Offline sky data and time conversion shared by the tracking modules.

* :func:`timescale` and :func:`ephemeris` load skyfield's data from the files that ship
  with the ``skyfield-data`` package (``de421.bsp``, 1900-2050), never from the network.
* Times cross module boundaries as POSIX UTC seconds (``t_unix_s``, floats or arrays),
  as aware :class:`datetime.datetime` or as skyfield :class:`~skyfield.timelib.Time`;
  :func:`unix_s` accepts all three.
"""

from __future__ import annotations

import functools
import warnings
from datetime import datetime, timezone
from typing import Any

import numpy as np

#: Julian date of the POSIX epoch 1970-01-01T00:00:00 UTC.
JD_UNIX_EPOCH = 2440587.5
DAY_S = 86400.0
#: the JPL ephemeris shipped by skyfield-data (covers 1900-2050).
EPHEMERIS_FILE = "de421.bsp"


def data_path() -> str:
    """Directory of the files bundled with ``skyfield-data``."""
    import skyfield_data

    # skyfield-data warns that its copy of finals2000A.all (Earth orientation) has expired;
    # urc never reads that file (the timescale is skyfield's built-in one), so hush it.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return skyfield_data.get_skyfield_data_path()


@functools.lru_cache(maxsize=1)
def _loader():
    from skyfield.api import Loader

    return Loader(data_path(), verbose=False)


@functools.lru_cache(maxsize=1)
def timescale():
    """skyfield's timescale from its built-in leap-second and UT1 tables (no download)."""
    return _loader().timescale(builtin=True)


@functools.lru_cache(maxsize=1)
def ephemeris():
    """The offline JPL ephemeris (``de421.bsp`` from skyfield-data)."""
    return _loader()(EPHEMERIS_FILE)


def unix_s(t: Any) -> Any:
    """POSIX UTC seconds (float or float array) from a time in any accepted form.

    ``t`` may be a number or array of POSIX seconds, an aware ``datetime`` (or a sequence
    of them) or a skyfield ``Time``. Naive datetimes are refused: they are ambiguous.
    """
    if isinstance(t, datetime):
        return _dt_unix_s(t)
    if hasattr(t, "ut1_fraction") and hasattr(t, "whole"):  # a skyfield Time
        return (t.whole - JD_UNIX_EPOCH) * DAY_S + t.ut1_fraction * DAY_S - t.dut1
    if isinstance(t, (list, tuple)) and t and isinstance(t[0], datetime):
        return np.array([_dt_unix_s(x) for x in t])
    if isinstance(t, (int, float, np.floating, np.integer)):
        return float(t)
    return np.asarray(t, dtype=float)


def _dt_unix_s(t: datetime) -> float:
    if t.tzinfo is None or t.utcoffset() is None:
        raise TypeError(f"naive datetime {t.isoformat()} is ambiguous; give it a time zone "
                        "(e.g. tzinfo=timezone.utc)")
    return t.timestamp()


def utc_datetime(t_unix_s: float) -> datetime:
    """Aware UTC datetime for POSIX seconds."""
    return datetime.fromtimestamp(float(t_unix_s), tz=timezone.utc)


def to_time(t: Any):
    """skyfield ``Time`` for any accepted time (array in, array out)."""
    if hasattr(t, "ut1_fraction") and hasattr(t, "whole"):
        return t
    u = unix_s(t)
    # Split into whole days + seconds: skyfield then applies the leap seconds of the day
    # itself (passing all seconds since 1970 would be off by the 27 s since then).
    days = np.floor(np.asarray(u) / DAY_S)
    return timescale().utc(1970, 1, 1 + days, 0, 0, u - days * DAY_S)


def sgp4_jd(t_unix_s: Any) -> tuple[Any, Any]:
    """``(jd, fr)`` UTC Julian date split as sgp4 wants it (full precision)."""
    u = np.asarray(t_unix_s, dtype=float)
    days = np.floor(u / DAY_S)
    return JD_UNIX_EPOCH + days, (u - days * DAY_S) / DAY_S


def dut1_s(t_unix_s: Any) -> Any:
    """UT1 - UTC in seconds from skyfield's built-in IERS table.

    A few times at once (a tracking loop asking 50 times a second) are interpolated
    between hourly values kept in a cache: UT1 - UTC drifts about a millisecond a day,
    and building a skyfield Time costs more than the whole SGP4 evaluation.
    """
    u = np.asarray(t_unix_s, dtype=float)
    if u.size > 16:
        return to_time(u).dut1
    hour = np.floor(u / 3600.0)
    out = np.empty(u.shape)
    for i, (h, x) in enumerate(zip(hour.ravel().tolist(), u.ravel().tolist())):
        d0, d1 = _dut1_at_hour(h), _dut1_at_hour(h + 1.0)
        if abs(d1 - d0) > 0.5:  # a leap second in this hour: no interpolating across it
            out.flat[i] = float(to_time(x).dut1)
        else:
            out.flat[i] = d0 + (d1 - d0) * (x / 3600.0 - h)
    return out if u.ndim else float(out)


@functools.lru_cache(maxsize=256)
def _dut1_at_hour(hour: float) -> float:
    return float(to_time(hour * 3600.0).dut1)


def gmst82(t_unix_s: Any, dut1: Any = None) -> tuple[Any, Any]:
    """Greenwich mean sidereal angle of the TEME frame (rad) and its rate (rad/s).

    The 1982 GMST that defines SGP4's TEME frame, via skyfield's own implementation so
    both agree to the last bit; ``dut1`` (UT1-UTC, s) is looked up when not given.
    """
    from skyfield.sgp4lib import theta_GMST1982

    if dut1 is None:
        dut1 = dut1_s(t_unix_s)
    jd, fr = sgp4_jd(t_unix_s)
    theta, theta_dot_per_day = theta_GMST1982(jd, fr + np.asarray(dut1) / DAY_S)
    return theta, theta_dot_per_day / DAY_S
