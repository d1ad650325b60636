"""`urc calibrate`: the API's answers printed (offset, or the refusal's reason); --apply
saves. (On main before this there was no `calibrate` command.)"""

from __future__ import annotations

from click.testing import CliRunner

from urc.cli import main
from urc import cli_pointing as pcli

DONE = {"state": "done", "step": "done", "progress": 1.0, "error": "",
        "result": {"az_offset_deg": 2.5, "az_offset_err_deg": 0.1, "el_offset_deg": -1.5, "el_offset_err_deg": 0.1,
                   "fwhm_deg": [10.0, 10.1], "offsets_suggested": {"az_deg": -2.5, "el_deg": 1.5}}}


def fake(scan: dict, calls: list):
    def request(url, config_path, method, path, body=None):
        calls.append((method, path))
        if path == "/api/calibration/procedure":
            return {"procedure": {k: scan[k] for k in ("state", "step", "progress")}}
        if path == "/api/calibration/scan" and method == "GET":
            return {"scan": scan}
        if path == "/api/calibration/scan/apply":
            return {"messages": ["saved to urc.toml"]}
        return {"ok": True}
    return request


def test_calibrate_prints_the_offset_and_applies(monkeypatch):
    calls: list = []
    monkeypatch.setattr(pcli, "_request", fake(DONE, calls))
    r = CliRunner().invoke(main, ["calibrate", "sun", "--apply"])
    assert r.exit_code == 0, r.output
    assert "az +2.500 +- 0.100 deg" in r.output and "el_deg = 1.500" in r.output
    assert ("POST", "/api/calibration/scan/apply") in calls and "saved to urc.toml" in r.output


def test_a_refused_scan_says_why_and_saves_nothing(monkeypatch):
    calls: list = []
    refused = {"state": "failed", "step": "failed", "progress": 0.5, "result": {"refused": "noise"},
               "error": "refused (noise): no significant peak"}
    monkeypatch.setattr(pcli, "_request", fake(refused, calls))
    r = CliRunner().invoke(main, ["calibrate", "moon", "--apply"])
    assert r.exit_code != 0 and "refused (noise)" in r.output
    assert ("POST", "/api/calibration/scan/apply") not in calls
