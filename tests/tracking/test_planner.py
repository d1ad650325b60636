"""Pass planner properties, for any pass over any rotator (hypothesis): the planned
trajectory stays within the limits, within the axes' speed and acceleration, and out of
keep-out zones (samples behind a zone are marked blocked: the tracker waits at the edge
and flies a route round the zone to rejoin, see test_tracker.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from urc.control.geometry import Geometry, KeepOut
from urc.tracking.planner import AxisLimits, PlanError, plan_pass

#: (az_min, az_max, el_max): 0-360, overlap to 450, SARCNET-like -90..450, Tartu, G-5500
RANGES = [(0.0, 360.0, 90.0), (0.0, 450.0, 90.0), (-90.0, 450.0, 90.0), (0.0, 400.0, 180.0),
          (0.0, 450.0, 180.0)]


def great_circle_pass(tca_az_deg: float, max_el_deg: float, rate_deg_per_s: float, sense: int):
    """A satellite on a great circle, horizon to horizon: ``max_el_deg`` at culmination
    in direction ``tca_az_deg``, crossing the sky at ``rate_deg_per_s``; 1 s samples."""
    def unit(az_deg: float, el_deg: float) -> np.ndarray:
        a, e = math.radians(az_deg), math.radians(el_deg)
        return np.array([math.cos(e) * math.sin(a), math.cos(e) * math.cos(a), math.sin(e)])  # E, N, U
    c, d = unit(tca_az_deg, max_el_deg), unit(tca_az_deg + 90.0 * sense, 0.0)
    t = np.arange(0.0, 180.0 / rate_deg_per_s, 1.0)
    s = np.radians(rate_deg_per_s * t - 90.0)
    p = np.cos(s)[:, None] * c + np.sin(s)[:, None] * d
    az = np.degrees(np.arctan2(p[:, 0], p[:, 1])) % 360.0
    el = np.degrees(np.arcsin(np.clip(p[:, 2], -1.0, 1.0)))
    keep = el >= 0.0
    return t[keep], az[keep], el[keep]


zone = st.one_of(st.none(), st.tuples(st.floats(0, 359), st.floats(5, 60), st.floats(5, 40)))
limits = st.tuples(st.floats(0.5, 30), st.floats(0.5, 60))   # max rate, acceleration


@settings(max_examples=60, deadline=None)
@given(rng=st.sampled_from(RANGES), tca_az=st.floats(0, 360),
       max_el=st.one_of(st.floats(1, 90), st.floats(80, 89.99)),  # keyholes need the most
       rate=st.floats(0.2, 1.5), sense=st.sampled_from([-1, 1]), az_lim=limits, el_lim=limits,
       z=zone, start_az=st.floats(0, 1), start_el=st.floats(0, 1))
def test_planned_trajectory_is_flyable_and_clear(rng, tca_az, max_el, rate, sense, az_lim, el_lim, z,
                                                 start_az, start_el):
    az_min, az_max, el_max = rng
    zones = () if z is None else (KeepOut("z", z[0], (z[0] + z[1]) % 360.0, 0.0, z[2]),)
    g = Geometry(az_min, az_max, 0.0, el_max, flip=el_max > 90.0, zones=zones)
    t, s_az, s_el = great_circle_pass(tca_az, max_el, rate, sense)
    az_limits, el_limits = AxisLimits(*az_lim), AxisLimits(*el_lim)
    start = (az_min + start_az * (az_max - az_min), start_el * el_max)
    try:
        plan = plan_pass(t, s_az, s_el, g, az_limits, el_limits, start, t[0] - 3600.0)
    except PlanError:
        return  # refused outright: nothing is flown
    a, e = plan.az_deg, plan.el_deg
    # within the limits
    assert az_min - 1e-6 <= a.min() and a.max() <= az_max + 1e-6
    assert -1e-6 <= e.min() and e.max() <= el_max + 1e-6
    # within the axes' speeds and accelerations
    assert plan.peak_az_rate_deg_per_s <= az_limits.max_rate_deg_per_s + 1e-6
    assert plan.peak_el_rate_deg_per_s <= el_limits.max_rate_deg_per_s + 1e-6
    assert plan.peak_az_accel_deg_per_s2 <= az_limits.accel_deg_per_s2 + 1e-6
    assert plan.peak_el_accel_deg_per_s2 <= el_limits.accel_deg_per_s2 + 1e-6
    # out of keep-out zones: every sample flown, and the way between two of them (to
    # within a twentieth of a degree: a corner cut shallower is below any sensor's count)
    core = Geometry(az_min, az_max, 0.0, el_max, flip=g.flip, zones=tuple(
        KeepOut(z.name, z.az_min_deg + 0.05, z.az_max_deg - 0.05, z.el_min_deg, z.el_max_deg - 0.05)
        for z in zones))
    for i in range(len(t) - 1):
        if plan.blocked[i] or plan.blocked[i + 1]:
            continue
        for f in np.linspace(0.0, 1.0, 7):
            pose = (a[i] + f * (a[i + 1] - a[i]), e[i] + f * (e[i + 1] - e[i]))
            assert core.zone_at(*pose, margin_deg=0.0) is None, (i, pose)
    # pre-positioning leaves in time (it was an hour ahead)
    assert plan.preposition_start_s <= t[0]


def test_a_step_cutting_a_zone_corner_is_blocked():
    """Both samples outside the zone, the straight way between them through its corner:
    the tracker must not fly that step (it waits and goes round instead)."""
    from urc.tracking.planner import _blocked
    g = Geometry(0.0, 360.0, 0.0, 90.0, zones=(KeepOut("z", 43.0, 48.0, 0.0, 10.0),))
    a, e = np.array([30.0, 40.0, 50.0, 60.0]), np.array([14.0, 11.0, 8.0, 5.0])
    assert g.zone_at(40.0, 11.0, margin_deg=0.0) is None and g.zone_at(50.0, 8.0, margin_deg=0.0) is None
    assert _blocked(a, e, g).tolist() == [False, True, True, False]


def test_a_continuing_arc_keeps_the_side_the_antenna_is_on():
    """A long arc (the midnight sun) is planned anew while the antenna is on it: where the
    flipped and the unflipped plan are equally good, the side it is on wins over the
    unflipped one, instead of a half-turn swing mid-track; a fresh plan from a pose as
    far from both prefers unflipped."""
    g = Geometry(0.0, 450.0, 0.0, 180.0, flip=True)
    t, s_az, s_el = great_circle_pass(180.0, 30.0, 0.5, 1)
    lim = AxisLimits(6.0, 10.0)
    flipped_aos = ((s_az[0] + 180.0) % 360.0, 180.0 - s_el[0])
    between = ((s_az[0] + flipped_aos[0]) / 2.0, 90.0)   # (the two AOS poses are 180 deg apart in azimuth)
    fresh = plan_pass(t, s_az, s_el, g, lim, lim, between, t[0] - 600.0)
    assert not fresh.flip
    going_on = plan_pass(t, s_az, s_el, g, lim, lim, flipped_aos, t[0], continuing=True)
    assert going_on.flip
    assert math.hypot(going_on.aos_pose[0] - flipped_aos[0], going_on.aos_pose[1] - flipped_aos[1]) < 1.0


@pytest.mark.parametrize("flip_sensed", [True, False])
def test_the_pre_position_pose_reached_sooner_wins_where_the_flip_is_sensed(flip_sensed):
    """Issue 36.21: on tartu-urc (az 0..400, el 0..180, 6 deg/s) the planner chose an
    unflipped start a 314 deg slew away over a flipped one about 135 deg away. Of
    equally good plans the pose reached sooner wins where the sensors read a flipped
    pose as such; where they do not (sarcnet-mini's compass on the boom reads it 180 deg
    off), the unflipped one still does."""
    from urc.tracking.planner import route_time_s

    g = Geometry(0.0, 400.0, 0.0, 180.0, flip=True, flip_sensed=flip_sensed)
    lim = AxisLimits(6.0, 12.0)
    t, s_az, s_el = great_circle_pass(300.0, 10.0, 0.5, -1)   # a low pass, AOS at az 30, going west
    start = (0.0, 10.0)
    plan = plan_pass(t, s_az, s_el, g, lim, lim, start, t[0] - 3600.0)
    unflipped_s = route_time_s([start, (s_az[0] + 360.0, s_el[0])], (6.0, 6.0))   # az 390: 0..30 is not on its way
    flipped = ((s_az[0] + 180.0) % 360.0, 180.0 - s_el[0])
    assert route_time_s([start, flipped], (6.0, 6.0)) < unflipped_s - 20.0     # (the case)
    if not flip_sensed:
        assert not plan.flip and plan.aos_pose[0] > 360.0
        return
    assert plan.flip
    assert route_time_s([start, plan.aos_pose], (6.0, 6.0)) < unflipped_s - 20.0
    assert plan.preposition_start_s > t[0] - unflipped_s - 5.0                  # it can leave later


def test_which_profiles_sense_a_flipped_pose():
    """The planner's choice follows the profile's sensors: encoders, pots and AS5600s on
    each axis read a flipped pose; SARCNET's compass rides the boom (its heading turns
    180 deg past the zenith); a bridged controller reporting sky elevations folds at 90."""
    from dataclasses import replace

    from urc.profiles import PROFILES
    from urc.model.settings import RotatorSettings

    sensed = {n for n, c in PROFILES.items() if c.senses_flipped_pose}
    assert sensed == {n for n, c in PROFILES.items() if c.can_flip} - {"sarcnet-mini"}
    assert "tartu-urc" in sensed
    assert RotatorSettings.from_caps(PROFILES["tartu-urc"]).geometry().flip_sensed
    assert not RotatorSettings.from_caps(PROFILES["sarcnet-mini"]).geometry().flip_sensed
    tartu = PROFILES["tartu-urc"]
    folded = replace(tartu, el=replace(tartu.el, sensor=replace(tartu.el.sensor, kind="controller", fold_deg=90.0)))
    assert not folded.senses_flipped_pose


def test_a_pass_is_planned_for_the_beam_with_a_pointing_model_in_force():
    """Issue 38: with a pointing model (IA 1.5, IE -0.8, CA 0.6, AN 0.4 deg) the planned
    mechanical poses put the beam on the track (Geometry.to_sky, the controller's own
    frame map); the planner used to subtract the offsets only, the beam off by the model."""
    terms = {"ia": 1.5, "ie": -0.8, "ca": 0.6, "an": 0.4}
    from urc.control.geometry import POINTING_TERMS

    g = Geometry(0.0, 450.0, 0.0, 90.0, pointing_deg=tuple(terms.get(n, 0.0) for n in POINTING_TERMS))
    t, s_az, s_el = great_circle_pass(120.0, 60.0, 0.5, 1)
    up = s_el > 5.0   # (a boresight below the horizon is no pose: the pass above 5 deg)
    t, s_az, s_el = t[up], s_az[up], s_el[up]
    lim = AxisLimits(6.0, 10.0)
    plan = plan_pass(t, s_az, s_el, g, lim, lim, (120.0, 0.0), t[0] - 600.0)
    beam = np.array([g.to_sky(a, e) for a, e in zip(plan.az_deg, plan.el_deg)])
    err = [math.degrees(math.acos(min(1.0, math.sin(math.radians(e1)) * math.sin(math.radians(e2))
                                      + math.cos(math.radians(e1)) * math.cos(math.radians(e2))
                                      * math.cos(math.radians(a1 - a2)))))
           for (a1, e1), a2, e2 in zip(beam, s_az, s_el)]
    assert max(err) < 0.05, max(err)
