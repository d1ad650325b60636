"""Step-track's math on a virtual clock (urc.peaking.steptrack): a satellite running
across the sky at a steady rate, its elements 30 s off, the program flown by a perfect
rotator; the simulated power through a Gaussian beam. The whole loop with the control
process and the real tracker is in tests/tracking/test_steptrack_pass.py."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from urc.control.geometry import Geometry, KeepOut
from urc.pointing.fit import ScanRefused
from urc.peaking.simsource import SimulatedPower, SkySource
from urc.pointing.sources import Sample, SignalRefused, judge
from urc.peaking.steptrack import (CYCLE_S, DETECT_Z, TRACK_RADIUS_FWHM, Prediction, StepTrack, build_program,
                                    detection_z, fit_beam)

AOS_U = 1_000_000.0
RATE_DEG_S = 0.5
FWHM = 10.0


class LinePlan:
    """A pass plan (urc.tracking.planner.Plan's fields used) along az at el 30."""

    def __init__(self, length_s: float = 600.0):
        self.t_s = np.arange(AOS_U, AOS_U + length_s + 1, 1.0)
        self.sky_az_deg = 100.0 + RATE_DEG_S * (self.t_s - AOS_U)
        self.sky_el_deg = np.full_like(self.t_s, 30.0)
        self.az_deg, self.el_deg = self.sky_az_deg.copy(), self.sky_el_deg.copy()
        self.blocked = np.zeros(len(self.t_s), dtype=bool)
        self.flip = False

    def pose_at(self, t: float):
        return float(np.interp(t, self.t_s, self.az_deg)), float(np.interp(t, self.t_s, self.el_deg)), 0.0, 0.0


class Truth:
    """The satellite where it really is: the plan's track ``late_s`` later."""

    def __init__(self, plan: LinePlan, late_s: float):
        self.pred, self.late_s = Prediction(plan), late_s

    def position(self, u: float):
        az, el = self.pred.at(u - self.late_s)
        return float(az), float(el)


def geometry(**kw) -> Geometry:
    return Geometry(az_min_deg=-180.0, az_max_deg=540.0, el_min_deg=0.0, el_max_deg=90.0, **kw)


class Source:
    """The beam at the program's pose now (a perfect rotator) seeing ``truth``."""

    def __init__(self, truth, *, snr_db: float = 20.0, ceiling_db: float | None = None, refuse: str = ""):
        self.sim = SimulatedPower(SkySource(truth), fwhm_deg=FWHM, snr_db=snr_db, ceiling_db=ceiling_db, seed=3)
        self.refuse = refuse

    def read_at(self, status, u: float) -> Sample:
        if self.refuse:
            raise SignalRefused(self.refuse, "test")  # type: ignore[arg-type]
        value = float(self.sim.measure(u, status.az_deg, status.el_deg)[0])
        return judge(u, value, "dB", now_s=u, max_age_s=None, ceiling=self.sim.ceiling_db)


def fly(source_of, *, late_s: float = -30.0, duration_s: float = 400.0, floor_db: float | None = 0.0, **kw):
    """Run a StepTrack for ``duration_s`` from AOS; returns it, the programs uploaded and
    the true pointing error of the scan centre and of the beam at every update."""
    plan = LinePlan()
    truth = Truth(plan, late_s)
    ids = iter(range(1, 10_000))
    track = StepTrack(plan, "SAT", source_of(truth), geometry(), fwhm_deg=FWHM, new_id=lambda: next(ids),
                      floor_db=floor_db, **kw)
    off = AOS_U  # UTC minus the control clock: the clock is 0 at AOS
    program = None
    programs, beam_err = [], []
    for now_s in np.arange(0.0, duration_s, 0.2):
        az, el = (plan.pose_at(now_s + off)[:2] if program is None else program.pose_at(now_s)[:2])
        status = SimpleNamespace(az_deg=az, el_deg=el, t_s=now_s)
        new = track.step(status, now_s, off, "tracking")
        if new is not None:
            assert not new.problem(), new.problem()
            program = new
            programs.append(new)
        taz, tel = truth.position(now_s + off)
        beam_err.append(math.degrees(_angle(az, el, taz, tel)))
    return track, programs, np.array(beam_err)


def _angle(a1, e1, a2, e2):
    a1, e1, a2, e2 = map(math.radians, (a1, e1, a2, e2))
    return math.acos(min(1.0, math.sin(e1) * math.sin(e2) + math.cos(e1) * math.cos(e2) * math.cos(a1 - a2)))


def test_time_offset_found_and_beam_kept_on():
    track, programs, err = fly(Source)
    assert track.state == "tracking" and track.fits > 20
    # truth(t) = prediction(t + 30): the satellite passes 30 s early, a time offset of -30 s
    assert abs(track.time_offset_s - (-30.0)) < 2.0, track.status(AOS_U)
    # the search along the track (0, +h, -h, +2h, -2h: h = 16 s here) locks on its 5th
    # cycle; from then on the beam (scan included) stays within a quarter beamwidth
    locked = err[int(6 * CYCLE_S / 0.2):]
    assert locked.max() < FWHM / 4, locked.max()
    # what the prediction alone gives: 15 deg off, more than a beamwidth
    assert err[0] > FWHM
    st = track.status(AOS_U + 300)
    assert st["state"] == "tracking" and abs(st["az_offset_deg"] - 15.0) < 1.5
    assert any("found by its signal" in e for e in track.take_events())


def test_noise_only_refused_and_prediction_flown():
    track, programs, err = fly(lambda truth: Source(truth, snr_db=-60.0))
    assert track.fits == 0 and track.time_offset_s == 0.0
    assert track.state in ("lost", "searching") and "noise" in track.last_refusal
    # lost: the prediction, no scan: a program's poses are the plan's
    plan = LinePlan()
    assert any(np.allclose(p.az_deg, np.interp(np.array(p.t_s) + AOS_U, plan.t_s, plan.az_deg), atol=1e-6)
               and np.allclose(p.el_deg, 30.0) for p in programs)
    # and the beam was never moved more than the acquisition scan off the prediction
    assert err.max() > FWHM  # (the prediction is 15 deg off the satellite, which is silent)


def test_saturated_refused():
    track, _, _ = fly(lambda truth: Source(truth, snr_db=30.0, ceiling_db=5.0), duration_s=120.0)
    assert track.fits == 0 and track.time_offset_s == 0.0
    assert any("signal lost" in e and "saturated" in e for e in track.take_events())


def test_source_refusing_falls_back_to_prediction():
    track, programs, _ = fly(lambda truth: Source(truth, refuse="stale"), duration_s=120.0)
    assert track.fits == 0 and track.state in ("lost", "searching")
    assert "stale" in track.last_refusal


def test_signal_loss_mid_pass_keeps_the_time_offset():
    class Fading(Source):
        def read_at(self, status, u):
            if u > AOS_U + 200:  # the satellite goes silent
                raise SignalRefused("missing", "no answer")
            return super().read_at(status, u)
    track, programs, err = fly(Fading, duration_s=240.0)
    assert track.state == "lost" and abs(track.time_offset_s + 30.0) < 2.0
    assert any("signal lost" in e for e in track.take_events())
    last = programs[-1]
    # the prediction shifted by the time offset: no scan, no cross-track
    t = np.array(last.t_s)
    want = np.interp(t + AOS_U - track.time_offset_s, LinePlan().t_s, LinePlan().az_deg)
    assert np.allclose(last.az_deg, want, atol=1e-6) and np.allclose(last.el_deg, 30.0)


def test_fit_beam_refuses_noise_and_finds_a_peak():
    rng = np.random.default_rng(1)
    dx, dy = rng.uniform(-3, 3, 60), rng.uniform(-3, 3, 60)
    with pytest.raises(ScanRefused) as exc:
        fit_beam(dx, dy, 1.0 + 0.01 * rng.normal(size=60), fwhm_deg=FWHM, floor=1.0)
    assert exc.value.reason == "noise"
    s2 = (FWHM / 2.3548) ** 2
    p = 1.0 + np.exp(-((dx - 1.5) ** 2 + (dy + 0.7) ** 2) / (2 * s2)) + 0.01 * rng.normal(size=60)
    centre, cov, a, _ = fit_beam(dx, dy, p, fwhm_deg=FWHM, floor=1.0)
    assert abs(centre[0] - 1.5) < 0.2 and abs(centre[1] + 0.7) < 0.2


def test_program_shifted_clamped_and_zones_blocked():
    plan = LinePlan()
    zone = KeepOut(name="mast", az_min_deg=150.0, az_max_deg=160.0, el_min_deg=0.0, el_max_deg=45.0)
    g = geometry(zones=(zone,))
    p = build_program(plan, Prediction(plan), g, program_id=1, name="SAT", end="park", now_s=10.0,
                      utc_minus_clock_s=AOS_U, time_offset_s=-30.0, cross_deg=0.0,
                      radius_deg=TRACK_RADIUS_FWHM * FWHM)
    assert not p.problem()
    t = np.array(p.t_s)
    assert t[0] <= 10.0  # flown at once, no pre-positioning
    # after the scan: the plan 30 s ahead
    rest = t > 60.0
    assert np.allclose(np.array(p.az_deg)[rest], np.interp(t[rest] + AOS_U + 30.0, plan.t_s, plan.az_deg))
    # poses in the zone are blocked (the antenna waits at its edge)
    az = np.array(p.az_deg)
    assert all(b for a, b in zip(az, p.blocked) if 150.0 <= a <= 160.0)
    # the satellite sets 30 s early: its LOS pose is held to the predicted LOS
    assert abs(p.los_s - 600.0) < 1e-6 and np.allclose(az[t >= 570.0], plan.az_deg[-1])
    # near the horizon the scan never drives el into the limit
    low = LinePlan()
    low.el_deg[:] = low.sky_el_deg[:] = 0.5
    q = build_program(low, Prediction(low), g, program_id=2, name="SAT", end="park", now_s=10.0,
                      utc_minus_clock_s=AOS_U, time_offset_s=0.0, cross_deg=0.0, radius_deg=3.0)
    assert min(q.el_deg) >= 0.5 - 1e-9


def test_detection_is_normal_on_noise_and_sees_a_3_db_signal():
    """The lock's statistic: on noise alone about N(0, 1) (Student's t with the noise
    estimated: DETECT_Z = 4 about once in 10 000 cycles of 50 samples; a noise
    estimate half the truth would make it 2 % of them), a 3 dB peak (twice the sample noise) plainly
    over it; a slow change of the signal across the cycle does not inflate the noise."""
    rng = np.random.default_rng(5)
    z = np.array([detection_z(1.0 + 0.01 * rng.normal(size=50), 1.0) for _ in range(2000)])
    assert abs(np.mean(z)) < 0.15 and 0.85 < np.std(z) < 1.2
    assert np.sum(z >= DETECT_Z) <= 2
    ramp = 1.0 + 0.02 * np.linspace(0.5, 1.0, 50) + 0.01 * rng.normal(size=50)
    assert detection_z(ramp, 1.0) > 2 * DETECT_Z
    # a source repeating one value gives nothing to judge by
    assert not detection_z(np.full(50, 1.5), 1.0) >= DETECT_Z
