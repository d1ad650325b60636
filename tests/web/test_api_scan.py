"""POST /api/calibration/scan runs a cross scan as the hub's procedure and GET gives its
result with the samples; /apply saves the offsets found through the settings' save. (On
main before this the routes did not exist: 404.)"""

from __future__ import annotations

import tomllib

import pytest

ERROR = {"ia_deg": 3.0, "ie_deg": -2.0}
SCAN_CONFIG = {"hardware": {"sim": {"wind": False, "pointing_error": ERROR}},
               "pointing": {"beamwidth_deg": 20.0, "snr_db": 30.0, "dwell_s": 0.4, "samples_per_point": 2}}


def run_until_finished(c, limit: int = 20000) -> dict:
    """Advance virtual time in small steps, letting the hub feed each status to the scan."""
    for _ in range(limit):
        c.bench.run(0.1)
        proc = c.get("/api/calibration/procedure").json()["procedure"]
        if proc["state"] != "running":
            return proc
    raise AssertionError(f"the scan did not finish: {proc}")


def test_a_beacon_scan_through_the_api_finds_the_offset_and_applies_it(make_client, tmp_path):
    config_path = tmp_path / "urc.toml"
    config_path.write_text("[offsets]\naz_deg = 0.0\n")
    c = make_client("tartu-urc", config_path=config_path, **SCAN_CONFIG)
    assert c.get("/api/calibration/scan").json()["scan"] is None
    r = c.post("/api/calibration/scan", json={"target": "beacon", "az_deg": 100.0, "el_deg": 35.0})
    assert r.status_code == 200, r.text
    assert r.json()["procedure"]["kind"] == "scan"
    # one at a time: a second start while it runs is refused
    assert c.post("/api/calibration/scan", json={"target": "beacon", "az_deg": 100.0, "el_deg": 35.0}).status_code == 409
    proc = run_until_finished(c)
    assert proc["state"] == "done", proc
    scan = c.get("/api/calibration/scan").json()["scan"]
    res = scan["result"]
    assert res["az_offset_deg"] == pytest.approx(3.0, abs=2.0)      # a tenth of the 20 deg beam
    assert res["el_offset_deg"] == pytest.approx(-2.0, abs=2.0)
    assert len(scan["samples"]) > 20 and {"dx_deg", "dy_deg", "value", "leg"} <= set(scan["samples"][0])
    a = c.post("/api/calibration/scan/apply")
    assert a.status_code == 200, a.text
    saved = tomllib.loads(config_path.read_text())["offsets"]
    assert saved["az_deg"] == pytest.approx(-res["az_offset_deg"], abs=1e-3)
    assert saved["el_deg"] == pytest.approx(-res["el_offset_deg"], abs=1e-3)
    assert c.post("/api/calibration/scan/apply").status_code == 409  # not twice


def test_a_sun_scan_without_a_station_is_refused_with_the_reason(make_client):
    c = make_client("tartu-urc")
    r = c.post("/api/calibration/scan", json={"target": "sun"})
    assert r.status_code == 409 and "station" in r.json()["error"]
    r = c.post("/api/calibration/scan", json={"target": "beacon"})
    assert r.status_code == 409 and "az_deg" in r.json()["error"]
    assert c.post("/api/calibration/scan", json={"target": "mars"}).status_code == 422
    assert c.post("/api/calibration/scan/apply").status_code == 409
