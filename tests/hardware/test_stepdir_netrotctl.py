"""satnogs-client's way for the gpio case: Hamlib's NETROTCTL (``rotctl -m 2``, the
backend satnogs-client's rotator settings name) against urc's rotctld port, urc driving
the SatNOGS v3 steppers itself (examples/satnogs-v3.toml, gpio emulated: lgpio's step
queue, the A4988s and the stepper model behind the pins), all real processes."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from urc_process import UrcProcess, free_port, wait_until

ROTCTL = shutil.which("rotctl")
if ROTCTL is None:  # CI installs libhamlib-utils: missing is a failure
    pytest.fail("Hamlib's rotctl not found: install libhamlib-utils (scripts/test.sh does)", pytrace=False)

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "satnogs-v3.toml"
#: one microstep after the worm (1/8 step, 200 steps/turn, 54:1), and the gear play the
#: reading may be off the truth by after a reversal (the satnogs-v3 profile's backlash)
STEP_DEG = 1.0 / 240.0


def rotctl(port: int, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([ROTCTL, "-m", "2", "-r", f"127.0.0.1:{port}", *args],
                          capture_output=True, text=True, timeout=20)


def truth(urc: UrcProcess) -> tuple[float, float]:
    t = urc.api_status()["simulator_truth"]
    return t["az"]["deg"], t["el"]["deg"]


@pytest.fixture
def satnogs_gpio(tmp_path):
    d = tmp_path / "urc"
    d.mkdir()
    urc = UrcProcess(d)
    urc.config = EXAMPLE          # the example as shipped, emulated, its rotctld on a free port
    rotctld_port = free_port()
    urc.start(args=["--emulate", "--port", str(urc.port), "--serve", f"rotctld=tcp:127.0.0.1:{rotctld_port}"])
    try:
        info = urc.api_status()
        assert info["simulator_truth"] is not None and not info["faults"], info
        yield urc, rotctld_port
    finally:
        urc.kill()


def test_netrotctl_drives_the_steppers_and_reads_back(satnogs_gpio):
    urc, port = satnogs_gpio
    res = rotctl(port, "P", "120", "30")
    assert res.returncode == 0, res.stdout + res.stderr
    wait_until(lambda: abs(truth(urc)[0] - 120.0) < 0.2 and abs(truth(urc)[1] - 30.0) < 0.2,
               60, "the antenna at 120/30 by the stepper model's truth")
    s = urc.wait(lambda s: not s["moving"], timeout_s=30)
    assert not s["faults"], s["faults"]
    res = rotctl(port, "p")
    assert res.returncode == 0, res.stdout + res.stderr
    az, el = (float(v) for v in res.stdout.split()[:2])
    true_az, true_el = truth(urc)
    # the step count is the position: what rotctl reads is the truth to a few microsteps
    # (plus the worm's play after the ramp's reversal, which the sensor side cannot see)
    assert abs(az - 120.0) < 0.3 and abs(el - 30.0) < 0.3, res.stdout
    assert abs(az - true_az) < 0.3 and abs(el - true_el) < 0.3, (res.stdout, true_az, true_el)


def test_netrotctl_out_of_range_is_refused_and_nothing_moves(satnogs_gpio):
    urc, port = satnogs_gpio
    before = truth(urc)
    res = rotctl(port, "P", "120", "190")         # satnogs-v3's elevation stops at 180
    # (rotctl exits 0 whatever a command answered: it reports urc's RPRT as an error line)
    assert "error" in (res.stdout + res.stderr).lower(), res.stdout + res.stderr
    s = urc.api_status()
    assert not s["moving"] and not s["faults"], s
    after = truth(urc)
    assert abs(after[0] - before[0]) < STEP_DEG and abs(after[1] - before[1]) < STEP_DEG
