"""A cross scan flown on the simulated rotator, whose beam is off by an injected
pointing error model, finds that error from the simulated source's power alone; a
noise-only or saturated scan is refused. (On today's main there is no simulated source,
no pointing error in the simulator and no fit: every test here fails there.)"""

from __future__ import annotations

import math

import numpy as np
import pytest

from urc.assembly import build_rotator
from urc.clock import VirtualClock
from urc.config import Config
from urc.pointing.fit import ScanRefused, fit_cross, fit_gauss_2d
from urc.pointing.model import PointingModel
from urc.pointing.scan import cross_scan, pose_offset, raster_scan
from urc.peaking.simsource import SimulatedPower, SkySource, world_beam
from urc.testing.scan_flight import fly_scan

BEACON_AZ_DEG, BEACON_EL_DEG = 120.0, 30.0
T0_UNIX_S = 1704110400.0
#: an encoder zero of a degree, some sag, a tilted mast and a skewed beam
ERROR = PointingModel(ia_deg=1.2, ie_deg=-1.8, ca_deg=0.3, an_deg=0.4, aw_deg=-0.3, tf_deg=0.9)


def expected_offset(model: PointingModel) -> tuple[float, float]:
    """(dx, dy) of the pose that puts the beam on the beacon, from the beacon."""
    az_m, el_m = model.mech_from_beam(BEACON_AZ_DEG, BEACON_EL_DEG)
    return tuple(float(v) for v in pose_offset(az_m, el_m, BEACON_AZ_DEG, BEACON_EL_DEG))  # type: ignore[return-value]


def sim_rotator(tmp_path, model: PointingModel | None, offsets: dict | None = None):
    cfg = Config.from_dict({"rotator": {"profile": "tartu-urc"}, "hardware": {"sim": {"wind": False}},
                            "offsets": offsets or {}})
    clock = VirtualClock(0.0)
    rot = build_rotator(cfg, clock, tmp_path, fast_virtual=True)
    rot.hw.world.pointing_error = model
    return rot, clock


def fly(tmp_path, model, *, fwhm_deg=10.0, snr_db=30.0, ceiling_db=None, seed=3):
    rot, clock = sim_rotator(tmp_path, model)
    src = SkySource.beacon(BEACON_AZ_DEG, BEACON_EL_DEG)

    def unix_at(now_s: float) -> float:
        return T0_UNIX_S + now_s
    power = SimulatedPower(src, fwhm_deg=fwhm_deg, snr_db=snr_db, ceiling_db=ceiling_db, seed=seed,
                           beam_at=world_beam(rot.hw.world, unix_at))
    plan = cross_scan(fwhm_deg, step_fwhm=0.25, settle_s=0.2, dwell_s=0.2)
    data = fly_scan(rot, clock, plan, src, power, unix_at, samples_per_point=2)
    return plan, data


def test_a_flown_cross_scan_recovers_the_injected_offset_within_a_tenth_of_the_beam(tmp_path):
    fwhm_deg = 10.0
    plan, data = fly(tmp_path, ERROR, fwhm_deg=fwhm_deg)
    dx, dy, v, legs = data.arrays()
    fit = fit_cross(dx, dy, v, data.unit, legs, fwhm_deg=fwhm_deg, half_width_deg=plan.half_width_deg)
    want_dx, want_dy = expected_offset(ERROR)
    assert math.hypot(want_dx, want_dy) > 1.0  # the injected error is worth finding
    assert abs(fit.dx_deg - want_dx) < 0.1 * fwhm_deg
    assert abs(fit.dy_deg - want_dy) < 0.1 * fwhm_deg
    # and the uncertainty it states is honest (4 sigma, plus the sensor's 0.1 deg step)
    assert abs(fit.dx_deg - want_dx) < 4 * fit.dx_err_deg + 0.1
    assert abs(fit.dy_deg - want_dy) < 4 * fit.dy_err_deg + 0.1
    assert fit.az.fwhm_deg[0] == pytest.approx(fwhm_deg, rel=0.2)


def test_the_true_beam_ignores_the_controllers_offsets(tmp_path):
    """The simulated beam is where the iron points: the axes' truth through the world's
    error model. The controller's [offsets] are its belief, which a calibration corrects:
    with the encoders reading 2 deg high in azimuth (IA = 2) and [offsets] az -2 (the
    right correction), a goto of the beacon puts the true beam on it. (Before, the beam
    was taken through the configured offsets as well, counting the error twice: 2 deg off.)"""
    from urc.rotator.loop import run_virtual

    rot, clock = sim_rotator(tmp_path, PointingModel(ia_deg=2.0), offsets={"az_deg": -2.0})
    rot.goto(BEACON_AZ_DEG, BEACON_EL_DEG)
    run_virtual(rot, clock, 200.0, until=lambda s: not s.moving and s.az.mode in ("holding", "idle")
                and abs(s.az_deg - BEACON_AZ_DEG) < 0.1 and abs(s.el_deg - BEACON_EL_DEG) < 0.1)
    _, az, el = world_beam(rot.hw.world, lambda now_s: T0_UNIX_S + now_s)()
    assert abs(az - BEACON_AZ_DEG) < 0.2 and abs(el - BEACON_EL_DEG) < 0.2, (az, el)
    # a south-zero rotator's mechanical zero points south: the iron's own bearing
    _, az_s, _ = world_beam(rot.hw.world, lambda now_s: T0_UNIX_S + now_s, az_zero_deg=180.0)()
    assert abs((az_s - az) % 360.0 - 180.0) < 1e-9


def test_with_the_model_off_the_scan_finds_no_offset(tmp_path):
    """Off by default: the same scan on a perfect mount finds the beacon where it is."""
    plan, data = fly(tmp_path, None)
    dx, dy, v, legs = data.arrays()
    fit = fit_cross(dx, dy, v, data.unit, legs, fwhm_deg=10.0, half_width_deg=plan.half_width_deg)
    assert abs(fit.dx_deg) < 0.3 and abs(fit.dy_deg) < 0.3


def test_a_saturating_receiver_is_refused(tmp_path):
    # the receiver tops out 3 dB above the floor: the peak (10.4 dB) is clipped
    plan, data = fly(tmp_path, ERROR, ceiling_db=3.0)
    assert data.refused.get("saturated", 0) > 0
    dx, dy, v, legs = data.arrays()
    with pytest.raises(ScanRefused) as exc:
        fit_cross(dx, dy, v, data.unit, legs, fwhm_deg=10.0, saturated=data.refused["saturated"])
    assert exc.value.reason == "saturated"


def test_clipped_values_given_without_the_sources_word_are_refused_by_the_ceiling():
    x = np.linspace(-15, 15, 31)
    db1 = np.minimum(10 * np.log10(1 + 10 * np.exp(-x ** 2 / 36)), 6.0)
    with pytest.raises(ScanRefused) as exc:
        fit_cross(np.concatenate([x, 0 * x]), np.concatenate([0 * x, x]), np.concatenate([db1, db1]), "dB", ["az"] * 31 + ["el"] * 31,
                  fwhm_deg=10.0, ceiling=6.0)
    assert exc.value.reason == "saturated"


@pytest.mark.parametrize("seed", range(5))
def test_noise_only_is_refused(seed):
    """No source at all (the beam far off it): pure radiometer noise is never fitted."""
    src = SkySource.beacon(BEACON_AZ_DEG, BEACON_EL_DEG)
    power = SimulatedPower(src, fwhm_deg=10.0, snr_db=30.0, seed=seed)
    plan = cross_scan(10.0)
    far = [(u, (az + 90.0) % 360.0, el) for u, az, el in plan.poses(src, T0_UNIX_S)]
    v = power.measure(*(np.array(c) for c in zip(*far)))
    dx = np.array([p.dx_deg for p in plan.points])
    dy = np.array([p.dy_deg for p in plan.points])
    with pytest.raises(ScanRefused) as exc:
        fit_cross(dx, dy, v, "dB", [p.leg for p in plan.points], fwhm_deg=10.0)
    assert exc.value.reason in ("noise", "width", "off_scan")


def test_a_raster_scan_finds_the_offset_in_both_axes():
    fwhm_deg = 3.0
    src = SkySource.beacon(BEACON_AZ_DEG, BEACON_EL_DEG)
    power = SimulatedPower(src, fwhm_deg=fwhm_deg, snr_db=30.0, seed=7)
    plan = raster_scan(fwhm_deg)
    poses = plan.poses(src, T0_UNIX_S)
    u, az, el = (np.array(c) for c in zip(*poses))
    v = power.measure(u, *ERROR.beam_from_mech(az, el))
    dx, dy = pose_offset(az, el, BEACON_AZ_DEG, BEACON_EL_DEG)
    fit = fit_gauss_2d(dx, dy, v, "dB", fwhm_deg=fwhm_deg, half_width_deg=plan.half_width_deg)
    want_dx, want_dy = expected_offset(ERROR)
    assert abs(fit.offset_deg[0] - want_dx) < 0.1 * fwhm_deg
    assert abs(fit.offset_deg[1] - want_dy) < 0.1 * fwhm_deg
