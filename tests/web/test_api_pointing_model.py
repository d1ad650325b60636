"""`urc pointing show|fit|clear` against the real API app (in process, virtual clock),
and the scans a calibration stores for the fit. (Before: no `pointing` command, no
/api/calibration/pointing-model, no scan stored: every test here fails there.)"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import click
import pytest
from click.testing import CliRunner

from urc.cli import main
from urc import cli_pointing as pcli
from urc.pointing import store
from urc.pointing.model import PointingModel
from urc.peaking.procedure import ScanCalibration, make_sky, make_source
from urc.pointing.scan import cross_scan, pose_offset
from urc.peaking.simsource import world_beam

from pointing.test_model import simulated_scans
from pointing.test_model_applied import ERROR, SCAN_POSITIONS, record, sky_error_deg


@pytest.fixture
def cli(make_client):
    """``cli(*args)``: `urc ...` with its requests answered by the app."""
    c = make_client("tartu-urc", hardware={"sim": {"wind": False, "pointing_error": ERROR.as_dict()}})

    def request(url, config_path, method, path, body=None):
        r = c.request(method, path, json=body) if body is not None else c.request(method, path)
        if r.status_code >= 400:
            raise click.ClickException(f"refused ({r.status_code}): {r.json().get('error') or r.json()}")
        return r.json()

    def run(*args):
        import unittest.mock as mock
        with mock.patch.object(pcli, "_request", request):
            return CliRunner().invoke(main, list(args))
    run.client = c
    return run


def scans_file(tmp_path, positions=SCAN_POSITIONS) -> str:
    path = tmp_path / "scans.jsonl"
    path.write_text("".join(json.dumps(record(s)) + "\n" for s in simulated_scans(ERROR, positions)))
    return str(path)


def test_show_fit_and_clear_the_model(cli, tmp_path):
    rot = cli.client.bench.rot
    r = cli("pointing", "show")
    assert r.exit_code == 0, r.output
    assert "no pointing model stored" in r.output and "scans stored: 0" in r.output
    # nothing to fit yet: said so, nothing stored
    r = cli("pointing", "fit")
    assert r.exit_code != 0 and "no scans" in r.output and "urc calibrate sun" in r.output
    r = cli("pointing", "fit", "--scans", scans_file(tmp_path))
    assert r.exit_code == 0, r.output
    assert "IA" in r.output and "+- " in r.output and "residual RMS" in r.output and "applied now" in r.output
    cli.client.bench.run(0.1)  # (the rotator takes new settings at its next tick)
    doc = store.load_model(cli.client.bench.state_dir)
    assert doc is not None and len(doc["scans"]) == len(SCAN_POSITIONS) and doc["date"].endswith("Z")
    for name in store.POINTING_TERMS:
        t = doc["terms"][name]
        assert abs(t["value_deg"] - getattr(ERROR, f"{name}_deg")) < 3 * t["err_deg"] + 0.02, name
    # applied at once to the running rotator: a goto puts the true beam on the target
    assert rot.geometry.pointing_deg == store.model_terms(doc)
    rot.goto(200.0, 40.0)
    cli.client.bench.settle()
    _, baz, bel = world_beam(cli.client.bench.world, lambda s: s)()
    assert sky_error_deg((baz, bel), (200.0, 40.0)) < 0.2
    r = cli("pointing", "show")
    assert "in force: yes" in r.output and "TF" in r.output
    r = cli("pointing", "clear")
    assert r.exit_code == 0 and "pointing model removed" in r.output
    cli.client.bench.run(0.1)
    assert store.load_model(cli.client.bench.state_dir) is None and rot.geometry.pointing_deg == ()
    assert "no pointing model stored" in cli("pointing", "show").output


def test_bad_scans_and_terms_are_refused_with_the_reason(cli, tmp_path):
    bad = tmp_path / "bad.jsonl"
    good = json.loads(open(scans_file(tmp_path)).readline())
    bad.write_text(json.dumps(good) + "\n" + json.dumps({**good, "dx_err_deg": None}) + "\n")
    r = cli("pointing", "fit", "--scans", str(bad))
    assert r.exit_code != 0 and "bad.jsonl:2: dx_err_deg must be a finite number" in r.output
    r = cli("pointing", "fit", "--scans", str(tmp_path / "missing.jsonl"))
    assert r.exit_code != 0 and "no such scan file" in r.output
    r = cli("pointing", "fit", "--scans", scans_file(tmp_path), "--terms", "IA,XY")
    assert r.exit_code != 0 and "unknown term(s) xy" in r.output
    # one elevation cannot tell IA, CA and NPAE apart: refused, naming them
    r = cli("pointing", "fit", "--scans", scans_file(tmp_path, [(a, 30.0) for a in range(0, 360, 45)]))
    assert r.exit_code != 0 and "apart" in r.output
    # the same scans fit for the encoder zeros alone
    r = cli("pointing", "fit", "--scans", scans_file(tmp_path, [(a, 30.0) for a in range(0, 360, 45)]),
            "--terms", "IA,IE")
    assert r.exit_code == 0, r.output
    assert "(not fitted)" in r.output
    assert store.load_model(cli.client.bench.state_dir) is not None
    # nothing saved by a refusal: the model stays as it was
    before = store.load_model(cli.client.bench.state_dir)
    assert cli("pointing", "fit", "--scans", str(bad)).exit_code != 0
    assert store.load_model(cli.client.bench.state_dir) == before


def test_a_damaged_stored_model_is_shown_as_such(cli):
    path = store.model_path(cli.client.bench.state_dir)
    path.write_text("{ not json")
    r = cli("pointing", "show")
    assert r.exit_code == 0 and "stored model unusable" in r.output and "urc pointing clear" in r.output


# ----------------------------------------------------------------------- stored scans
BEACON_AZ_DEG, BEACON_EL_DEG, FWHM_DEG = 120.0, 30.0, 10.0


def scan(b, kept: list) -> ScanCalibration:
    sky = make_sky("beacon", az_deg=BEACON_AZ_DEG, el_deg=BEACON_EL_DEG)
    source = make_source(b.cfg.pointing, b.cfg.hardware.sim.pointing_error, sky, seed=3, az_zero_deg=0.0)
    proc = ScanCalibration(b.rot, sky, source, fwhm_deg=FWHM_DEG, samples_per_point=2, target="beacon",
                           plan=cross_scan(FWHM_DEG, step_fwhm=0.25, settle_s=0.2, dwell_s=0.4),
                           unix_at=lambda s: 1704110400.0 + s.t_s, record=kept.append)
    b.run(900.0, on_tick=proc.poll, until=lambda s: proc.finished)
    assert proc.state == "done", proc.as_dict()
    return proc


def test_a_scan_is_stored_in_the_models_frame_whatever_model_is_in_force(bench):
    """Flown with no model and with one in force, a scan stores the same boresight pose
    and offset (what the fit needs); only what it reports differs."""
    error = PointingModel(ia_deg=2.5, ie_deg=-1.5)
    b = bench("tartu-urc", hardware={"sim": {"wind": False, "pointing_error": error.as_dict()}},
              pointing={"beamwidth_deg": FWHM_DEG, "snr_db": 30.0})
    kept: list = []
    first = scan(b, kept)
    b.rot.reconfigure(replace(b.rot.settings, pointing_deg=error.as_terms()))
    b.run(1.0)
    assert b.rot.geometry.pointing_deg == error.as_terms()
    second = scan(b, kept)
    assert len(kept) == 2 and first.result["stored"] and second.result["stored"]
    bore_az, bore_el = (float(v) for v in error.mech_from_beam(BEACON_AZ_DEG, BEACON_EL_DEG))
    want = pose_offset(bore_az, bore_el, BEACON_AZ_DEG, BEACON_EL_DEG)
    for rec in kept:
        store.check_scan(rec, "stored")
        assert rec["dx_deg"] == pytest.approx(float(want[0]), abs=0.1 * FWHM_DEG)
        assert rec["dy_deg"] == pytest.approx(float(want[1]), abs=0.1 * FWHM_DEG)
        assert sky_error_deg((rec["az_deg"], rec["el_deg"]), (bore_az, bore_el)) < 0.1 * FWHM_DEG
    assert kept[1]["model_then"] == list(error.as_terms()) and kept[0]["model_then"] == []
    # with the model in force urc reports the beam where it is: no offset left to find
    assert math.hypot(first.result["az_offset_deg"], first.result["el_offset_deg"]) > 2.0
    assert math.hypot(second.result["az_offset_deg"], second.result["el_offset_deg"]) < 0.1 * FWHM_DEG
