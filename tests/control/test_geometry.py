"""Cable wrap, flip, keep-out zones and path planning."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from urc.control.geometry import Geometry, KeepOut

RATES = (6.0, 6.0)


def test_keepout_sector_across_north():
    z = KeepOut("n", 350, 10, 0, 30)
    assert z.contains(355, 10) and z.contains(5, 10) and z.contains(725, 10)
    assert not z.contains(20, 10) and not z.contains(5, 31)
    assert KeepOut("all", 0, 360, 0, 5).contains(123, 1)


def test_candidates_use_the_overlap():
    g = Geometry(0, 450, 0, 90)
    assert sorted(g.candidates(30, 10)) == [(30, 10), (390, 10)]
    assert g.candidates(100, 10) == [(100, 10)]


def test_flip_candidates():
    g = Geometry(0, 400, 0, 180, flip=True)
    assert (200.0, 100.0) in g.candidates(20, 80)


def test_plan_takes_the_short_way_through_the_overlap():
    g = Geometry(0, 450, 0, 90)
    route = g.plan((440, 10), 10, 10, RATES)
    assert route == [(370, 10)]


def test_plan_720_rotator_never_parks_into_limit():
    g = Geometry(-360, 360, 0, 90)
    assert g.plan((350, 0), 0, 0, RATES) == [(360, 0)]
    assert g.plan((-350, 0), 0, 0, RATES) == [(-360, 0)]


def test_offsets_map_frames():
    g = Geometry(0, 360, 0, 90, az_offset_deg=10)
    assert g.to_sky(0, 45) == (10, 45)
    assert sorted(g.candidates(10, 45)) == [(0, 45), (360, 45)]  # both ends of a 0..360 range


def test_plan_goes_over_a_low_keepout():
    mast = KeepOut("mast", 80, 100, 0, 20)
    g = Geometry(0, 360, 0, 90, zones=(mast,), zone_margin_deg=0.5)
    route = g.plan((60, 5), 120, 5, RATES)
    assert route is not None and len(route) > 1
    pts = [(60, 5)] + route
    assert all(g.segment_clear(a, b, RATES) is None for a, b in zip(pts, pts[1:]))


def test_plan_refuses_target_inside_zone():
    g = Geometry(0, 360, 0, 90, zones=(KeepOut("roof", 0, 360, 0, 10),))
    assert g.plan((0, 45), 100, 5, RATES) is None


def test_clear_until_stops_before_zone():
    g = Geometry(0, 360, 0, 90, zones=(KeepOut("mast", 80, 100, 0, 20),), zone_margin_deg=0.5)
    end = g.clear_until((10, 5), "az", 360)
    assert 78 < end < 80


def test_clear_until_from_inside_a_zone_only_leaves_the_shortest_way():
    g = Geometry(0, 360, 0, 90, zones=(KeepOut("roof", 330, 20, 0, 8),), zone_margin_deg=0.5)
    assert g.clear_until((0, 7), "el", 0) == 7          # down: no way out, stays put
    assert g.clear_until((0, 7), "el", 90) == 90        # up: out of it
    assert 329 < g.clear_until((5, 7), "az", 360) < 330  # out at 20, stops before it again
    assert g.clear_until((5, 7), "az", 0) == 5          # 35 deg through the roof the other way


@settings(max_examples=300, deadline=None)
@given(st.floats(0, 450), st.floats(0, 90), st.floats(0, 359.9), st.floats(0, 90),
       st.floats(0, 359), st.floats(1, 60), st.floats(0, 60), st.floats(1, 40))
def test_property_planned_routes_avoid_zones(a0, e0, az, el, zaz, zw, zel, zh):
    zone = KeepOut("z", zaz, zaz + zw, zel, zel + zh)
    g = Geometry(0, 450, 0, 90, zones=(zone,), zone_margin_deg=0.5)
    route = g.plan((a0, e0), az, el, RATES)
    if route is None:
        return
    pts = [(a0, e0)] + route
    for a, b in zip(pts, pts[1:]):
        assert g.in_limits(*b)
        assert g.segment_clear(a, b, RATES) is None


def test_start_inside_a_zone_leaves_straight_up_before_moving_on():
    """Switched on inside the roof zone: the route first climbs out of it, it never
    crosses deeper into the zone (found by the safety property test on g5500)."""
    roof = KeepOut("roof", 330, 20, 0, 8)
    g = Geometry(0, 450, 0, 180, zones=(roof,), zone_margin_deg=1.3)
    route = g.plan((19.8, 0.1), 0.0, 12.0, RATES)
    assert route is not None and route[0][0] == 19.8 and route[0][1] > 8.0
    pts = [(19.8, 0.1)] + route
    for a, b in zip(pts[1:], pts[2:]):
        assert g.segment_clear(a, b, RATES) is None


def test_starting_in_the_margin_band_may_not_enter_the_zone():
    roof = KeepOut("roof", 330, 20, 0, 8)
    g = Geometry(0, 450, 0, 90, zones=(roof,), zone_margin_deg=1.3)
    assert g.segment_clear((21.0, 0.0), (0.0, 9.0), RATES) is not None


def test_a_fixed_elevation_on_a_zone_band_edge_measures_depth_along_azimuth():
    """A single-axis rotator's beam at el 0 in a zone from the horizon: only the azimuth
    can take it out, so the depth is the azimuth's (it was 0 at any azimuth)."""
    roof = KeepOut("roof", 330.0, 20.0, 0.0, 8.0)
    assert roof.depth_deg(10.0, 0.0) == 0.0
    assert roof.depth_deg(10.0, 0.0, el_fixed=True) == pytest.approx(10.0)
    assert roof.depth_deg(18.0, 0.0, el_fixed=True) == pytest.approx(2.0)
    assert roof.depth_deg(25.0, 0.0, el_fixed=True) == pytest.approx(-5.0)
    turntable = Geometry(-180.0, 540.0, 0.0, 0.0, zones=(roof,))
    assert turntable.deeper_into_zone((19.4, 0.0), (18.9, 0.0), margin_deg=0.1) == roof
    assert turntable.deeper_into_zone((18.9, 0.0), (19.4, 0.0), margin_deg=0.1) is None
