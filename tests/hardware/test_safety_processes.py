"""The modelled safety chain against real `urc run` processes: the control process
frozen (SIGSTOP), then thawed or killed; the simulator's truth shows how far the
antenna went after the heartbeat stopped."""

from __future__ import annotations

import json
import os
import signal
import time

import pytest

from urc.clock import RealClock
from urc.hardware.sim import SimWorld, physics_for
from urc.profiles import get_profile
from urc_process import UrcProcess, process_gone, wait_until

PROFILE = "tartu-urc"
TIMEOUT_S = 0.22


def start(tmp_path, part: bool) -> UrcProcess:
    # the external part alone: without the I/O process's takeover of a frozen control
    # process (tests/test_app.py tests that layer)
    p = UrcProcess(tmp_path, profile=PROFILE, extra="[faults]\ncontrol_takeover_s = 0\n")
    if part:
        p.config.write_text(p.config.read_text().replace(
            "wind = false\n", f"wind = false\nmotor_enable_timeout_s = {TIMEOUT_S}\n", 1))
    return p.start()


def moving_fast(p: UrcProcess) -> dict:
    """Goto far, and return the status once the azimuth turns at most of its top speed."""
    top = get_profile(PROFILE).az.max_rate_deg_per_s
    assert p.post("/api/goto", {"az_deg": 300, "el_deg": 30}).status_code == 200
    return p.wait(lambda s: abs(s["simulator_truth"]["az"]["rate_deg_per_s"]) > 0.8 * top, 60.0)


def test_a_frozen_then_thawed_control_process_lost_motor_power(tmp_path):
    p = start(tmp_path, part=True)
    try:
        s = moving_fast(p)
        # (the start's self-test of the chain may have dropped the relay once already)
        trips = s["simulator_truth"]["motor_enable"]["trips"]
        assert trips <= 1
        pid = p.control_pid()
        os.kill(pid, signal.SIGSTOP)
        # (frozen well past the relay's TIMEOUT_S, and short of the control process's
        # IO_SILENT_S, 1 s: the relay alone is judged; it was a 2 s freeze)
        time.sleep(0.6)
        os.kill(pid, signal.SIGCONT)
        # the world catches up on the first tick after the thaw: the relay dropped (again
        # perhaps while the loop, late by 0.6 s, held the motors off and let the heartbeat rest)
        p.wait(lambda s: s["simulator_truth"]["motor_enable"]["trips"] >= trips + 1, 30.0)
    finally:
        p.kill()  # (nothing judged of its stop: an orderly one waited for the move's ramp down)


@pytest.mark.parametrize("freeze_s", [0.0, 2.0])
def test_a_frozen_or_killed_control_process_runs_on_only_until_the_relay_drops(tmp_path, freeze_s):
    """kill -9 (after a freeze of ``freeze_s``): the control process's last truth
    record carries the heartbeat deadline; the iron (a world built from that record)
    ran on until it, then coasted: within the top speed x timeout + coast."""
    p = start(tmp_path, part=True)
    truth_file = p.state_dir / "simulator-truth.json"
    try:
        moving_fast(p)
        pid = p.control_pid()
        if freeze_s:
            os.kill(pid, signal.SIGSTOP)
            time.sleep(freeze_s)
        os.kill(pid, signal.SIGKILL)
        wait_until(lambda: process_gone(pid), 10.0, "control process gone")
    finally:
        p.stop()
    record = json.loads(truth_file.read_text())
    assert record["power_cut_at_wall_s"] is not None and record["axes"]["az"]["drive"] != 0.0
    last_deg = record["axes"]["az"]["load_deg"]
    caps = get_profile(PROFILE)
    world = SimWorld(caps, physics_for(PROFILE), RealClock(), truth_path=truth_file, wind=False)
    travel = abs(world.truth()["az"]["deg"] - last_deg)
    top = caps.az.max_rate_deg_per_s
    run_on_s = max(0.0, record["power_cut_at_wall_s"] - record["wall_s"])
    assert run_on_s <= TIMEOUT_S + 0.1                # the record is fresh: at most a tick old
    assert 0.0 < travel <= top * (TIMEOUT_S + 0.1) + 1.0, travel



@pytest.mark.parametrize("part", [True, False], ids=["part", "no-part"])
@pytest.mark.parametrize("how", ["SIGSTOP", "SIGKILL"])
def test_a_dead_or_frozen_control_processs_lines_drive_until_the_relay_or_the_takeover(tmp_path, part, how):
    """With the I/O process's takeover (default 1 s): the dead or frozen process's lines
    hold their level, as on a Pi, so the motor runs on until the safety relay drops out
    (with the part) or, without it, until the I/O process has killed it and taken the
    lines (a frozen one after control_takeover_s). The simulator's truth log (written by
    the worlds, not urc) shows the run-on; a model whose outputs drop by themselves when
    the process dies shows none."""
    from urc.hardware.sim.truthlog import ENV, read_log

    log = tmp_path / "truth.log"
    p = UrcProcess(tmp_path, profile=PROFILE)
    if part:
        p.config.write_text(p.config.read_text().replace(
            "wind = false\n", f"wind = false\nmotor_enable_timeout_s = {TIMEOUT_S}\n", 1))
    p.start(env={**os.environ, ENV: str(log)})
    try:
        moving_fast(p)
        t_event = time.time()
        ctl = p.control_pid()
        os.kill(ctl, getattr(signal, how))
        # taken over, then a control process of its own started again (issue 33: urc run
        # no longer ends)
        p.wait(lambda s: any("started again" in e for e in s["events"]), timeout_s=60)
        assert p.control_pid() != ctl and p.proc.poll() is None
    finally:
        out = p.stop()
    assert "every output driven safe by the I/O process" in out, out
    entries = read_log(log)
    before = [e for e in entries if e["t"] == "s" and e["wall_s"] <= t_event][-1]["axes"]["az"]
    restore = [e for e in entries if e["t"] == "restore" and e["wall_s"] > t_event]
    # the first: the I/O process's world, on moving iron (the second: the new control process's)
    assert len(restore) >= 1, entries[-5:]
    az = restore[0]["axes"]["az"]
    assert az["drive"] != 0.0 and abs(before["rate"]) > 0.5
    top = get_profile(PROFILE).az.max_rate_deg_per_s
    run_on_s = restore[0]["run_on_s"]
    if part:
        assert 0.0 < run_on_s <= TIMEOUT_S + 0.1
    elif how == "SIGSTOP":
        assert run_on_s >= 1.0                         # the takeover waits that long
        assert abs(az["to_deg"] - before["deg"]) >= 0.8 * top * 1.0
    else:
        assert run_on_s > 0.0
    final = json.loads((tmp_path / "state" / "simulator-truth.json").read_text())["axes"]["az"]
    assert final["load_deg"] == pytest.approx(az["to_deg"], abs=0.5)   # and it stood there


def test_the_io_process_has_what_a_takeover_needs_imported_before_it_is_needed(tmp_path):
    """A takeover opens the hardware in the I/O process: done cold, its imports cost
    0.3-0.4 s of a dead process's motor still driving (no part). prepare_takeover
    imports them beforehand, and opens nothing."""
    import subprocess
    import sys

    examples = __import__("pathlib").Path(__file__).resolve().parents[2] / "examples"
    code = (
        "import sys\n"
        "from urc.config import load_config\n"
        "from urc.cli import with_emulation\n"
        "from urc.assembly import prepare_takeover\n"
        f"cfg = with_emulation(load_config({str(examples / 'tartu-urc.toml')!r}))\n"
        "assert 'gpiozero.pins.mock' not in sys.modules and 'urc.hardware.gpio.emulate' not in sys.modules\n"
        "assert prepare_takeover(cfg) == []\n"
        "assert 'gpiozero.pins.mock' in sys.modules and 'urc.hardware.gpio.emulate' in sys.modules\n"
        "import os; assert not os.listdir('.'), os.listdir('.')\n"
        "print('ok')\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr


def test_a_flapping_control_process_latches_a_fault_after_three_stops(tmp_path):
    """Issue 33: 20 freezes of 0.5 s (shorter than the takeover) cut the relay 20 times
    and resumed the move after each, about 30 deg of jerky travel before a fault. A
    freeze that drops the safety part's relay is a stall (urc counts ticks later than the
    part's timeout); the third within 60 s latches a watchdog fault, after which nothing
    moves, however often the process freezes again."""
    p = start(tmp_path, part=True)
    try:
        moving_fast(p)
        ctl = p.control_pid()
        latched_at = None
        for i in range(8):
            os.kill(ctl, signal.SIGSTOP)
            time.sleep(0.5)
            os.kill(ctl, signal.SIGCONT)
            time.sleep(0.5)
            s = p.status()
            if latched_at is None and any(f["kind"] == "watchdog" for f in s["faults"]):
                latched_at = (i, s["simulator_truth"]["az"]["deg"], s["loop"]["stalls"])
        assert latched_at is not None, s["loop"]
        assert latched_at[0] <= 3 and latched_at[2] <= 4, latched_at   # (the third stall latches)
        s = p.wait(lambda s: not s["moving"])
        assert abs(s["simulator_truth"]["az"]["deg"] - latched_at[1]) < 1.0   # nothing moved after the latch
        assert s["last_stop"]["kind"] == "fault" and s["target_az_deg"] is None, s["last_stop"]
    finally:
        p.kill()
