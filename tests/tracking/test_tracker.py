"""Whole passes flown on the simulator (virtual clock) for every profile: planned before
AOS, pre-positioned, followed smoothly, judged by simulator truth against skyfield-level
target positions."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from skyfield.api import EarthSatellite, wgs84

from urc.profiles import PROFILES
from urc.tracking import sky
from urc.testing.evaluate import fly_pass_on_sim
from urc.tracking.passes import find_passes
from urc.tracking.planner import AxisLimits, plan_pass
from urc.tracking.station import Station

from .conftest import T0_UNIX_S

FLIPPERS = [n for n, c in PROFILES.items() if c.can_flip]


def iss(leo_sets):
    return next(s for s in leo_sets if s.norad_id == 25544)


def overhead_station(es, t_unix_s: float, dlat_deg: float = 0.05) -> Station:
    """A station near the satellite's sub-point at t: its pass there reaches ~90 deg
    (keyhole; 89.3 deg at the default offset, 88.0 at 0.135, as bench/tracking_bench.py)."""
    ts = sky.timescale()
    sat = EarthSatellite.from_satrec(es.satrec, ts)
    sp = wgs84.subpoint_of(sat.at(ts.from_datetime(sky.utc_datetime(t_unix_s))))
    return Station(float(sp.latitude.degrees) + dlat_deg, float(sp.longitude.degrees), 0.0, "overhead")


def fly_pass(tmp_path, profile: str, es, station: Station, p, flip: bool = False):
    return fly_pass_on_sim(profile, es, station, p, tmp_path / profile, flip=flip)


def quantum(profile: str) -> float:
    c = PROFILES[profile]
    return max(c.az.sensor.resolution_deg, c.el.sensor.resolution_deg)


@pytest.mark.parametrize("profile", sorted(PROFILES))
def test_full_pass_every_profile(tmp_path, leo_sets, station, profile):
    es = iss(leo_sets)
    p = max(find_passes(es, station, T0_UNIX_S, duration_s=86400, min_el_deg=10), key=lambda p: p.max_el_deg)
    rot, plan, stats, plan_stats, *_ = fly_pass(tmp_path, profile, es, station, p)
    assert not rot.status().faults
    # this pass fits every profile's range and speeds: the plan itself is exact, so all
    # of the error measured is the rotator's
    assert plan_stats.rms_deg < 0.01, plan_stats
    # pre-positioned: on target from the first second of the pass
    c = PROFILES[profile]
    band = max(c.az.restart_deg, c.el.restart_deg) + quantum(profile)
    assert stats.aos_error_deg <= band + 0.5, stats
    # regression guards, not the goal (bench/tracking_bench.py measures that): within
    # 3x the quantisation floor q/sqrt(12), or 0.15 deg where noise or gear play rule
    bound = max(3 * quantum(profile) / math.sqrt(12), 0.15)
    assert stats.rms_deg <= bound, stats
    assert stats.p95_deg <= 2 * bound, stats


@pytest.mark.parametrize("dlat_deg", [0.05, 0.135])  # 89.3 and 88.0 deg, the bench's keyholes
def test_keyhole_pass_is_flown_over_the_top(tmp_path, leo_sets, dlat_deg):
    """Issue 12.6, judged by the simulator: at every control tick, the plan's pose
    against the target's true direction. Holding the azimuth and sweeping the elevation
    over the top misses by the pass's distance from the zenith at worst (1.998 deg at
    88.0, 0.740 at 89.3); the plan missed by 2.114 and 0.820 (its azimuth swung into the
    keyhole and back) and now reaches that bound, which no plan over the top can beat."""
    es = iss(leo_sets)
    station = overhead_station(es, T0_UNIX_S + 3600.0, dlat_deg)
    p = max(find_passes(es, station, T0_UNIX_S + 3000.0, duration_s=1800, min_el_deg=0),
            key=lambda p: p.max_el_deg)
    assert p.max_el_deg > 85.0
    bound_deg = 90.0 - p.max_el_deg
    rot, plan, stats, plan_stats, *_ = fly_pass_on_sim("tartu-urc", es, station, p, tmp_path)
    assert plan.flip, plan.summary()
    # over the top, geometry costs only the seconds around culmination where the azimuth
    # would have to turn faster than the motor can (the pass misses the zenith)
    assert plan_stats.p95_deg < 0.01, plan_stats
    assert plan_stats.max_deg <= bound_deg + 0.002, (plan_stats, bound_deg)
    assert any(n.startswith("keyhole") for n in plan.notes), plan.notes  # said to the user
    assert plan.peak_az_rate_deg_per_s < 6.0
    assert not rot.status().faults
    assert stats.rms_deg <= 0.3, stats
    assert stats.max_deg <= bound_deg + 0.05, (stats, bound_deg)  # the antenna really flew it


def test_keyhole_without_flip_is_rate_limited_not_lost(tmp_path, leo_sets):
    es = iss(leo_sets)
    station = overhead_station(es, T0_UNIX_S + 3600.0)
    p = max(find_passes(es, station, T0_UNIX_S + 3000.0, duration_s=1800, min_el_deg=0),
            key=lambda p: p.max_el_deg)
    rot, plan, stats, plan_stats, *_ = fly_pass(tmp_path, "bigras", es, station, p)  # el 0..90: cannot flip
    assert not plan.flip and plan.rate_limited
    assert plan_stats.rms_deg > 1.0, plan_stats  # the keyhole costs, by geometry, before any control error
    assert plan.peak_az_rate_deg_per_s <= 0.9 * PROFILES["bigras"].az.max_rate_deg_per_s + 1e-6
    assert stats.p95_deg < 30.0  # the swing is spread, not lost
    assert not rot.status().faults


def test_pass_behind_a_keepout_zone_goes_round_it_and_never_into_it(tmp_path, leo_sets, station):
    """A tree stands where the pass culminates, reaching above it: the antenna waits at
    its edge while the satellite is behind it, flies over it to rejoin the track, and is
    never inside it — pre-positioning included."""
    from urc.control.geometry import KeepOut
    from urc.tracking.propagate import look_angles
    es = iss(leo_sets)
    p = min(find_passes(es, station, T0_UNIX_S, duration_s=86400, min_el_deg=10), key=lambda p: p.max_el_deg)
    tca_az = float(look_angles(es, station, np.array([p.tca_unix_s])).az_deg[0])
    tree = KeepOut("tree", (tca_az - 5.0) % 360.0, (tca_az + 5.0) % 360.0, 0.0, p.max_el_deg + 5.0)
    zone = {"name": tree.name, "az_min_deg": tree.az_min_deg, "az_max_deg": tree.az_max_deg,
            "el_min_deg": 0.0, "el_max_deg": tree.el_max_deg}
    flown = fly_pass_on_sim("tartu-urc", es, station, p, tmp_path / "tree", config={"keepout": [zone]})
    t, az, el = flown.flight
    inner = KeepOut("inner", tree.az_min_deg + 1.0, tree.az_max_deg - 1.0, 0.0, tree.el_max_deg - 1.0)
    assert not any(inner.contains(a, e) for a, e in zip(az, el)), "the antenna went into the tree"
    assert flown.plan.blocked.any() and not flown.rotator.status().faults
    assert flown.stats.aos_error_deg < 0.5, flown.stats               # pre-positioned in time
    behind = (flown.plan.blocked.argmax(), len(flown.plan.blocked) - flown.plan.blocked[::-1].argmax())
    rejoin_s = flown.plan.t_s[behind[1] - 1] + 60.0                      # a minute after it reappears
    after = t[(t >= p.aos_unix_s) & (t <= p.los_unix_s)] >= rejoin_s
    assert np.percentile(flown.error_deg[after], 95) < 0.3               # back on the track


def test_planner_uses_the_overlap_for_a_pass_crossing_north():
    from urc.control.geometry import Geometry
    t = np.arange(0.0, 600.0, 1.0)
    az = (300.0 + 0.2 * t) % 360.0          # 300 -> 60 through north
    el = 10.0 + 30.0 * np.sin(np.pi * t / 600.0)
    g = Geometry(0.0, 450.0, 0.0, 90.0)
    plan = plan_pass(t, az, el, g, AxisLimits(6.0, 10.0), AxisLimits(3.0, 10.0), (0.0, 0.0), -1e9)
    assert plan.az_deg.min() >= 0.0 and plan.az_deg.max() <= 450.0
    assert np.all(np.abs(np.diff(plan.az_deg)) < 1.0)  # continuous: no unwinding mid-pass
    assert plan.az_deg[0] == pytest.approx(300.0) and plan.az_deg[-1] == pytest.approx(419.8, abs=0.5)


def test_planner_refuses_a_pass_it_cannot_fit():
    from urc.control.geometry import Geometry
    from urc.tracking.planner import PlanError
    t = np.arange(0.0, 100.0, 1.0)
    g = Geometry(0.0, 90.0, 0.0, 90.0)
    with pytest.raises(PlanError):
        plan_pass(t, np.full_like(t, 200.0), np.full_like(t, 30.0), g, AxisLimits(6, 10), AxisLimits(6, 10),
                  (0.0, 0.0), 0.0)


def test_planner_flies_most_of_a_pass_wider_than_the_range():
    """A pass across north spanning 129 -> -12 deg on a 0..450 rotator fits no wrap
    turn: fly the turn that holds most of it and wait at the limit for the rest."""
    from urc.control.geometry import Geometry
    t = np.arange(0.0, 700.0, 1.0)
    az = (129.0 - 0.2 * t) % 360.0
    el = 10.0 + 30.0 * np.sin(np.pi * t / 700.0)
    plan = plan_pass(t, az, el, Geometry(0.0, 450.0, 0.0, 90.0), AxisLimits(4, 4), AxisLimits(2, 3),
                     (0.0, 0.0), 0.0)
    assert plan.az_deg.min() >= 0.0 and plan.az_deg.max() <= 450.0
    assert np.all(np.abs(np.diff(plan.az_deg)) <= 0.21)
    assert any("beyond the azimuth limits" in n for n in plan.notes)


def test_planner_unwinds_once_when_that_loses_less():
    """On a fast 0..360 rotator a pass across north is flown with one quick unwind, at the
    moment that costs least, instead of waiting at the limit for half the pass."""
    from urc.control.geometry import Geometry
    t = np.arange(0.0, 700.0, 1.0)
    az = (300.0 + 0.2 * t) % 360.0           # 300 -> 80 through north
    el = 10.0 + 30.0 * np.sin(np.pi * t / 700.0)
    plan = plan_pass(t, az, el, Geometry(0.0, 360.0, 0.0, 90.0), AxisLimits(30, 60), AxisLimits(30, 60),
                     (0.0, 0.0), 0.0)
    assert plan.az_deg.min() >= 0.0 and plan.az_deg.max() <= 360.0
    assert any("unwinds once" in n for n in plan.notes), plan.notes
    swings = (np.abs(np.diff(plan.az_deg)) > 1.0).astype(int)
    assert np.sum(np.diff(swings) == 1) + swings[0] == 1  # one contiguous swing, nothing else
    assert swings.sum() <= 40  # 360 deg at up to 27 deg/s, spread around the moment


@pytest.mark.parametrize("profile,flip,expect", [("tartu-urc", None, True), ("g5500", "auto", True),
                                                 ("bigras", None, False), ("tartu-urc", False, False)])
def test_flip_is_decided_per_pass_unless_forbidden(profile, flip, expect):
    """Issue 12.4: tartu-urc shipped flip = false, so a 165 deg pass across north unwound
    360 deg at culmination (22 deg RMS) where flying over the top costs nothing. The
    default is now "auto": the planner decides on every rotator that can flip."""
    from urc.assembly import settings_from_config
    from urc.config import Config
    rotator = {"profile": profile} if flip is None else {"profile": profile, "flip": flip}
    g = settings_from_config(Config.from_dict({"rotator": rotator})).geometry()
    assert g.can_fly_passes_flipped is expect and not g.flip
    if not PROFILES[profile].can_flip:
        return
    t = np.arange(0.0, 660.0, 1.0)
    az = (300.0 + 0.25 * t) % 360.0                  # 300 -> 105 through north: 165 deg
    el = 5.0 + 75.0 * np.sin(np.pi * t / 660.0)
    c = PROFILES[profile]
    plan = plan_pass(t, az, el, g, AxisLimits(c.az.max_rate_deg_per_s, c.az.accel_deg_per_s2),
                     AxisLimits(c.el.max_rate_deg_per_s, c.el.accel_deg_per_s2), (0.0, 90.0), -1e9)
    from urc.tracking.planner import pointing_error_deg
    err = pointing_error_deg(plan.az_deg, plan.el_deg, az, el, g)
    if expect:
        assert plan.flip and err.max() < 0.05, (plan.notes, err.max())
        assert np.all(np.abs(np.diff(plan.az_deg)) < 1.0)  # no unwind
    else:
        assert not plan.flip and err.max() > 10.0  # forbidden: the geometry costs


def test_status_tracking_is_brought_up_to_date_between_refreshes(tmp_path, leo_sets, station, monkeypatch):
    """Issue 12.7: status.tracking az/el was refreshed at ~1 Hz, so the dashboard and the
    API showed where the target had been up to a second before (a degree near culmination)."""
    from conftest import Bench
    from urc.tracking.propagate import look_angles
    from urc.tracking.tracker import Tracker
    from urc.web import live

    es = iss(leo_sets)
    p = max(find_passes(es, station, T0_UNIX_S, duration_s=86400, min_el_deg=10), key=lambda p: p.max_el_deg)
    u0 = p.tca_unix_s
    b = Bench("tartu-urc", tmp_path / "state")
    tracker = Tracker(b.rot, station, lambda now_s: u0)
    tracker.track_pass(es, p, 0.0)
    now = {"wall": u0, "mono": 100.0}
    monkeypatch.setattr(live.time, "time", lambda: now["wall"])
    monkeypatch.setattr(live.time, "monotonic", lambda: now["mono"])
    from types import SimpleNamespace
    hub = live.Hub(b.rot, SimpleNamespace(status=lambda: tracker.status(0.0)))  # as TrackingService
    first = hub.status_dict()["tracking"]
    now["wall"], now["mono"] = u0 + 0.9, 100.5  # within the refresh period: the cached status
    later = hub.status_dict()["tracking"]
    truth = look_angles(es, station, np.array([u0 + 0.9]))
    moved = abs((truth.az_deg[0] - first["az_deg"] + 180) % 360 - 180) + abs(truth.el_deg[0] - first["el_deg"])
    assert moved > 0.1  # the target really moved meanwhile
    assert later["az_deg"] == pytest.approx(truth.az_deg[0], abs=0.02)
    assert later["el_deg"] == pytest.approx(truth.el_deg[0], abs=0.02)


@pytest.mark.parametrize("dlat_deg", [0.05, 0.1, 0.135, 0.2])  # 89.3, 88.7, 88.0, 87.0 deg
def test_keyhole_plan_is_near_the_hold_azimuth_bound(leo_sets, dlat_deg):
    """Issue 12.6: the 88 deg keyhole on tartu-urc with flip peaked at 2.7 deg of plan
    error (then 2.11; 0.82 at 89.3 deg), while holding the azimuth and sweeping elevation
    over the top is bounded by the pass's distance from the zenith (2.0; 0.74). That
    bound is the minimax of every plan over the top, and the plan now reaches it, judged
    between its samples too (the tracker interpolates them)."""
    from urc.assembly import settings_from_config
    from urc.config import Config
    from urc.tracking.planner import pointing_error_deg
    from urc.tracking.propagate import look_angles
    es = iss(leo_sets)
    base = overhead_station(es, T0_UNIX_S + 3600.0)
    station = Station(base.lat_deg + dlat_deg - 0.05, base.lon_deg, 0.0, "near overhead")
    p = max(find_passes(es, station, T0_UNIX_S + 3000.0, duration_s=1800, min_el_deg=0),
            key=lambda p: p.max_el_deg)
    bound_deg = 90.0 - p.max_el_deg
    g = settings_from_config(Config.from_dict({"rotator": {"profile": "tartu-urc"}})).geometry()
    t = np.arange(p.aos_unix_s, p.los_unix_s, 1.0)
    la = look_angles(es, station, t)
    c = PROFILES["tartu-urc"]
    plan = plan_pass(t, la.az_deg, la.el_deg, g, AxisLimits(c.az.max_rate_deg_per_s, c.az.accel_deg_per_s2),
                     AxisLimits(c.el.max_rate_deg_per_s, c.el.accel_deg_per_s2), (0.0, 90.0), -1e9)
    tf = np.arange(p.aos_unix_s, p.los_unix_s - 1.0, 0.1)
    laf = look_angles(es, station, tf)
    err = pointing_error_deg(np.interp(tf, plan.t_s, plan.az_deg), np.interp(tf, plan.t_s, plan.el_deg),
                             laf.az_deg, laf.el_deg, g)
    assert plan.flip
    assert err.max() <= bound_deg + 0.002, (err.max(), bound_deg)


def fly_continuous(tmp_path, profile: str, target_of, station: Station, start_unix_s: float, duration_s: float,
                   flip="auto", config: dict | None = None):
    """Track a continuous target on the simulator from ``start_unix_s``: (rotator,
    tracker, UTC times, true sky az, el, mechanical az) at every tick."""
    from urc.assembly import build_rotator
    from urc.clock import VirtualClock
    from urc.config import Config
    from urc.rotator.loop import run_virtual
    from urc.tracking.tracker import Tracker

    cfg = Config.from_dict({"rotator": {"profile": profile, "flip": flip}, "hardware": {"sim": {"wind": False}},
                            **(config or {})})
    clock = VirtualClock(0.0)
    rot = build_rotator(cfg, clock, tmp_path / profile, fast_virtual=True)
    tracker = Tracker(rot, station, lambda now_s: start_unix_s + now_s)
    tracker.track(target_of(station), clock.now_s())
    rows = []

    def on_tick(s) -> None:
        tracker.step(s.t_s)
        truth = s.sim_truth
        rows.append((start_unix_s + s.t_s, *rot.geometry.to_sky(truth["az"]["deg"], truth["el"]["deg"]),
                     truth["az"]["deg"]))
    run_virtual(rot, clock, duration_s, on_tick=on_tick)
    t, az, el, az_m = (np.array(c) for c in zip(*rows))
    return rot, tracker, t, az, el, az_m


#: no wrap turn of a 0..360 azimuth holds the Sun's noon at 30 deg south in January
AZ_0_360 = {"limits": {"az": {"min_deg": 0.0, "max_deg": 360.0}}}


@pytest.mark.parametrize("config", [None, AZ_0_360], ids=["0-400", "0-360"])
def test_sun_culminating_across_the_wrap_point_is_not_lost(tmp_path, config):
    """Issue 12 (continuous targets never flipped under flip = "auto"): at 30 deg south in
    January the Sun culminates at 83 deg due north, its azimuth falling through 0/360
    at noon. Tracked from 200 s before, the antenna took the turn nearest its park
    pose and unwound 360 deg at culmination, up to 14 deg off the Sun for a minute. Its arc is
    now planned when tracking starts: on tartu-urc's 0..400 deg, the overlap turn holds
    the rest of the day (367 -> 243 deg) and so does flying over the top, which is
    reached sooner from the park pose (az 187 against 367: issue 36.21) and flown;
    limited to 0..360 only over the top holds it (the azimuth passes 180 instead)."""
    from urc.angles import great_circle_deg
    from urc.tracking.propagate import sun_look_angles
    from urc.tracking.targets import SunTarget

    station = Station(-30.0, 116.0, 0.0, "south")
    t = np.arange(T0_UNIX_S, T0_UNIX_S + 86400.0, 30.0)
    noon = float(t[np.argmax(sun_look_angles(station, t).el_deg)])
    rot, tracker, t, az, el, az_m = fly_continuous(tmp_path, "tartu-urc", SunTarget, station, noon - 200.0, 300.0,
                                                   config=config)
    sun = sun_look_angles(station, t)
    err = great_circle_deg(az, el, sun.az_deg, sun.el_deg)
    on = t > noon - 110.0  # 90 s to slew there from the park pose
    assert err[on].max() < 0.2, err[on].max()
    assert np.ptp(az_m[on]) < 30.0  # no unwind: the azimuth axis moved with the Sun only
    assert rot.status().flipped and not rot.status().faults


@pytest.mark.parametrize("profile, hours, flipped", [("tartu-urc", -3.0, False), ("tartu-urc", 0.0, True),
                                                    ("sarcnet-mini", 0.0, False)])
def test_sun_that_needs_no_flip_is_flown_on_the_side_reached_sooner(tmp_path, station, profile, hours, flipped):
    """The Sun over Tartu, flown as well either way: from tartu-urc's park pose (az 0,
    el 90) the side reached sooner wins (issue 36.21): at 09:00 UTC (az 162) unflipped,
    27 s against 57 s for the flipped az 342; at noon (az 204) flipped, az 24 and el 174
    in 14 s against 34 s (it was unflipped: no flip whenever as good). sarcnet-mini's
    compass rides the boom and reads a flipped pose 180 deg off: it stays unflipped at
    noon too, though the flipped start is sooner from its park pose (az 0, el 0)."""
    from urc.tracking.targets import SunTarget

    rot, tracker, *_ = fly_continuous(tmp_path, profile, SunTarget, station, T0_UNIX_S + hours * 3600.0, 60.0)
    assert tracker.arc is not None and tracker.arc.flip is flipped
    assert rot.status().flipped is flipped


def least_follow_error_deg(t: np.ndarray, sky_az: np.ndarray, sky_el: np.ndarray, rate_deg_per_s: float) -> float:
    """The least worst-case error of any plan whose azimuth turns with the target (no
    flip) within ``rate_deg_per_s``, the elevation free, computed independently of the
    planner: with error E, the azimuth must stay within asin(sin E / cos el) of the
    target's at each sample, and a path through such intervals within a speed limit
    exists iff every pair of them is reachable from the other in the time between
    (1-D Lipschitz extension); bisection on E."""
    u = np.degrees(np.unwrap(np.radians(sky_az)))
    cos_el = np.maximum(np.cos(np.radians(np.clip(sky_el, 0.0, 90.0))), 1e-12)
    reach = np.abs(t[:, None] - t[None, :]) * rate_deg_per_s

    def feasible(err_deg: float) -> bool:
        half = np.degrees(np.arcsin(np.clip(np.sin(np.radians(err_deg)) / cos_el, 0.0, 1.0)))
        return bool(np.all((u - half)[None, :] - (u + half)[:, None] <= reach + 1e-9))
    lo, hi = 0.0, 90.0
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if feasible(mid) else (mid, hi)
    return hi


@pytest.mark.parametrize("profile,dlat_deg", [("bigras", 0.05), ("bigras", 0.135), ("tartu-urc", 0.135),
                                              ("tartu-urc", 0.3)])
def test_keyhole_plan_is_the_minimax_over_the_azimuth_speed(leo_sets, profile, dlat_deg):
    """Issue 12.6, the true minimax: a keyhole plan misses the target by no more than the
    least any plan can, at its samples, within the azimuth's speed budget: turning the
    azimuth with the target (the only way on bigras, which cannot flip; it missed 89.3
    deg by 12.1 deg where 7.9 is possible), or, on a rotator that can flip, holding it
    over the top (the pass's distance from the zenith), whichever is less (on tartu-urc
    the hold at 88 deg, the turn at 85.6)."""
    from urc.assembly import settings_from_config
    from urc.config import Config
    from urc.tracking.planner import RATE_BUDGET, pointing_error_deg
    from urc.tracking.propagate import look_angles
    es = iss(leo_sets)
    station = overhead_station(es, T0_UNIX_S + 3600.0, dlat_deg)
    p = max(find_passes(es, station, T0_UNIX_S + 3000.0, duration_s=1800, min_el_deg=0),
            key=lambda p: p.max_el_deg)
    g = settings_from_config(Config.from_dict({"rotator": {"profile": profile}})).geometry()
    c = PROFILES[profile]
    t = np.arange(p.aos_unix_s, p.los_unix_s, 1.0)
    la = look_angles(es, station, t)
    plan = plan_pass(t, la.az_deg, la.el_deg, g, AxisLimits(c.az.max_rate_deg_per_s, c.az.accel_deg_per_s2),
                     AxisLimits(c.el.max_rate_deg_per_s, c.el.accel_deg_per_s2), (0.0, 90.0), -1e9)
    worst = float(pointing_error_deg(plan.az_deg, plan.el_deg, la.az_deg, la.el_deg, g).max())
    least = least_follow_error_deg(t, la.az_deg, la.el_deg, RATE_BUDGET * c.az.max_rate_deg_per_s)
    if c.can_flip:
        least = min(least, 90.0 - p.max_el_deg)
    assert worst <= least + 0.005, (worst, least)
    assert plan.peak_az_rate_deg_per_s <= RATE_BUDGET * c.az.max_rate_deg_per_s + 1e-6


def test_an_arc_that_cannot_be_planned_is_followed_and_not_replanned_at_every_update(tmp_path, station,
                                                                                      monkeypatch):
    """Planning a Sun's arc costs tens of milliseconds on the API's event loop: when it
    fails, the Sun is followed on the side the antenna is on, and planning is tried again
    a minute later, not five times a second."""
    from urc.assembly import build_rotator
    from urc.clock import VirtualClock
    from urc.config import Config
    from urc.tracking import tracker as tracker_mod
    from urc.tracking.planner import PlanError
    from urc.tracking.targets import SunTarget

    calls = []

    def refuse(*args, **kw):
        calls.append(args[0][0])
        raise PlanError("refused for the test")
    monkeypatch.setattr(tracker_mod, "plan_pass", refuse)
    clock = VirtualClock(0.0)
    rot = build_rotator(Config.from_dict({"rotator": {"profile": "tartu-urc"}}), clock, tmp_path, fast_virtual=True)
    followed = []
    track = rot.track
    monkeypatch.setattr(rot, "track", lambda *a, **kw: (followed.append(a), track(*a, **kw)))
    trk = tracker_mod.Tracker(rot, station, lambda now_s: T0_UNIX_S + now_s)
    trk.track(SunTarget(station), 0.0)
    for i in range(100):  # 20 s of updates
        trk.step(0.2 * i)
    assert len(calls) == 1 and trk.arc is None
    assert len(followed) > 80 and not trk.last_error  # followed all the same (an update per 0.2 s)
    trk.step(tracker_mod.ARC_STEP_S + 1.0)
    assert len(calls) == 2


def test_an_arc_is_planned_on_the_background_worker_never_by_the_caller(tmp_path, station, monkeypatch):
    """Issue 33 item 6: `urc run` steps the tracker on its event loop; a Sun's arc (a day
    of positions planned whole, tens of ms) is planned on the tracker's worker, and the
    Sun is followed on the side it is on meanwhile."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    from urc.assembly import build_rotator
    from urc.clock import VirtualClock
    from urc.config import Config
    from urc.tracking import tracker as tracker_mod
    from urc.tracking.targets import SunTarget

    threads = []
    plan = tracker_mod.plan_pass

    def recorded(*args, **kw):
        threads.append(threading.current_thread())
        return plan(*args, **kw)
    monkeypatch.setattr(tracker_mod, "plan_pass", recorded)
    clock = VirtualClock(0.0)
    rot = build_rotator(Config.from_dict({"rotator": {"profile": "tartu-urc"}}), clock, tmp_path, fast_virtual=True)
    followed = []
    track = rot.track
    monkeypatch.setattr(rot, "track", lambda *a, **kw: (followed.append(a), track(*a, **kw)))
    trk = tracker_mod.Tracker(rot, station, lambda now_s: T0_UNIX_S + now_s)
    with ThreadPoolExecutor(max_workers=1) as worker:
        trk.background = worker
        trk.track(SunTarget(station), 0.0)
        trk.step(0.0)
        assert trk.arc is None and followed  # followed on its side meanwhile
        deadline = time.monotonic() + 30.0
        i = 1
        while trk.arc is None and time.monotonic() < deadline:
            time.sleep(0.05)
            trk.step(0.2 * i)
            i += 1
    assert trk.arc is not None and threads and threading.current_thread() not in threads


def test_a_pass_planned_while_the_antenna_parks_is_pre_positioned_from_the_park(tmp_path, leo_sets, station):
    """busy_soak lost a G-5500 pass: planned 30 s after the last pass's LOS while the
    antenna still drove to its park 400 deg away, the pre-positioning's travel was
    measured from where it was then; the park went on, and the move began 30 s late.
    The travel is now measured from where the motion under way ends."""
    from conftest import Bench
    from urc.tracking.tracker import Tracker

    es = iss(leo_sets)
    p = next(p for p in find_passes(es, station, T0_UNIX_S, duration_s=86400, min_el_deg=10)
             if 150.0 < p.aos_az_deg < 330.0)
    b = Bench("g5500", tmp_path / "state")
    b.rot.goto_pose(400.0, 0.0)
    b.run(120.0, until=lambda s: not s.moving and abs(s.az.pos_deg - 400.0) < 1.0)
    tracker = Tracker(b.rot, station, lambda now_s: p.aos_unix_s - 300.0)
    b.rot.park()
    b.run(20.0)   # (on its way: some 120 deg of the 400 behind it)
    s = b.rot.status()
    assert s.moving and 100.0 < 400.0 - s.az.pos_deg < 300.0
    parking = tracker.plan_pass(es, p, b.rot.clock.now_s()).plan
    b.run(120.0, until=lambda s: not s.moving)
    parked = tracker.plan_pass(es, p, b.rot.clock.now_s()).plan
    assert parking.preposition_start_s == pytest.approx(parked.preposition_start_s, abs=1.0)
