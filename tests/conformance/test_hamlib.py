"""Conformance with Hamlib's own clients: ``rotctl`` for each model against urc's
pseudo-terminals and TCP, and ``rotctld`` used as a proxy in front of urc's serial
emulations. One real ``urc run`` serves every protocol at once, sharing one rotator."""

from __future__ import annotations

import shutil
import socket
import subprocess
import time

import pytest

from urc_process import UrcProcess, free_port

ROTCTL = shutil.which("rotctl")
ROTCTLD = shutil.which("rotctld")
if ROTCTL is None or ROTCTLD is None:  # CI installs libhamlib-utils: missing is a failure
    pytest.fail("Hamlib's rotctl/rotctld not found: install libhamlib-utils (scripts/test.sh does)",
                pytrace=False)

# model -> (protocol, baud, has a position query, azimuth only)
SERIAL_MODELS = {
    201: ("easycomm1", 9600, False, False),
    202: ("easycomm2", 9600, True, False),
    204: ("easycomm3", 9600, True, False),
    601: ("gs232a", 9600, True, False),
    603: ("gs232b", 9600, True, False),
    901: ("rot2prog", 600, True, False),
    902: ("rot1prog", 1200, True, True),
    # MD-01 defaults to 460800 baud, which Hamlib 4.5's serial_setup cannot set (a pty
    # ignores the rate anyway); 115200 is the fastest it accepts
    903: ("md01", 115200, True, False),
}
TOLERANCE_DEG = 1.2  # SPID reports whole degrees (Rot1Prog) or halves; GS-232 whole degrees


@pytest.fixture(scope="module")
def urc(tmp_path_factory):
    work = tmp_path_factory.mktemp("conformance")
    rotctld_port = free_port()
    serve = [{"protocol": "rotctld", "tcp": f"127.0.0.1:{rotctld_port}"}]
    for model, (proto, *_rest) in SERIAL_MODELS.items():
        serve.append({"protocol": proto, "pty": str(work / f"urc-{model}")})
    proc = UrcProcess(work, profile="berkeley", serve=serve).start()
    proc.rotctld_port = rotctld_port
    proc.work = work
    yield proc
    out = proc.stop()
    assert "stopped, state saved" in out, out


def rotctl(model: int, port: str, *args: str, baud: int | None = None, timeout_s: float = 20) -> str:
    cmd = [ROTCTL, "-m", str(model), "-r", port]
    if baud:
        cmd += ["-s", str(baud)]
    res = subprocess.run(cmd + list(args), capture_output=True, text=True, timeout=timeout_s)
    assert res.returncode == 0, f"rotctl -m {model} {' '.join(args)}: rc {res.returncode}\n{res.stdout}{res.stderr}"
    return res.stdout


def read_pos(model: int, port: str, baud: int | None = None) -> tuple[float, float]:
    out = rotctl(model, port, "p", baud=baud).split()
    return float(out[0]), float(out[1])


def settle_at(urc: UrcProcess, az: float, el: float | None) -> dict:
    return urc.wait(lambda s: abs(s["az_deg"] - az) < 0.5 and (el is None or abs(s["el_deg"] - el) < 0.5)
                    and not s["moving"], timeout_s=60)


def test_net_rotctl_model_2(urc):
    port = f"127.0.0.1:{urc.rotctld_port}"
    # (23.4 deg from the park at 0, 0: every target in this file lies below 100 deg of
    # azimuth, each move a few seconds at most at berkeley's 40 deg/s)
    rotctl(2, port, "P", "23.4", "5.6")
    s = settle_at(urc, 23.4, 5.6)
    az, el = read_pos(2, port)
    # the held antenna may move a sensor count in the wind between two reads (berkeley's
    # AS5600 count is 0.088 deg): the value read must be what the controller reported
    # just before or just after it, to rotctld's two decimals
    after = urc.status()
    assert any(az == pytest.approx(x["az_deg"], abs=0.006) and el == pytest.approx(x["el_deg"], abs=0.006)
               for x in (s, after)), (az, el, s["az_deg"], s["el_deg"], after["az_deg"], after["el_deg"])
    truth = s["simulator_truth"]
    assert az == pytest.approx(truth["az"]["deg"], abs=0.5) and el == pytest.approx(truth["el"]["deg"], abs=0.5)


@pytest.mark.parametrize("model", sorted(SERIAL_MODELS))
def test_rotctl_serial_model(urc, model):
    proto, baud, has_query, az_only = SERIAL_MODELS[model]
    port = str(urc.work / f"urc-{model}")
    # (azimuths 47-70: between model 2's 23.4 before and the proxies' 81-83 after;
    # elevations 19-29, model 2's 5.6 before and the proxies' 30 after)
    target_az, target_el = 40.0 + model % 97, (0.0 if az_only else 10.0 + model % 37)
    rotctl(model, port, "P", str(target_az), str(target_el), baud=baud)
    s = settle_at(urc, target_az, None if az_only else target_el)
    if has_query:
        az, el = read_pos(model, port, baud)
        assert az == pytest.approx(s["az_deg"], abs=TOLERANCE_DEG)
        if not az_only:
            assert el == pytest.approx(s["el_deg"], abs=TOLERANCE_DEG)
    # every protocol's position query reflects a move made through another one
    az2, el2 = read_pos(2, f"127.0.0.1:{urc.rotctld_port}")
    assert az2 == pytest.approx(target_az, abs=0.5)


@pytest.mark.parametrize("model", [202, 603, 901])
def test_rotctld_as_proxy_in_front_of_urc(urc, model):
    proto, baud, _, _ = SERIAL_MODELS[model]
    port = free_port()
    daemon = subprocess.Popen([ROTCTLD, "-m", str(model), "-r", str(urc.work / f"urc-{model}"), "-s", str(baud),
                               "-T", "127.0.0.1", "-t", str(port)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 10
        while True:
            try:
                sock = socket.create_connection(("127.0.0.1", port), timeout=5)
                break
            except OSError:
                assert time.monotonic() < deadline, "rotctld did not start"
                time.sleep(0.1)
        with sock:
            f = sock.makefile("rwb", buffering=0)
            target = (80.0 + model % 50, 30.0)
            f.write(f"P {target[0]} {target[1]}\n".encode())
            assert f.readline() == b"RPRT 0\n"
            settle_at(urc, *target)
            f.write(b"p\n")
            az, el = float(f.readline()), float(f.readline())
            assert az == pytest.approx(target[0], abs=TOLERANCE_DEG) and el == pytest.approx(target[1], abs=TOLERANCE_DEG)
    finally:
        daemon.terminate()
        daemon.wait(timeout=10)


def test_out_of_range_is_refused_and_nothing_moves(urc):
    port = f"127.0.0.1:{urc.rotctld_port}"
    before = urc.status()
    res = subprocess.run([ROTCTL, "-m", "2", "-r", port, "P", "10", "240"], capture_output=True, text=True, timeout=20)
    assert res.returncode != 0 or "error" in (res.stdout + res.stderr).lower()
    time.sleep(0.5)
    after = urc.status()
    # "moving" is no test here: in the wind the berkeley's gear play lets the antenna
    # drift and the holding controller corrects it. What matters is that the refused
    # command set no new target and the antenna stays where it was.
    assert (after["target_az_deg"], after["target_el_deg"]) == (before["target_az_deg"], before["target_el_deg"])
    assert after["az_deg"] == pytest.approx(before["az_deg"], abs=1.0)
    assert after["el_deg"] == pytest.approx(before["el_deg"], abs=1.0)
