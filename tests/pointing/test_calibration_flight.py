"""The bench's Sun calibration harness (urc.testing.calibration_flight): a cross scan of
the simulated Sun flown on the simulated rotator finds an offset that, applied, puts the
true beam on the Sun; the correction arithmetic is checked against the error model
itself. (The module is new: every test here fails on main before it.)"""

from __future__ import annotations

import math

import numpy as np

from urc.pointing.model import PointingModel
from urc.testing.calibration_flight import SunCalibrator, corrected_error_deg, mech_pose, scan_half_width_fwhm
from urc.tracking.station import Station

TARTU = Station(58.378, 26.729, 70.0, "Tartu")
NINE_Z = 1718960400.0  # 2024-06-21T09:00Z: the Sun near el 52 at Tartu
MIDNIGHT_Z = 1718928000.0
ERROR = PointingModel(ia_deg=1.2, ie_deg=-1.8, ca_deg=0.3, an_deg=0.4, aw_deg=-0.3, tf_deg=0.9)


def test_a_sun_scan_finds_the_offset_that_puts_the_beam_on_the_sun(tmp_path):
    fwhm_deg = 10.0
    cal = SunCalibrator(TARTU, ERROR, fwhm_deg=fwhm_deg, snr_db=30.0, state_dir=tmp_path)
    s = cal.scan(NINE_Z)
    assert s is not None and s.fit is not None, s
    assert 40.0 < s.sun_el_deg < 60.0
    # from park (az 0, el 90) to the Sun at 6 deg/s, then 32 points: minutes, not hours
    assert 30.0 < s.duration_s < 300.0
    before = float(corrected_error_deg(ERROR, s.mid_az_deg, s.mid_el_deg))
    after = float(corrected_error_deg(ERROR, s.mid_az_deg, s.mid_el_deg, offset=(s.fit.dx_deg, s.fit.dy_deg)))
    assert before > 1.0 and after < 0.1 * fwhm_deg, (before, after)
    # the pose with the beam on the Sun is where the error model puts it
    am, em = ERROR.mech_from_beam(s.mid_az_deg, s.mid_el_deg)
    pm = mech_pose(s)
    assert abs((pm[0] - am + 180) % 360 - 180) * math.cos(math.radians(em)) < 0.1 * fwhm_deg
    assert abs(pm[1] - em) < 0.1 * fwhm_deg


def test_no_scan_while_the_sun_leaves_no_room(tmp_path):
    cal = SunCalibrator(TARTU, ERROR, fwhm_deg=10.0, snr_db=30.0, state_dir=tmp_path)
    assert cal.scan(MIDNIGHT_Z) is None  # below the horizon
    assert cal.clock.now_s() == 0.0       # nothing flown
    assert scan_half_width_fwhm(31.0, 30.0) == 1.0
    assert scan_half_width_fwhm(45.0, 3.0) == 1.5
    assert scan_half_width_fwhm(5.0, 10.0) < 1.0


def test_the_corrections_arithmetic_against_the_model_itself():
    az, el = np.array([100.0, 200.0, 250.0]), np.array([15.0, 40.0, 65.0])
    assert np.all(corrected_error_deg(ERROR, az, el) > 0.5)
    assert np.all(corrected_error_deg(ERROR, az, el, model=ERROR) < 1e-6)  # the true model corrects exactly
    assert np.all(corrected_error_deg(None, az, el) == 0.0)
    # an encoder zero alone is exactly an offset: dx = IA cos(el_m), dy = IE
    ia = PointingModel(ia_deg=2.0, ie_deg=-1.0)
    am, em = ia.mech_from_beam(az[1], el[1])
    off = ((am - az[1]) * math.cos(math.radians(em)), em - el[1])
    assert float(corrected_error_deg(ia, az[1], el[1], offset=off)) < 1e-6
