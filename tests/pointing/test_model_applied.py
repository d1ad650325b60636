"""The fitted pointing model, stored in the state directory, applied to every command and
every reported position (issue 38 part 4): with the simulator's beam off by an injected
error, a goto puts the true beam on the target once the model fitted to scans is
applied, and is off by the error without it; the status reports where the beam points;
keep-out zones are judged where the beam points. (Before, nothing read a stored model
and Geometry had no pointing model: the tests with the model fail there.)"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from urc.control.geometry import Geometry, KeepOut, model_offsets_deg
from urc.pointing import store
from urc.pointing.model import PointingModel
from urc.pointing.model_fit import fit_records
from urc.pointing.scan import pose_offset
from urc.peaking.simsource import world_beam

from .test_model import simulated_scans

#: a mount 2-3 deg off: an encoder zero error, a tilted mast, sag and a skewed beam
ERROR = PointingModel(ia_deg=3.0, ie_deg=-2.0, ca_deg=0.4, npae_deg=0.3, an_deg=0.6, aw_deg=-0.4, tf_deg=0.8)
SCAN_POSITIONS = [(az, el) for az in (30, 90, 150, 210, 270, 330) for el in (10, 35, 65)]
TARGETS = [(45.0, 20.0), (135.0, 50.0), (250.0, 12.0), (320.0, 70.0)]


def record(scan) -> dict:
    """A simulated scan result as urc stores one (the boresight frame, no model then)."""
    return {"az_deg": scan.az_m_deg, "el_deg": scan.el_m_deg, "dx_deg": scan.dx_deg, "dy_deg": scan.dy_deg,
            "dx_err_deg": scan.dx_err_deg, "dy_err_deg": scan.dy_err_deg, "offsets": {"az_deg": 0.0, "el_deg": 0.0}}


def fitted_doc() -> dict:
    return fit_records([record(s) for s in simulated_scans(ERROR, SCAN_POSITIONS, fwhm_deg=3.0, snr_db=25.0)],
                       source="test")


def sky_error_deg(a: tuple[float, float], b: tuple[float, float]) -> float:
    dx, dy = pose_offset(a[0], a[1], b[0], b[1])
    return math.hypot(float(dx), float(dy))


def goto_beam(b, az: float, el: float) -> tuple[tuple[float, float], object]:
    b.rot.goto(az, el)
    st = b.settle()
    _, baz, bel = world_beam(b.world, lambda now_s: now_s)()
    return (baz, bel), st


def injected_error_deg(az: float, el: float) -> float:
    """How far off the beam is with the boresight on (az, el)."""
    return sky_error_deg(tuple(float(v) for v in ERROR.beam_from_mech(az, el)), (az, el))


def make_bench(bench, tmp_path, doc: dict | None):
    if doc is not None:
        store.save_model(tmp_path / "state-tartu-urc", doc)
    return bench("tartu-urc", hardware={"sim": {"wind": False, "pointing_error": ERROR.as_dict()}})


def test_a_goto_puts_the_true_beam_on_the_target_with_the_fitted_model(bench, tmp_path):
    doc = fitted_doc()
    b = make_bench(bench, tmp_path, doc)
    assert b.rot.geometry.pointing_deg == store.model_terms(doc)
    for az, el in TARGETS:
        beam, st = goto_beam(b, az, el)
        injected = injected_error_deg(az, el)
        assert injected > 1.5
        assert sky_error_deg(beam, (az, el)) < 0.1 * injected, (az, el, beam)
        # and urc reports where the beam points: on the target
        assert sky_error_deg((st.az_deg, st.el_deg), (az, el)) < 0.1 * injected


def test_without_the_model_the_beam_is_off_by_the_injected_error(bench, tmp_path):
    b = make_bench(bench, tmp_path, None)
    assert b.rot.geometry.pointing_deg == ()
    for az, el in TARGETS:
        beam, st = goto_beam(b, az, el)
        assert sky_error_deg(beam, (az, el)) == pytest.approx(injected_error_deg(az, el), rel=0.1, abs=0.1)
        assert sky_error_deg((st.az_deg, st.el_deg), (az, el)) < 0.1  # (it believes it is on it)


def test_a_damaged_stored_model_is_not_applied_and_says_why(bench, tmp_path):
    path = store.model_path(tmp_path / "state-tartu-urc")
    path.parent.mkdir(parents=True)
    doc = fitted_doc()
    doc["terms"]["ia"]["value_deg"] = float("nan")
    path.write_text(json.dumps(doc))
    b = make_bench(bench, tmp_path, None)
    assert b.rot.geometry.pointing_deg == ()
    b.run(0.5)
    said = [e for e in b.rot.status().events if "pointing model not applied" in str(e)]
    assert said and "urc pointing clear" in str(said[0]), b.rot.status().events


def test_the_scalar_model_is_the_fitted_models():
    """Geometry's numpy-free terms are urc.pointing.model's (its fit's reference)."""
    rng = np.random.default_rng(1)
    for az, el in zip(rng.uniform(0, 360, 50), rng.uniform(-5, 89.9, 50)):
        assert model_offsets_deg(ERROR.as_terms(), az, el) == pytest.approx(ERROR.offsets_deg(az, el), abs=1e-12)


def test_forward_and_inverse_agree_and_stay_in_the_sky():
    g = Geometry(0.0, 450.0, 0.0, 180.0, flip=True, pointing_deg=ERROR.as_terms())
    for az in range(0, 360, 15):
        for el in (3.0, 10.0, 45.0, 80.0, 88.0, 89.9, 90.0):
            poses = g.candidates(az, el)
            assert poses, (az, el)
            for pose in poses:
                s_az, s_el = g.to_sky(*pose)
                assert s_el <= 90.0 + 1e-9
                assert sky_error_deg((s_az, s_el), (az, el)) < 1e-6, (az, el, pose)


def test_keep_out_zones_are_judged_where_the_beam_points():
    """A zone from az 100 to 120: with the beam 2 deg anticlockwise of the boresight (IA
    2), the boresight at az 121 puts the beam at 119, inside; at 123 the beam is at 121."""
    zone = KeepOut("mast", 100.0, 120.0, 0.0, 30.0)
    g = Geometry(0.0, 450.0, 0.0, 90.0, zones=(zone,), zone_margin_deg=0.0, pointing_deg=(2.0,) + (0.0,) * 6)
    assert g.zone_at(121.0, 10.0) is zone
    assert g.zone_at(123.0, 10.0) is None
    # a goto of az 121 (outside) is planned to the boresight 123, outside too
    route = g.plan((200.0, 10.0), 121.0, 10.0, (3.0, 3.0))
    assert route is not None and route[-1][0] == pytest.approx(123.0)
    assert g.plan((200.0, 10.0), 119.0, 10.0, (3.0, 3.0)) is None  # the beam would be in the zone


def test_a_single_axis_rotator_takes_no_model():
    from dataclasses import replace

    from urc.profiles import get_profile
    from urc.model.settings import RotatorSettings

    caps = get_profile("tartu-urc").single_axis()
    s = replace(RotatorSettings.from_caps(caps), pointing_deg=ERROR.as_terms()).completed()
    assert s.pointing_deg == () and s.geometry().pointing_deg == ()
