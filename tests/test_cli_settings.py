"""``urc settings`` and ``urc status`` against a real ``urc run``: the BIG-RAS menu
settings changed from the command line are checked, saved to the configuration file
and in effect after the restart; a single-axis rotator's status shows azimuth only."""

from __future__ import annotations

import subprocess
import tomllib

from urc.config import load_config
from urc_process import URC, UrcProcess


def urc(*args, check=True):
    res = subprocess.run(URC + list(args), capture_output=True, text=True, timeout=60)
    if check and res.returncode != 0:
        raise AssertionError(f"urc {' '.join(args)} failed ({res.returncode}): {res.stdout}{res.stderr}")
    return res


def test_menu_settings_from_the_cli_persist_and_apply_at_restart(tmp_path):
    u = UrcProcess(tmp_path, profile="bigras").start()
    try:
        out = urc("settings", "set", "rotator.pulses_per_deg=1", "rotator.zero=south", "rotator.elevation=false",
                  "control.az.min_rate_deg_per_s=1.2", "--url", u.url).stdout
        assert "saved to" in out and "restart" in out, out
        bad = urc("settings", "set", "rotator.max_el_deg=120", "--url", u.url, check=False)
        assert bad.returncode != 0 and "rotator.max_el_deg: expected 90 or 180" in bad.stderr, bad.stderr
        assert urc("settings", "show", "rotator.zero", "--url", u.url).stdout.strip() == "south"
    finally:
        u.stop()
    saved = tomllib.loads(u.config.read_text())
    assert saved["rotator"]["pulses_per_deg"] == 1 and saved["rotator"]["zero"] == "south"
    cfg = load_config(u.config)
    assert cfg.caps.axes == ("az",) and cfg.caps.az.sensor.resolution_deg == 1.0
    (tmp_path / "again").mkdir()
    u2 = UrcProcess(tmp_path / "again", profile="bigras")
    u2.config.write_text(u.config.read_text().replace(f"port = {u.port}", f"port = {u2.port}"))
    u2.start()
    try:
        s = u2.status()
        assert s["axes"] == ["az"] and s["el"] is None
        assert abs(s["az_deg"] - 180.0) < 1.0  # the south zero point: mechanical 0 points south
        text = urc("status", "--url", u2.url).stdout
        assert "azimuth only" in text and " el " not in text, text
        # no EL needed (5 deg, five counts of the 1 p/deg set above: BIG-RAS turns 4 deg/s at most)
        assert "going to az 185" in urc("goto", "185", "--url", u2.url).stdout
        s = u2.wait(lambda s: abs(s["az_deg"] - 185.0) < 1.0 and not s["moving"], 120)
        assert s["el"] is None
    finally:
        u2.stop()
