"""Targets: one interface for satellites, Sun, Moon, fixed directions, places, balloons."""

from __future__ import annotations

import math

import numpy as np
import pynmea2
import pytest

from urc.tracking import sky
from urc.tracking.elements import Catalog
from urc.tracking.errors import SatelliteNotFound, TargetError
from urc.tracking.propagate import look_angles, moon_look_angles, sun_look_angles
from urc.tracking.station import Station
from urc.tracking.targets import FixedTarget, GeoPointTarget, MoonTarget, NmeaTarget, \
    SatelliteTarget, SunTarget, Target, parse_target

from .conftest import T0, T0_UNIX_S

#: rate() against a central difference of position() over +-0.5 s
RATE_VS_DIFF_TOL_DEG_PER_S = 1e-4
AZEL_TOL_DEG = 1e-6


def numeric_rate(target, t_unix_s):
    (a0, e0), (a1, e1) = target.position(t_unix_s - 0.5), target.position(t_unix_s + 0.5)
    return (a1 - a0 + 180.0) % 360.0 - 180.0, e1 - e0


def check_rate(target, t_unix_s):
    az_rate, el_rate = target.rate(t_unix_s)
    n_az, n_el = numeric_rate(target, t_unix_s)
    assert az_rate == pytest.approx(n_az, abs=RATE_VS_DIFF_TOL_DEG_PER_S)
    assert el_rate == pytest.approx(n_el, abs=RATE_VS_DIFF_TOL_DEG_PER_S)


def test_satellite_target(leo_sets, station):
    cat = Catalog(leo_sets)
    iss = SatelliteTarget.from_catalog(cat, "iss", station)
    assert isinstance(iss, Target) and iss.name == "ISS (ZARYA)"
    for dt in (0.0, 247.0, 4000.0):
        u = T0_UNIX_S + dt
        la = look_angles(leo_sets[0], station, u)
        assert iss.position(u) == pytest.approx((float(la.az_deg), float(la.el_deg)))
        check_rate(iss, u)
    assert iss.position(T0) == iss.position(T0_UNIX_S)
    with pytest.raises(SatelliteNotFound):
        SatelliteTarget.from_catalog(cat, "nope", station)


@pytest.mark.parametrize("cls,body", [(SunTarget, "sun"), (MoonTarget, "moon")])
def test_sun_and_moon_targets(station, cls, body):
    target = cls(station)
    assert target.name == body.capitalize()
    eph = sky.ephemeris()
    alt, az, _ = (eph["earth"] + station.skyfield).at(sky.to_time(T0_UNIX_S)) \
        .observe(eph[body]).apparent().altaz()
    az_deg, el_deg = target.position(T0_UNIX_S)
    assert (az_deg, el_deg) == pytest.approx((az.degrees, alt.degrees), abs=AZEL_TOL_DEG)
    check_rate(target, T0_UNIX_S)


#: a station under the Tropic of Capricorn: the Sun culminates at 89.75 deg on 2023-12-21
TROPIC = Station(-23.2, 116.0, 0.0, "tropic")
SOLSTICE_NOON_UNIX_S = 1703131200.0 - 8 * 3600.0


@pytest.mark.parametrize("where", ["tropic", "tartu"])
@pytest.mark.parametrize("cls,look", [(SunTarget, sun_look_angles), (MoonTarget, moon_look_angles)])
def test_sun_and_moon_between_knots_match_skyfield(station, where, cls, look):
    """position() and rate() come from a table of skyfield's answers (interpolated between
    knots): off the knots, over a day and through a culmination 0.25 deg from the zenith,
    they stay within 1e-5 deg (great circle) and 1e-6 deg/s of skyfield at that time."""
    from urc.angles import great_circle_deg

    st = TROPIC if where == "tropic" else station
    target = cls(st)
    u = SOLSTICE_NOON_UNIX_S + np.sort(np.random.default_rng(1).uniform(-43200.0, 43200.0, 400))
    u[:5] = SOLSTICE_NOON_UNIX_S + np.array([0.1, 3.3, 4.9, 7.7, 9.99])  # within one interval
    got = np.array([target.position(x) + target.rate(x) for x in u])
    ref = look(st, u)
    assert great_circle_deg(got[:, 0], got[:, 1], ref.az_deg, ref.el_deg).max() < 1e-5
    assert np.abs(got[:, 3] - ref.el_rate_deg_per_s).max() < 1e-6
    # the azimuth rate as an angle on the sky (it grows without bound at the zenith)
    cos_el = np.cos(np.radians(ref.el_deg))
    assert np.abs((got[:, 2] - ref.az_rate_deg_per_s) * cos_el).max() < 1e-6


def test_following_the_sun_asks_skyfield_once_per_table(station, monkeypatch):
    """Ten minutes of the tracker's queries (position and rate every 0.2 s) cost one
    vectorised skyfield call, not 6000 single ones."""
    from urc.tracking import targets

    calls = []
    monkeypatch.setattr(targets, "sun_look_angles", lambda *a, **k: calls.append(a) or sun_look_angles(*a, **k))
    sun = SunTarget(station)
    t0 = math.floor(T0_UNIX_S / targets.BODY_TABLE_S) * targets.BODY_TABLE_S
    for u in t0 + np.arange(0.0, targets.BODY_TABLE_S, 0.2):
        sun.position(u)
        sun.rate(u)
    assert len(calls) == 1 and np.size(calls[0][1]) > 1


def test_fixed_and_geographic_targets(station):
    fixed = FixedTarget(370.0, 45.0)
    assert fixed.position(T0) == (10.0, 45.0) and fixed.rate(T0) == (0.0, 0.0)
    with pytest.raises(TargetError):
        FixedTarget(10.0, 200.0)
    above = GeoPointTarget(station, station.lat_deg, station.lon_deg, station.alt_m + 1000.0)
    assert above.position()[1] == pytest.approx(90.0, abs=1e-6)
    assert above.range_km == pytest.approx(1.0, abs=1e-6)
    # 100 km due north on the ellipsoid: azimuth ~0, below the horizon by the Earth's
    # curvature (d / 2R = 0.45 deg) less the station's 70 m height
    north = GeoPointTarget(station, station.lat_deg + 100.0 / 111.4, station.lon_deg, 0.0)
    az_deg, el_deg = north.position(T0)
    assert az_deg == pytest.approx(0.0, abs=0.01) or az_deg == pytest.approx(360.0, abs=0.01)
    assert el_deg == pytest.approx(-0.45 - math.degrees(0.07 / 100.0), abs=0.03)
    assert north.range_km == pytest.approx(100.0, abs=0.5)
    with pytest.raises(TargetError):
        GeoPointTarget(station, 95.0, 0.0)


def _balloon_gga(t_unix_s: float, lat: float, lon: float, alt_m: float) -> bytes:
    tod = sky.utc_datetime(t_unix_s)

    def dm(x: float, width: int) -> str:
        d = int(abs(x))
        return f"{d:0{width}d}{(abs(x) - d) * 60:07.4f}"

    msg = pynmea2.GGA("GP", "GGA", (tod.strftime("%H%M%S.00"), dm(lat, 2), "N", dm(lon, 3), "E",
                                    "1", "09", "1.0", f"{alt_m:.1f}", "M", "19.5", "M", "", ""))
    return (str(msg) + "\r\n").encode()


def test_nmea_balloon_linear_prediction(station):
    balloon = NmeaTarget(station, max_extrapolation_s=60.0, name="HAB-1")
    with pytest.raises(TargetError, match="no position report yet"):
        balloon.position(T0_UNIX_S)

    def track(t):  # a balloon drifting north-east and climbing 5 m/s
        dt = t - T0_UNIX_S
        return 58.50 + 2e-5 * dt, 26.90 + 3e-5 * dt, 12000.0 + 5.0 * dt

    reports = [balloon.feed(_balloon_gga(T0_UNIX_S + dt, *track(T0_UNIX_S + dt)),
                            T0_UNIX_S + dt + 0.4) for dt in (0.0, 10.0)]
    assert [len(r) for r in reports] == [1, 1]
    # between and shortly after reports: linear prediction (exact for a linear track,
    # up to the curvature of lat/lon on the ellipsoid over 20 s: negligible)
    t = T0_UNIX_S + 20.0
    truth = GeoPointTarget(station, *track(t))
    az, el = balloon.position(t)
    assert az == pytest.approx(truth.az_deg, abs=1e-3)
    assert el == pytest.approx(truth.el_deg, abs=1e-3)
    assert balloon.range_km(t) == pytest.approx(truth.range_km, abs=1e-3)
    check_rate(balloon, t)
    with pytest.raises(TargetError, match="not predicting more than 60 s ahead"):
        balloon.position(T0_UNIX_S + 75.0)
    # repeats and garbage do not disturb it; a bad checksum is counted
    assert balloon.feed(_balloon_gga(T0_UNIX_S + 10.0, *track(T0_UNIX_S + 10.0)), t) == []
    bad = _balloon_gga(T0_UNIX_S + 11.0, *track(T0_UNIX_S + 11.0))
    assert balloon.feed(bad[:-5] + b"00\r\n", t) == []
    assert balloon.bad_sentences == 1


def test_nmea_balloon_byte_by_byte(station):
    data = b"".join(_balloon_gga(T0_UNIX_S + dt, 58.5, 26.9, 1000.0 + dt) for dt in (0, 1, 2))
    balloon = NmeaTarget(station)
    got = []
    for i in range(len(data)):
        got += balloon.feed(data[i:i + 1], T0_UNIX_S + 3.0)
    assert [r.t_unix_s for r in got] == [T0_UNIX_S, T0_UNIX_S + 1, T0_UNIX_S + 2]
    assert got[-1].alt_m == pytest.approx(1002.0)


def test_parse_target(leo_sets, station):
    cat = Catalog(leo_sets)
    assert isinstance(parse_target("Sun", station), SunTarget)
    assert isinstance(parse_target("moon", station), MoonTarget)
    assert parse_target("azel:120,30", station).position() == (120.0, 30.0)
    assert isinstance(parse_target("geo:58.5,26.9,300", station), GeoPointTarget)
    assert parse_target("sat:25544", station, cat).name == "ISS (ZARYA)"
    assert parse_target("metop", station, cat).name == "METOP-B"
    with pytest.raises(TargetError, match=r"expected azel:AZ,EL with numbers"):
        parse_target("azel:1", station)
    with pytest.raises(TargetError, match="needs a catalog"):
        parse_target("iss", station)


def test_targets_accept_all_time_forms(leo_sets, station):
    iss = SatelliteTarget(leo_sets[0], station)
    ref = iss.position(T0_UNIX_S)
    assert iss.position(T0) == ref
    assert np.allclose(iss.position(sky.to_time(T0_UNIX_S)), ref, atol=1e-9)
