"""`urc service install`: the systemd unit, checked by systemd's own verifier."""

from __future__ import annotations

import shutil
import subprocess

import pytest
from click.testing import CliRunner

from urc.cli import main


def test_print_shows_a_notify_unit_with_a_watchdog(tmp_path):
    cfg = tmp_path / "urc.toml"
    cfg.write_text("[rotator]\nprofile = \"tartu-urc\"\n")
    r = CliRunner().invoke(main, ["service", "install", "--print", "--config", str(cfg),
                                  "--state-dir", str(tmp_path / "state"), "--user", "station"])
    assert r.exit_code == 0, r.output
    unit = r.output
    for line in ("Type=notify", "NotifyAccess=all", "WatchdogSec=2", "Restart=on-failure", "User=station",
                 "WantedBy=multi-user.target"):
        assert line in unit.splitlines()
    exec_line = next(ln for ln in unit.splitlines() if ln.startswith("ExecStart="))
    assert f"--config {cfg}" in exec_line and "-m urc run" in exec_line
    # systemd's own check (scripts/test.sh installs systemd: missing is a failure)
    assert shutil.which("systemd-analyze"), "systemd-analyze not found: install systemd"
    path = tmp_path / "urc.service"
    path.write_text(unit.replace("User=station\n", ""))
    v = subprocess.run(["systemd-analyze", "verify", str(path)], capture_output=True, text=True)
    problems = [ln for ln in v.stderr.splitlines() if "urc.service" in ln and "network-online" not in ln]
    assert not problems, v.stderr


def test_user_unit_is_written_where_systemctl_user_looks(tmp_path, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path))
    r = CliRunner().invoke(main, ["service", "install", "--user-unit"])
    assert r.exit_code == 0, r.output
    unit = tmp_path / ".config" / "systemd" / "user" / "urc.service"
    assert "WantedBy=default.target" in unit.read_text() and "User=" not in unit.read_text()
    assert "systemctl --user" in r.output


@pytest.mark.parametrize("args", [["--config", "/no/such/file.toml"]])
def test_bad_arguments_are_refused(args):
    r = CliRunner().invoke(main, ["service", "install", "--print", *args])
    assert r.exit_code != 0


def test_the_unit_runs_where_lgpio_can_make_its_notify_fifo(tmp_path):
    """lgpio makes its FIFO in LG_WD (else the current directory) and its Python module
    opens it relative to the current directory: the unit runs in the state directory
    (else the user's home), never in /, with LG_WD unset."""
    from urc.systemd_unit import unit_text

    lines = unit_text(None, tmp_path / "state", user="station").splitlines()
    assert f"WorkingDirectory={(tmp_path / 'state').resolve()}" in lines
    assert "UnsetEnvironment=LG_WD" in lines
    assert "WorkingDirectory=~" in unit_text(None, None, user_unit=True).splitlines()
