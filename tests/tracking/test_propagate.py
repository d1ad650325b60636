"""Propagation against outside authorities: Vallado's SGP4 verification vectors (shipped
with the sgp4 package) and skyfield's own topocentric pipeline."""

from __future__ import annotations

import math
import os
from datetime import datetime, timedelta, timezone

import numpy as np
import pytest
import sgp4
from skyfield.api import EarthSatellite

from urc.tracking import sky
from urc.tracking.elements import parse_tle
from urc.tracking.propagate import look_angles, look_angles_many, moon_look_angles, \
    sun_look_angles, teme_states
from urc.tracking.station import Station

from .conftest import T0, T0_UNIX_S

#: Vallado's tcppver.out prints 8 decimals of km; our time conversion (epoch + minutes as
#: POSIX seconds) costs up to ~1e-7 s, i.e. < 1 mm at 8 km/s.
TCPPVER_TOL_KM = 1e-5
TCPPVER_TOL_KM_PER_S = 1e-8
#: Vallado's case 33333 (e = 0.995, built to trip error 4) amplifies that 1e-7 s ~1000x.
TCPPVER_SENSITIVE = {33333: 1000.0}
#: our numpy TEME -> topocentric chain against skyfield's (same GMST-82, same WGS84).
AZEL_TOL_DEG = 1e-6
RANGE_TOL_KM = 1e-6
RATE_TOL_DEG_PER_S = 1e-6
RANGE_RATE_TOL_KM_PER_S = 1e-6

SGP4_DIR = os.path.dirname(sgp4.__file__)


def _vallado_cases():
    """(line1, line2, [(tsince_min, r_km, v_km_per_s), ...]) from SGP4-VER.TLE + tcppver.out."""
    tle = [ln for ln in open(os.path.join(SGP4_DIR, "SGP4-VER.TLE")).read().splitlines()
           if ln.startswith(("1 ", "2 "))]
    out: dict[int, list] = {}
    cur = None
    for ln in open(os.path.join(SGP4_DIR, "tcppver.out")).read().splitlines():
        f = ln.split()
        if len(f) == 2 and f[1] == "xx":
            cur = out.setdefault(int(f[0]), [])
        elif len(f) >= 7 and cur is not None:
            cur.append((float(f[0]), np.array(f[1:4], float), np.array(f[4:7], float)))
    for l1, l2 in zip(tle[0::2], tle[1::2]):
        yield l1[:69], l2[:69], out[int(l1[2:7])]


def test_vallado_reference_vectors():
    """Every case of Vallado's verification file, read by our TLE parser (checksums off:
    some lines are deliberately bad) and propagated through ``teme_states``."""
    n_points = 0
    for l1, l2, rows in _vallado_cases():
        (es,) = parse_tle(f"{l1}\n{l2}\n", "SGP4-VER.TLE", checksum=False)
        sat = es.satrec
        epoch_unix_s = (sat.jdsatepoch - 2440587.5) * 86400.0 + sat.jdsatepochF * 86400.0
        t = np.array([epoch_unix_s + row[0] * 60.0 for row in rows])
        err, r, v = teme_states(es, t)
        for i, (tsince, r_ref, v_ref) in enumerate(rows):
            if err[i]:
                continue  # Vallado's file ends a case at its first error too
            scale = TCPPVER_SENSITIVE.get(es.norad_id, 1.0)
            assert np.abs(r[i] - r_ref).max() < TCPPVER_TOL_KM * scale, (es.norad_id, tsince)
            assert np.abs(v[i] - v_ref).max() < TCPPVER_TOL_KM_PER_S * scale, \
                (es.norad_id, tsince)
            n_points += 1
    assert n_points > 500


def _skyfield_topo(es, station, t):
    sat = EarthSatellite.from_satrec(es.satrec, sky.timescale())
    return (sat - station.skyfield).at(t)


def _az_diff_deg(a, b):
    return (np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0


def test_look_angles_match_skyfield(leo_sets, deep_sets, station):
    u = T0_UNIX_S + np.arange(0.0, 86400.0, 47.0)
    t = sky.to_time(u)
    for es in leo_sets + deep_sets:
        la = look_angles(es, station, u)
        topo = _skyfield_topo(es, station, t)
        alt, az, dist, alt_rate, az_rate, range_rate = topo.frame_latlon_and_rates(
            station.skyfield)
        assert np.abs(la.el_deg - alt.degrees).max() < AZEL_TOL_DEG
        # azimuth is ill-defined at the zenith; weight it by cos(el) (the pointing error)
        assert np.abs(_az_diff_deg(la.az_deg, az.degrees) * np.cos(np.radians(alt.degrees))
                      ).max() < AZEL_TOL_DEG
        assert np.abs(la.range_km - dist.km).max() < RANGE_TOL_KM
        assert np.abs(la.el_rate_deg_per_s - alt_rate.degrees.per_second).max() \
            < RATE_TOL_DEG_PER_S
        assert np.abs((la.az_rate_deg_per_s - az_rate.degrees.per_second)
                      * np.cos(np.radians(alt.degrees))).max() < RATE_TOL_DEG_PER_S
        assert np.abs(la.range_rate_km_per_s - range_rate.km_per_s).max() \
            < RANGE_RATE_TOL_KM_PER_S


def test_many_satellites_equal_one_by_one(leo_sets, deep_sets, station):
    sats = leo_sets + deep_sets
    u = T0_UNIX_S + np.arange(0.0, 7200.0, 60.0)
    many = look_angles_many(sats, station, u)
    assert many.az_deg.shape == (len(sats), len(u))
    for i, es in enumerate(sats):
        one = look_angles(es, station, u)
        assert np.array_equal(many.el_deg[i], one.el_deg)
        assert np.array_equal(many.az_deg[i], one.az_deg)


def test_time_forms(leo_sets, station):
    iss = leo_sets[0]
    ref = look_angles(iss, station, T0_UNIX_S)
    assert np.ndim(ref.az_deg) == 0
    for t in (T0, sky.to_time(T0_UNIX_S), np.float64(T0_UNIX_S)):
        la = look_angles(iss, station, t)
        assert float(la.el_deg) == pytest.approx(float(ref.el_deg), abs=1e-9)
    arr = look_angles(iss, station, [T0, T0 + timedelta(seconds=10)])
    assert arr.el_deg.shape == (2,)
    with pytest.raises(TypeError, match="naive datetime"):
        look_angles(iss, station, datetime(2024, 1, 1, 12))


def test_unix_seconds_and_skyfield_time_agree():
    for when in (T0, datetime(2016, 12, 31, 23, 59, 59, tzinfo=timezone.utc),
                 datetime(2017, 1, 1, 0, 0, 1, tzinfo=timezone.utc)):
        t = sky.to_time(when.timestamp())
        assert (t.tt - sky.timescale().from_datetime(when).tt) * 86400 == pytest.approx(0, abs=1e-6)
        assert sky.unix_s(t) == pytest.approx(when.timestamp(), abs=1e-6)


def test_refraction_matches_skyfield(leo_sets, station):
    u = T0_UNIX_S + np.arange(0.0, 86400.0, 30.0)
    iss = leo_sets[0]
    geo = look_angles(iss, station, u)
    app = look_angles(iss, station, u, refraction=True, temperature_c=10.0, pressure_mbar=1010.0)
    alt, _, _ = _skyfield_topo(iss, station, sky.to_time(u)).altaz(temperature_C=10.0,
                                                                    pressure_mbar=1010.0)
    assert np.abs(app.el_deg - alt.degrees).max() < AZEL_TOL_DEG
    near = np.abs(geo.el_deg) < 0.2
    assert near.any() and np.all(app.el_deg[near] - geo.el_deg[near] > 0.4)  # ~0.5 deg


def test_decayed_orbit_gives_nan_and_error(station):
    l1 = "1 33334U 78066F   06174.85818871  .00000620  00000-0  10000-3 0  6809"
    l2 = "2 33334  68.4714 236.1303 5602877 123.7484 302.5767  0.00001000 67521"
    (es,) = parse_tle(f"{l1}\n{l2}\n", checksum=False)
    assert es.sgp4_error is not None
    la = look_angles(es, station, T0_UNIX_S)
    assert la.error != 0 and math.isnan(float(la.el_deg))
    assert la.error_messages()


def test_sun_and_moon(station):
    u = T0_UNIX_S + np.arange(0.0, 86400.0, 3600.0)
    eph = sky.ephemeris()
    t = sky.to_time(u)
    for fn, body in ((sun_look_angles, "sun"), (moon_look_angles, "moon")):
        la = fn(station, u)
        alt, az, dist = (eph["earth"] + station.skyfield).at(t).observe(eph[body]) \
            .apparent().altaz()
        assert np.abs(la.el_deg - alt.degrees).max() < AZEL_TOL_DEG
        assert np.abs(_az_diff_deg(la.az_deg, az.degrees)).max() < AZEL_TOL_DEG
    # independent sanity: at Tartu (58.4 N) on 1 January the Sun culminates near
    # 90 - 58.4 - 23.0 = 8.6 degrees, at about 10:13 UTC (26.7 E, equation of time +3 min)
    noon = datetime(2024, 1, 1, 10, 13, tzinfo=timezone.utc)
    sun = sun_look_angles(station, noon)
    assert float(sun.el_deg) == pytest.approx(8.6, abs=0.3)
    assert float(sun.az_deg) == pytest.approx(180.0, abs=1.0)
    assert abs(float(sun.el_rate_deg_per_s)) < 1e-3
    refr = sun_look_angles(station, noon, refraction=True)
    assert float(refr.el_deg) - float(sun.el_deg) == pytest.approx(0.1, abs=0.03)


def test_station_geometry():
    st = Station(58.378, 26.729, 70.0)
    assert np.allclose(st.enu @ st.enu.T, np.eye(3), atol=1e-12)
    # "up" is the ellipsoid normal, tilted from the geocentric direction by about
    # 0.192 * sin(2 lat) degrees (geodetic minus geocentric latitude)
    geocentric = st.itrs_km / np.linalg.norm(st.itrs_km)
    tilt_deg = math.degrees(math.acos(float(st.enu[2] @ geocentric)))
    assert tilt_deg == pytest.approx(0.192 * math.sin(math.radians(2 * 58.378)), abs=0.002)
