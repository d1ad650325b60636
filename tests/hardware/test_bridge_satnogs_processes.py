"""urc in front of a SatNOGS controller, as real processes: the emulated SatNOGS firmware
(urc.testing.satnogs_firmware) on a pty, a real ``urc run`` bridging to it with the
``satnogs`` dialect and serving Easycomm II on a pty of its own, and the station's own
software path unchanged: Hamlib's ``rotctld -m 202`` on urc's pty (as satnogs-client
runs it), driven by Hamlib's ``rotctl`` ``P``/``p``."""

from __future__ import annotations

import shutil
import socket
import subprocess
import time

import pytest

from urc.testing.satnogs_firmware import SatnogsOnPty
from urc_process import UrcProcess, free_port, wait_until

ROTCTLD, ROTCTL = shutil.which("rotctld"), shutil.which("rotctl")
if ROTCTLD is None or ROTCTL is None:  # CI installs libhamlib-utils: missing is a failure
    pytest.fail("Hamlib's rotctld/rotctl not found: install libhamlib-utils (scripts/test.sh does)", pytrace=False)


def bridged_urc(tmp_path, ctl: SatnogsOnPty, serve: list[dict] | None = None) -> UrcProcess:
    d = tmp_path / "urc"
    d.mkdir()
    config = f'[hardware]\nbackend = "bridge"\n[hardware.bridge]\nprotocol = "satnogs"\nserial = "{ctl.link}"\n'
    return UrcProcess(d, profile="satnogs-v3", serve=serve or [], extra=config).start()


def true_deg(ctl: SatnogsOnPty) -> tuple[float, float]:
    with ctl.lock:
        return ctl.fw.true_deg()


def listening(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
        return True
    except OSError:
        return False


def rotctl(port: int, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([ROTCTL, "-m", "2", "-r", f"127.0.0.1:{port}", *args],
                          capture_output=True, text=True, timeout=20)


def test_satnogs_client_path_rotctld_202_on_urcs_pty_drives_the_controller(tmp_path):
    """rotctl P/p -> rotctld -m 202 (Hamlib's Easycomm II) -> urc's Easycomm pty -> urc
    -> the satnogs bridge -> the emulated SatNOGS firmware: the antenna goes where
    rotctl said and rotctl reads back where it is."""
    ctl = SatnogsOnPty(str(tmp_path / "satnogs"))
    urc_pty = str(tmp_path / "urc-easycomm")
    urc = bridged_urc(tmp_path, ctl, serve=[{"protocol": "easycomm2", "pty": urc_pty}])
    port = free_port()
    rotctld = subprocess.Popen([ROTCTLD, "-m", "202", "-r", urc_pty, "-s", "19200", "-t", str(port),
                                "-T", "127.0.0.1"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_until(lambda: listening(port), 10, "rotctld listening")
        res = rotctl(port, "P", "120", "30")
        assert res.returncode == 0, res.stdout + res.stderr
        wait_until(lambda: abs(true_deg(ctl)[0] - 120.0) < 0.2 and abs(true_deg(ctl)[1] - 30.0) < 0.2,
                   40, "the SatNOGS controller's antenna at 120/30")
        with ctl.lock:
            assert b"AZ120.0 EL30.0\n" in ctl.fw.received    # urc's target, in the firmware's own form
            assert b"AZ\n" not in ctl.fw.received            # (never Hamlib 4.6's bare AZ: a set to 0 there)
        s = urc.wait(lambda s: not s["moving"], timeout_s=20)
        assert not s["faults"], s["faults"]
        res = rotctl(port, "p")
        assert res.returncode == 0, res.stdout + res.stderr
        az, el = (float(v) for v in res.stdout.split()[:2])
        assert abs(az - 120.0) < 0.3 and abs(el - 30.0) < 0.3, res.stdout
    finally:
        rotctld.terminate()
        rotctld.wait(5)
        urc.kill()
        ctl.close()


def test_homing_and_errors_of_the_controller_show_in_urc_and_block_motion(tmp_path):
    """The controller told to home by someone else (RESET): urc says it homes (silent,
    position unknown) and takes up by itself when it answers again. Then its firmware
    hangs and its watchdog takes over (status 8, error 16, answering GS/GE only): urc's
    axes say so in the controller's words, motion is refused, and no target reaches it.
    (An error it reports while it still answers positions, a homing error, latches a
    fault of its own: test_bridge_satnogs.py.)"""
    ctl = SatnogsOnPty(str(tmp_path / "satnogs"), phys_deg=(4.0, 3.0), home_delay_s=4.0)
    urc = bridged_urc(tmp_path, ctl)
    try:
        urc.wait(lambda s: not s["faults"] and s["position_known"], timeout_s=20)
        with ctl.lock:
            ctl.fw.feed(b"RESET\n")                      # (as Hamlib's reset would)
        s = urc.wait(lambda s: bool(s["faults"]), timeout_s=15)
        reasons = " ".join(f["reason"] for f in s["faults"])
        assert "it says nothing while it homes" in reasons, s["faults"]
        s = urc.wait(lambda s: not s["faults"], timeout_s=30)     # homed: it answers again
        assert abs(s["az_deg"]) < 0.2 and abs(s["el_deg"]) < 0.2, (s["az_deg"], s["el_deg"])
        assert any("link fault cleared" in e for e in s["events"]), s["events"][-5:]

        with ctl.lock:
            ctl.fw.feed(b"RST\n")                        # the firmware hangs: its watchdog, 2 s
        # it answers only GS/GE then: no position, and the reason is the controller's own
        s = urc.wait(lambda s: "the controller reports watchdog" in s["az"]["sensor_error"], timeout_s=20)
        assert "(status 8, error 16)" in s["az"]["sensor_error"], s["az"]
        assert s["faults"], s
        with ctl.lock:
            mark = len(ctl.fw.received)
        r = urc.post("/api/goto", {"az_deg": 90.0, "el_deg": 20.0})
        assert r.status_code != 200 and "fault latched" in r.text, r.text
        time.sleep(1.0)
        with ctl.lock:
            after = ctl.fw.received[mark:]
        assert not [line for line in after.split(b"\n") if line.startswith(b"AZ") and line != b"AZ EL"], after
    finally:
        urc.kill()
        ctl.close()
