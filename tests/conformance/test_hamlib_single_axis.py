"""Hamlib's own ``rotctl`` against a single-axis urc (``[rotator] elevation = false``,
the TRC turntable example): netrotctl (model 2) reads urc's rotctld limits (elevation
0..0, rot_type Az) and behaves as with Hamlib's azimuth-only backends; GS-232A azimuth
(model 609) drives urc's GS-232A emulation over a pseudo-terminal."""

from __future__ import annotations

import shutil
import subprocess
import time

import pytest

from urc_process import UrcProcess, free_port

ROTCTL = shutil.which("rotctl")
if ROTCTL is None:  # pragma: no cover - scripts/test.sh installs it
    pytest.fail("Hamlib's rotctl not found: install libhamlib-utils (scripts/test.sh does)", pytrace=False)


@pytest.fixture(scope="module")
def urc(tmp_path_factory):
    work = tmp_path_factory.mktemp("single-axis")
    port = free_port()
    serve = [{"protocol": "rotctld", "tcp": f"127.0.0.1:{port}"},
             {"protocol": "gs232a", "pty": str(work / "urc-gs232a")}]
    proc = UrcProcess(work, profile="tartu-urc", serve=serve)
    text = proc.config.read_text()  # the TRC turntable: [rotator] elevation = false
    proc.config.write_text(text.replace('profile = "tartu-urc"\n', 'profile = "tartu-urc"\nelevation = false\n'))
    proc.start()
    proc.rotctld = f"127.0.0.1:{port}"
    proc.work = work
    yield proc
    out = proc.stop()
    assert "stopped, state saved" in out, out


def rotctl(model: int, port: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([ROTCTL, "-m", str(model), "-r", port, *args], capture_output=True, text=True, timeout=20)


def test_netrotctl_sees_an_azimuth_only_rotator(urc):
    s = urc.status()
    assert s["axes"] == ["az"] and s["el"] is None and s["el_deg"] is None
    res = rotctl(2, urc.rotctld, "dump_state")
    assert res.returncode == 0 and "max_el=0.000000" in res.stdout and "rot_type=Az" in res.stdout, res.stdout


def test_netrotctl_p_moves_the_azimuth_and_reads_el_0(urc):
    res = rotctl(2, urc.rotctld, "P", "8.4", "0")   # (the Tartu rotator turns 6 deg/s)
    assert res.returncode == 0, res.stdout + res.stderr
    s = urc.wait(lambda s: abs(s["az_deg"] - 8.4) < 0.3 and not s["moving"])
    out = rotctl(2, urc.rotctld, "p")
    az, el = (float(v) for v in out.stdout.split()[:2])
    assert az == pytest.approx(s["az_deg"], abs=0.11) and el == 0.0
    assert s["simulator_truth"]["az"]["deg"] == pytest.approx(8.4, abs=0.3)


def test_an_elevation_is_refused_as_hamlib_does_and_nothing_moves(urc):
    before = urc.status()
    # Hamlib's rot_set_position checks min_el..max_el (0..0 from urc's dump_state): -RIG_EINVAL
    res = rotctl(2, urc.rotctld, "P", "200", "45")
    assert res.returncode != 0 and "Invalid parameter" in res.stdout + res.stderr, res.stdout + res.stderr
    time.sleep(0.5)
    after = urc.status()
    assert after["target_az_deg"] == before["target_az_deg"] and not after["moving"]
    assert after["az_deg"] == pytest.approx(before["az_deg"], abs=0.2)


def test_gs232a_azimuth_model_over_a_pty(urc):
    port = str(urc.work / "urc-gs232a")
    res = rotctl(609, port, "P", "20", "0")
    assert res.returncode == 0, res.stdout + res.stderr
    urc.wait(lambda s: abs(s["az_deg"] - 20.0) < 0.3 and not s["moving"])
    out = rotctl(609, port, "p")
    az, el = (float(v) for v in out.stdout.split()[:2])
    assert az == pytest.approx(20.0, abs=1.0) and el == 0.0
