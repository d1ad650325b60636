"""The calibration scan as the web hub runs it (urc.peaking.procedure): a state machine
fed each status, issuing gotos, reading the simulator's source from the status' truth
through the configured pointing error. On main before this there was no such procedure
(the module did not exist): every test here fails there."""

from __future__ import annotations

import math

import pytest

from urc.config import Config
from urc.pointing.model import PointingModel
from urc.peaking.procedure import ScanCalibration, ScanSetupError, make_sky, make_source
from urc.pointing.scan import cross_scan, pose_offset

BEACON_AZ_DEG, BEACON_EL_DEG = 120.0, 30.0
T0_UNIX_S = 1704110400.0
FWHM_DEG = 10.0


def unix_at(status) -> float:
    return T0_UNIX_S + status.t_s


def scan(bench, error: dict | None, *, snr_db: float = 30.0, az_deg=BEACON_AZ_DEG, el_deg=BEACON_EL_DEG,
         rotator: dict | None = None):
    hw = {"sim": {"wind": False, **({"pointing_error": error} if error else {})}}
    b = bench("tartu-urc", hardware=hw, pointing={"beamwidth_deg": FWHM_DEG, "snr_db": snr_db},
              rotator=dict(rotator or {}))
    cfg = b.cfg
    sky = make_sky("beacon", az_deg=az_deg, el_deg=el_deg)
    source = make_source(cfg.pointing, cfg.hardware.sim.pointing_error, sky, seed=3,
                         az_zero_deg=cfg.rotator.zero_offset_deg)
    plan = cross_scan(FWHM_DEG, step_fwhm=0.25, settle_s=0.2, dwell_s=0.4)
    proc = ScanCalibration(b.rot, sky, source, fwhm_deg=FWHM_DEG, plan=plan, samples_per_point=2,
                           target="beacon", unix_at=unix_at)
    b.run(900.0, on_tick=proc.poll, until=lambda s: proc.finished)
    return b, proc


def expected_offset(model: PointingModel) -> tuple[float, float]:
    """(daz, del) the antenna reads off the beacon when its beam is on it."""
    az_m, el_m = model.mech_from_beam(BEACON_AZ_DEG, BEACON_EL_DEG)
    dx, dy = pose_offset(az_m, el_m, BEACON_AZ_DEG, BEACON_EL_DEG)
    return float(dx) / math.cos(math.radians(BEACON_EL_DEG)), float(dy)


def test_the_scan_recovers_an_injected_encoder_zero_error_within_a_tenth_of_the_beam(bench):
    error = {"ia_deg": 2.5, "ie_deg": -1.5}
    b, proc = scan(bench, error)
    assert proc.state == "done", proc.as_dict()
    r = proc.result
    want_az, want_el = expected_offset(PointingModel.from_dict(error))
    assert abs(r["az_offset_deg"] - want_az) < 0.1 * FWHM_DEG
    assert abs(r["el_offset_deg"] - want_el) < 0.1 * FWHM_DEG
    # the offsets it offers put the report on the beam: minus the encoder zero error
    assert r["offsets_suggested"]["az_deg"] == pytest.approx(-2.5, abs=0.1 * FWHM_DEG)
    assert r["offsets_suggested"]["el_deg"] == pytest.approx(1.5, abs=0.1 * FWHM_DEG)
    assert r["az_offset_err_deg"] > 0 and r["el_offset_err_deg"] > 0
    assert len(proc.report()["samples"]) == 2 * len(proc.plan.points)
    assert "samples" not in proc.as_dict()["result"]  # (the live frames stay small)


def test_a_noise_only_source_is_refused(bench):
    # the beam is 9 deg (4.5 beamwidths) off the boresight: the scan sees only noise
    hw = {"sim": {"wind": False, "pointing_error": {"ia_deg": 9.0}}}
    b = bench("tartu-urc", hardware=hw, pointing={"beamwidth_deg": 2.0, "snr_db": 30.0})
    sky = make_sky("beacon", az_deg=BEACON_AZ_DEG, el_deg=BEACON_EL_DEG)
    source = make_source(b.cfg.pointing, b.cfg.hardware.sim.pointing_error, sky, seed=5, az_zero_deg=0.0)
    proc = ScanCalibration(b.rot, sky, source, fwhm_deg=2.0, samples_per_point=2,
                           plan=cross_scan(2.0, settle_s=0.2, dwell_s=0.4), unix_at=unix_at)
    b.run(900.0, on_tick=proc.poll, until=lambda s: proc.finished)
    assert proc.state == "failed"
    assert proc.result["refused"] in ("noise", "width", "off_scan")
    assert proc.error.startswith("refused")
    assert proc.report()["samples"]  # the samples are kept for the plot


def test_a_sun_scan_needs_the_station():
    with pytest.raises(ScanSetupError, match="station"):
        make_sky("sun", Config.from_dict({}).station)


def test_a_sim_source_on_hardware_without_truth_fails_with_the_reason(bench):
    b = bench("tartu-urc", pointing={"beamwidth_deg": FWHM_DEG})
    sky = make_sky("beacon", az_deg=BEACON_AZ_DEG, el_deg=BEACON_EL_DEG)
    proc = ScanCalibration(b.rot, sky, make_source(b.cfg.pointing, None, sky, az_zero_deg=0.0), fwhm_deg=FWHM_DEG,
                           unix_at=unix_at)
    status = b.rot.status()
    from dataclasses import replace
    proc.poll(replace(status, sim_truth=None))
    assert proc.state == "failed" and "simulator" in proc.error


def test_a_south_zero_rotator_scans_the_same_sky(bench):
    """[rotator] zero = "south": the simulator's axes count from south (compass = axis
    + 180). The simulated source must see the beam at the compass bearing the iron
    points to; taking the axis angle as a compass one put the beam 180 deg away from the
    beacon (the scan was refused as noise)."""
    error = {"ia_deg": 2.5, "ie_deg": -1.5}
    b, proc = scan(bench, error, rotator={"zero": "south"})
    assert b.cfg.rotator.zero_offset_deg == 180.0
    truth_az = b.rot.status().sim_truth["az"]["deg"]
    assert abs((b.rot.status().az_deg - truth_az) % 360.0 - 180.0) < 5.0  # the frames differ by 180
    assert proc.state == "done", proc.as_dict()
    want_az, want_el = expected_offset(PointingModel.from_dict(error))
    assert abs(proc.result["az_offset_deg"] - want_az) < 0.1 * FWHM_DEG
    assert abs(proc.result["el_offset_deg"] - want_el) < 0.1 * FWHM_DEG
