"""Vectorised topocentric look angles: satellites with SGP4, the Sun and Moon with skyfield.

Satellites: sgp4 (``Satrec.sgp4_array`` / ``SatrecArray``) gives TEME states for a whole
time array (or catalog x time array) in one call; numpy rotates them to the Earth-fixed
frame with skyfield's GMST-1982 angle (TEME -> PEF, polar motion ignored as skyfield does
by default) and projects them on the station's geodetic horizon. The result matches
skyfield's ``(sat - topos).at(t).altaz()`` to ~1e-7 degrees at a fraction of the cost.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Sequence

import numpy as np
from sgp4.api import SGP4_ERRORS, Satrec, SatrecArray

from . import sky
from .elements import ElementSet
from .station import Station

__all__ = ["LookAngles", "look_angles", "look_angles_many", "moon_look_angles",
           "sun_look_angles", "teme_states"]

_RAD = np.pi / 180.0
_DEG = 180.0 / np.pi


@dataclass(frozen=True)
class LookAngles:
    """Where a target is seen from the station; arrays shaped like the request.

    Angles in degrees (azimuth from north through east, 0..360), rates per second,
    range in km. ``error`` is sgp4's error code per sample (0 = fine; the other values
    are NaN where it is not).
    """

    az_deg: np.ndarray
    el_deg: np.ndarray
    range_km: np.ndarray
    range_rate_km_per_s: np.ndarray
    az_rate_deg_per_s: np.ndarray
    el_rate_deg_per_s: np.ndarray
    error: np.ndarray

    def error_messages(self) -> set[str]:
        return {SGP4_ERRORS.get(int(e), f"error {int(e)}") for e in np.unique(self.error) if e}


def _satrec(sat: ElementSet | Satrec) -> Satrec:
    return sat.satrec if isinstance(sat, ElementSet) else sat


def teme_states(sats: ElementSet | Satrec | Sequence[ElementSet | Satrec], t: Any):
    """``(error, r_km, v_km_per_s)`` in TEME straight from sgp4.

    One satellite: shapes ``(n,)``, ``(n, 3)``; a sequence: ``(n_sats, n)``, ``(n_sats, n, 3)``.
    """
    u = np.atleast_1d(sky.unix_s(t)).ravel()
    jd, fr = sky.sgp4_jd(u)
    if isinstance(sats, (ElementSet, Satrec)):
        return _satrec(sats).sgp4_array(jd, fr)
    return SatrecArray([_satrec(s) for s in sats]).sgp4(jd, fr)


def teme_to_itrs(r_km, v_km_per_s, theta_rad, theta_dot_rad_per_s):
    """Rotate TEME states to the Earth-fixed frame (pseudo-Earth-fixed, no polar motion).

    ``theta`` broadcasts against the leading axes of ``r``; velocities become Earth-relative.
    """
    c, s = np.cos(theta_rad), np.sin(theta_rad)
    x = c * r_km[..., 0] + s * r_km[..., 1]
    y = -s * r_km[..., 0] + c * r_km[..., 1]
    w = theta_dot_rad_per_s
    vx = c * v_km_per_s[..., 0] + s * v_km_per_s[..., 1] + w * y
    vy = -s * v_km_per_s[..., 0] + c * v_km_per_s[..., 1] - w * x
    return (x, y, r_km[..., 2]), (vx, vy, v_km_per_s[..., 2])


def _enu(station: Station, r, v):
    """East/north/up components of the line of sight and of its rate."""
    s = station.itrs_km
    d = (r[0] - s[0], r[1] - s[1], r[2] - s[2])
    rows = station.enu
    comp = [rows[i, 0] * d[0] + rows[i, 1] * d[1] + rows[i, 2] * d[2] for i in range(3)]
    rate = [rows[i, 0] * v[0] + rows[i, 1] * v[1] + rows[i, 2] * v[2] for i in range(3)]
    return comp, rate


def _look(station: Station, r_teme, v_teme, err, u, refraction: bool, temperature_c: float,
          pressure_mbar: float) -> LookAngles:
    theta, theta_dot = sky.gmst82(u)
    r, v = teme_to_itrs(r_teme, v_teme, theta, theta_dot)
    (e, n, z), (ed, nd, zd) = _enu(station, r, v)
    hor2 = e * e + n * n
    hor = np.sqrt(hor2)
    rng = np.sqrt(hor2 + z * z)
    rng_rate = (e * ed + n * nd + z * zd) / rng
    el = np.arctan2(z, hor) * _DEG
    az = np.mod(np.arctan2(e, n) * _DEG, 360.0)
    # d(el)/dt = (z' rho - z rho') / (rho * horizontal distance); d(az)/dt from atan2(e, n)
    with np.errstate(divide="ignore", invalid="ignore"):
        el_rate = (zd * rng - z * rng_rate) / (rng * hor) * _DEG
        az_rate = (ed * n - nd * e) / hor2 * _DEG
    if refraction:
        el = _refract(el, temperature_c, pressure_mbar)
    bad = err != 0
    if np.any(bad):
        for a in (az, el, rng, rng_rate, az_rate, el_rate):
            a[bad] = np.nan
    return LookAngles(az, el, rng, rng_rate, az_rate, el_rate, err)


def _refract(el_deg, temperature_c: float, pressure_mbar: float):
    """Apparent elevation: skyfield's refraction model (Bennett), zero below -1 degree."""
    from skyfield.earthlib import refract

    return refract(np.asarray(el_deg, dtype=float), temperature_c, pressure_mbar)


def _reshape(la: LookAngles, shape: tuple) -> LookAngles:
    if shape == la.az_deg.shape:
        return la
    fields = [np.reshape(getattr(la, k), shape) for k in LookAngles.__dataclass_fields__]
    if shape == ():
        fields = [f[()] for f in fields]
    return LookAngles(*fields)


def look_angles(sat: ElementSet | Satrec, station: Station, t: Any, *, refraction: bool = False,
                temperature_c: float = 10.0, pressure_mbar: float = 1010.0) -> LookAngles:
    """Look angles of one satellite for a time or an array of times.

    ``refraction`` gives the apparent elevation (what an antenna should point at at
    optical frequencies, and near enough at radio ones); rates are geometric.
    """
    u = sky.unix_s(t)
    shape = np.shape(u)
    uf = np.atleast_1d(u).astype(float).ravel()
    jd, fr = sky.sgp4_jd(uf)
    err, r, v = _satrec(sat).sgp4_array(jd, fr)
    la = _look(station, r, v, err, uf, refraction, temperature_c, pressure_mbar)
    return _reshape(la, shape)


def look_angles_many(sats: Iterable[ElementSet | Satrec], station: Station, t: Any, *,
                     refraction: bool = False, temperature_c: float = 10.0,
                     pressure_mbar: float = 1010.0) -> LookAngles:
    """Look angles of many satellites at once: arrays shaped ``(n_sats, n_times)``."""
    u = np.atleast_1d(sky.unix_s(t)).astype(float).ravel()
    jd, fr = sky.sgp4_jd(u)
    err, r, v = SatrecArray([_satrec(s) for s in sats]).sgp4(jd, fr)
    return _look(station, r, v, err, u[np.newaxis, :], refraction, temperature_c, pressure_mbar)


def _body_look(body: str, station: Station, t: Any, refraction: bool, temperature_c: float,
               pressure_mbar: float) -> LookAngles:
    eph = sky.ephemeris()
    time = sky.to_time(t)
    app = (eph["earth"] + station.skyfield).at(time).observe(eph[body]).apparent()
    alt, az, dist, alt_rate, az_rate, range_rate = app.frame_latlon_and_rates(station.skyfield)
    el = alt.degrees
    if refraction:
        el = app.altaz(temperature_C=temperature_c, pressure_mbar=pressure_mbar)[0].degrees
    shape = np.shape(el)
    return LookAngles(np.asarray(az.degrees), np.asarray(el), np.asarray(dist.km),
                      np.asarray(range_rate.km_per_s), np.asarray(az_rate.degrees.per_second),
                      np.asarray(alt_rate.degrees.per_second), np.zeros(shape, dtype=int))


def sun_look_angles(station: Station, t: Any, *, refraction: bool = False,
                    temperature_c: float = 10.0, pressure_mbar: float = 1010.0) -> LookAngles:
    """The Sun's apparent position (light time, aberration) from the station, via skyfield."""
    return _body_look("sun", station, t, refraction, temperature_c, pressure_mbar)


def moon_look_angles(station: Station, t: Any, *, refraction: bool = False,
                     temperature_c: float = 10.0, pressure_mbar: float = 1010.0) -> LookAngles:
    """The Moon's apparent position from the station, via skyfield."""
    return _body_look("moon", station, t, refraction, temperature_c, pressure_mbar)
