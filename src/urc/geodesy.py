"""Points on the WGS84 ellipsoid and where one lies seen from another: the geometry the
ground station and a geographic target (urc.tracking) and the BIG-RAS's NMEA points
(urc.protocols.gs232) share. Functions of plain numbers, below every package using them.

skyfield's WGS84 model gives the Earth-fixed (ITRS) position; numpy and skyfield are
imported only when a position is computed (checking one needs neither).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

#: what a geodetic position may hold: (name, lowest, highest); a longitude 180..360 is
#: east of 180, as some programs write it
RANGES = (("lat_deg", -90.0, 90.0), ("lon_deg", -180.0, 360.0), ("alt_m", -500.0, 100_000.0))


def position_problem(lat_deg: object, lon_deg: object, alt_m: object) -> str | None:
    """What is wrong with a geodetic position, in words ("lat_deg: expected a number in
    -90..90, found 123.0"), or None: each value a finite number (not a bool) in range."""
    for (key, lo, hi), value in zip(RANGES, (lat_deg, lon_deg, alt_m)):
        if not isinstance(value, (int, float)) or isinstance(value, bool) \
                or not math.isfinite(value) or not lo <= value <= hi:
            return f"{key}: expected a number in {lo:g}..{hi:g}, found {value!r}"
    return None


def itrs_km(lat_deg: float, lon_deg: float, alt_m: float) -> np.ndarray:
    """Earth-fixed (ITRS) position in km, from skyfield's WGS84 model."""
    import numpy as np
    from skyfield.api import wgs84

    return np.asarray(wgs84.latlon(lat_deg, lon_deg, elevation_m=alt_m).itrs_xyz.km, dtype=float)


def enu_rows(lat_deg: float, lon_deg: float) -> np.ndarray:
    """Rows: east, north, up unit vectors (ITRS) of the geodetic horizon at a place.

    skyfield keeps this rotation private; it is three lines of trigonometry.
    """
    import numpy as np

    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    return np.array([[-so, co, 0.0], [-sl * co, -sl * so, cl], [cl * co, cl * so, sl]])


def look_at(from_itrs_km: np.ndarray, from_enu: np.ndarray, to_itrs_km: np.ndarray) -> tuple[float, float, float]:
    """(azimuth, elevation, range_km) of a point seen from a place (its ITRS position and
    :func:`enu_rows`): geometric, no refraction."""
    import numpy as np

    d = to_itrs_km - from_itrs_km
    e, n, u = from_enu @ d
    az = math.degrees(math.atan2(e, n)) % 360.0
    el = math.degrees(math.atan2(u, math.hypot(e, n)))
    return az, el, float(np.linalg.norm(d))
