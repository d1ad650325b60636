"""The pointing error model: forward and inverse agree, each term does what its name
says (the tilt checked against an exact rotation of the axis), and a least-squares fit
of scans recovers injected terms within their stated uncertainty. (main has no pointing
model: every test fails there.)"""

from __future__ import annotations

import math

import numpy as np
import pytest

from urc.errors import CalibrationError
from urc.pointing.fit import fit_cross
from urc.pointing.model import TERMS, PointingModel
from urc.pointing.model_fit import ScanResult, fit_model, scan_result
from urc.pointing.scan import cross_scan, offset_pose, pose_offset
from urc.peaking.simsource import SimulatedPower, SkySource

FULL = PointingModel(ia_deg=0.8, ie_deg=-0.5, ca_deg=0.2, npae_deg=0.15, an_deg=0.3, aw_deg=-0.25, tf_deg=0.6)


def test_forward_inverse_round_trip_over_the_sky():
    az, el = np.meshgrid(np.arange(0.0, 360.0, 7.5), np.arange(0.0, 86.0, 5.0))
    beam_az, beam_el = FULL.beam_from_mech(az, el)
    back_az, back_el = FULL.mech_from_beam(beam_az, beam_el)
    assert np.max(np.abs((back_az - az + 180) % 360 - 180)) < 1e-9
    assert np.max(np.abs(back_el - el)) < 1e-9
    # scalars in, floats out
    a, e = FULL.mech_from_beam(*FULL.beam_from_mech(10.0, 40.0))
    assert a == pytest.approx(10.0, abs=1e-9) and e == pytest.approx(40.0, abs=1e-9)


def test_each_term_in_its_own_words():
    assert PointingModel(ia_deg=1).offsets_deg(123, 45) == pytest.approx((1.0, 0.0))
    assert PointingModel(ie_deg=1).offsets_deg(123, 45) == pytest.approx((0.0, 1.0))
    assert PointingModel(tf_deg=1).offsets_deg(0, 0) == pytest.approx((0.0, 1.0))      # sag: most at the horizon
    assert PointingModel(tf_deg=1).offsets_deg(0, 60) == pytest.approx((0.0, 0.5))
    assert PointingModel(ca_deg=1).offsets_deg(0, 60) == pytest.approx((2.0, 0.0))     # 1/cos E
    assert PointingModel(npae_deg=1).offsets_deg(0, 45) == pytest.approx((1.0, 0.0))   # tan E
    # the beam looking toward the lean of the axis is low (mech - beam > 0)
    lean_east = PointingModel.with_tilt(0.5, 90.0)
    assert lean_east.offsets_deg(90, 30)[1] == pytest.approx(0.5)
    assert lean_east.offsets_deg(270, 30)[1] == pytest.approx(-0.5)
    assert lean_east.tilt == pytest.approx((0.5, 90.0))
    with pytest.raises(ValueError):
        PointingModel(ia_deg=float("nan"))
    with pytest.raises(ValueError):
        PointingModel.from_dict({"xx": 1.0})
    assert PointingModel.from_dict({"IA": 1.0, "tf_deg": 2.0}) == PointingModel(ia_deg=1.0, tf_deg=2.0)


def exact_tilted_beam(tilt_deg, toward_deg, az_m, el_m):
    """Where a boresight at mechanical (az_m, el_m) points when the azimuth axis leans
    ``tilt_deg`` toward ``toward_deg``: the mount's frame rotated rigidly (east, north, up)."""
    a, e = math.radians(az_m), math.radians(el_m)
    v = np.array([math.cos(e) * math.sin(a), math.cos(e) * math.cos(a), math.sin(e)])
    p, t = math.radians(toward_deg), math.radians(tilt_deg)
    k = np.array([-math.cos(p), math.sin(p), 0.0])  # horizontal axis that tips up toward p
    v = v * math.cos(t) + np.cross(k, v) * math.sin(t) + k * (k @ v) * (1 - math.cos(t))
    return math.degrees(math.atan2(v[0], v[1])) % 360.0, math.degrees(math.asin(v[2]))


@pytest.mark.parametrize("toward_deg", [0.0, 90.0, 200.0])
@pytest.mark.parametrize("az_m, el_m", [(0.0, 10.0), (45.0, 40.0), (160.0, 70.0), (300.0, 25.0)])
def test_the_axis_tilt_terms_match_an_exact_rotation(toward_deg, az_m, el_m):
    tilt = 0.3
    model = PointingModel.with_tilt(tilt, toward_deg)
    want = exact_tilted_beam(tilt, toward_deg, az_m, el_m)
    got = model.beam_from_mech(az_m, el_m)
    # first order: what is left is of order tilt^2 (1 + tan^2 E); a wrong sign or a
    # swapped sin/cos would be off by the tilt itself (0.3 deg)
    tol_deg = math.degrees(math.radians(tilt) ** 2) * (1 + math.tan(math.radians(el_m)) ** 2)
    assert abs((got[0] - want[0] + 180) % 360 - 180) * math.cos(math.radians(el_m)) < tol_deg
    assert abs(got[1] - want[1]) < tol_deg


def simulated_scans(model, positions, *, fwhm_deg=3.0, snr_db=25.0, seed=0):
    """Cross scans (beam model + radiometer noise, no rotator) at sky positions."""
    out = []
    for i, (az, el) in enumerate(positions):
        src = SkySource.beacon(az, el)
        power = SimulatedPower(src, fwhm_deg=fwhm_deg, snr_db=snr_db, seed=seed + i)
        plan = cross_scan(fwhm_deg)
        u, pa, pe = (np.array(c) for c in zip(*plan.poses(src, 0.0)))
        v = power.measure(u, *model.beam_from_mech(pa, pe))
        dx, dy = pose_offset(pa, pe, az, el)
        fit = fit_cross(dx, dy, v, "dB", [p.leg for p in plan.points], fwhm_deg=fwhm_deg,
                        half_width_deg=plan.half_width_deg)
        # the mechanical pose where the beam was on the source: the target plus the offset
        out.append(scan_result(*offset_pose(az, el, fit.dx_deg, fit.dy_deg), fit))
    return out


POSITIONS = [(az, el) for az in (60, 110, 160, 210, 260, 310) for el in (12, 40, 70)]


def test_a_model_fit_recovers_injected_terms_within_their_stated_uncertainty():
    fit = fit_model(simulated_scans(FULL, POSITIONS))
    got, want = fit.model.as_dict(), FULL.as_dict()
    for t in TERMS:
        err = fit.errors_deg[t]
        assert 0 < err < 0.2, t
        assert abs(got[f"{t}_deg"] - want[f"{t}_deg"]) < 3 * err, (t, got[f"{t}_deg"], want[f"{t}_deg"], err)
    assert fit.residual_rms_deg < 0.1 and fit.scans == len(POSITIONS)
    # the fitted model points the beam where it is: commands through it land on the source
    for az, el in POSITIONS[:4]:
        m = fit.model.mech_from_beam(az, el)
        beam = FULL.beam_from_mech(*m)
        assert math.hypot(((beam[0] - az + 180) % 360 - 180) * math.cos(math.radians(el)), beam[1] - el) < 0.1


def test_scans_at_one_elevation_cannot_separate_ia_ca_npae():
    scans = [ScanResult(az, 30.0, 0.1, 0.1, 0.01, 0.01) for az in range(0, 360, 30)]
    with pytest.raises(CalibrationError, match="apart"):
        fit_model(scans)
    fit = fit_model(scans, ("ia", "ie", "an", "aw"))  # fewer terms: fine
    assert fit.model.ia_deg == pytest.approx(0.1 / math.cos(math.radians(30)))
    with pytest.raises(CalibrationError, match="at least"):
        fit_model(scans[:3])
