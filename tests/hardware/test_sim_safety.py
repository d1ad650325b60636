"""The external safety chain as the simulator models it (heartbeat -> motor power
enable): a frozen or killed controller loses motor power at the part's timeout, as the
relay would drop out on iron; without the part the motors run on."""

from __future__ import annotations

import math

import json
import time

import pytest

from urc.clock import VirtualClock
from urc.hardware import build_hardware
from urc.hardware.sim.safety import MotorPowerEnable
from urc.profiles import get_profile
from urc.rotator.rotator import Rotator, RotatorSettings

TIMEOUT_S = 0.22


def _rotator(tmp_path, profile: str, timeout_s: float | None, truth_file=None):
    settings = RotatorSettings.from_caps(get_profile(profile))
    clock = VirtualClock(0.0)
    opts = {"wind": False, "truth_file": truth_file}
    if timeout_s is not None:
        opts["motor_enable_timeout_s"] = timeout_s
    hw = build_hardware("sim", settings.caps, clock, tmp_path, opts)
    return Rotator(settings, hw, clock), clock, hw


def _ticks(rot, clock, seconds: float) -> None:
    period_s = 1.0 / rot.caps.loop_hz
    for _ in range(round(seconds / period_s)):
        clock.advance(period_s)
        rot.tick()


def _freeze(rot, clock, profile: str, freeze_s: float, timeout_s: float | None) -> tuple[float, float, dict]:
    """Move the azimuth at full speed, then freeze the controller (no tick, no heartbeat
    edge: the clock goes on) for ``freeze_s``; returns (az travel until it thaws, the
    top speed, the truth then)."""
    hw = rot.hw
    world = hw.world
    start = world.truth()["az"]["deg"]
    rot.goto_az(start + 150.0)
    _ticks(rot, clock, 12.0)                     # well into the move, at full speed
    moving = world.truth()["az"]
    assert abs(moving["rate_deg_per_s"]) > 0.5 * get_profile(profile).az.max_rate_deg_per_s
    at_freeze = moving["deg"]
    clock.advance(freeze_s)
    hw.poll(clock.now_s())                       # what the iron did meanwhile (thaw)
    truth = hw.sim_truth()
    return abs(truth["az"]["deg"] - at_freeze), get_profile(profile).az.max_rate_deg_per_s, truth


@pytest.mark.parametrize("profile", ["tartu-urc", "g5500"])
@pytest.mark.parametrize("freeze_s", [2.0, 10.0])
def test_a_frozen_controller_loses_motor_power_at_the_timeout(tmp_path, profile, freeze_s):
    rot, clock, _ = _rotator(tmp_path, profile, TIMEOUT_S)
    travel, top, truth = _freeze(rot, clock, profile, freeze_s, TIMEOUT_S)
    assert truth["motor_enable"]["powered"] is False and truth["motor_enable"]["trips"] == 1
    assert truth["az"]["rate_deg_per_s"] == 0.0  # at rest before the thaw
    # the drive ran at most the timeout (plus the tick it was written in), then coasted
    assert travel <= top * (TIMEOUT_S + 0.02) + 1.0, travel
    assert travel < 2.0


@pytest.mark.parametrize("profile", ["tartu-urc", "g5500"])
def test_without_the_part_a_frozen_controller_runs_on(tmp_path, profile):
    rot, clock, _ = _rotator(tmp_path, profile, None)
    travel, top, truth = _freeze(rot, clock, profile, 2.0, None)
    assert "motor_enable" not in truth
    assert travel == pytest.approx(top * 2.0, rel=0.1)      # the whole freeze at speed


def test_power_comes_back_with_the_heartbeat_and_brakes_follow_the_supply(tmp_path):
    """The relay drops the brake coil's supply too (the brake engages), and both come
    back once rising edges come again."""
    rot, clock, hw = _rotator(tmp_path, "tartu-urc", TIMEOUT_S)
    world = hw.world
    rot.goto_az(world.truth()["az"]["deg"] + 100.0)
    _ticks(rot, clock, 5.0)
    assert world.truth()["az"]["brake_released"] is True and world.motor_power()
    clock.advance(1.0)
    hw.poll(clock.now_s())
    assert not world.motor_power()
    assert world.truth()["az"]["brake_released"] is False     # engaged after its delay
    _ticks(rot, clock, 3.0)
    assert world.motor_power()
    assert world.truth()["az"]["brake_released"] is True


def test_no_power_before_the_first_heartbeat(tmp_path):
    """At boot, before urc drives the heartbeat, the relay is out whatever the lines do
    (GPIO0-8 high at boot cannot turn a motor)."""
    clock = VirtualClock(0.0)
    hw = build_hardware("sim", get_profile("tartu-urc"), clock, tmp_path,
                        {"wind": False, "truth_file": None, "motor_enable_timeout_s": TIMEOUT_S})
    world = hw.world
    hw.poll(0.0)
    hw.az.motor.set_drive(1.0)
    hw.az.brake.set_released(True)
    for _ in range(100):
        clock.advance(0.02)
        hw.poll(clock.now_s())
    assert world.truth()["az"]["deg"] == pytest.approx(get_profile("tartu-urc").az.park_deg, abs=1e-9)
    hw.heartbeat.write(True)                    # one rising edge: power for the timeout
    for _ in range(100):
        clock.advance(0.02)
        hw.poll(clock.now_s())
    assert world.enable.trips == 1 and not world.motor_power()


def test_monostable_retriggers_on_rising_edges_only():
    t = [0.0]
    part = MotorPowerEnable(0.2, lambda: t[0])
    assert not part.powered_at(0.0)
    part.heartbeat(True)
    assert part.powered_at(0.1) and not part.powered_at(0.2)
    t[0] = 0.15
    part.heartbeat(False)                        # a falling edge does not retrigger
    assert part.cut_at_s() == pytest.approx(0.2)
    t[0] = 0.19
    part.heartbeat(True)
    assert part.cut_at_s() == pytest.approx(0.39)
    t[0] = 0.3
    part.heartbeat(True)                         # a level held high is no edge
    assert part.cut_at_s() == pytest.approx(0.39)
    with pytest.raises(ValueError):
        MotorPowerEnable(0.0, lambda: 0.0)


@pytest.mark.parametrize("pulled_down", [True, False])
def test_a_released_trigger_drops_the_relay_only_with_its_pull_down(pulled_down):
    """Review 35 #1: with the heartbeat line released (strict_gpiod, a halted Pi's Hi-Z
    pins, a broken wire) a floating +TR picks up hum, and hum is edges: the relay stays
    in. The documented 100 kOhm to GND holds it low: the relay drops at the timeout."""
    t = [0.0]
    part = MotorPowerEnable(0.2, lambda: t[0], trigger_pulled_down=pulled_down)
    part.heartbeat(True)
    t[0] = 0.02
    part.release()
    assert part.powered_at(0.1)
    assert part.powered_at(5.0) is (not pulled_down)
    assert part.cut_at_s() == (pytest.approx(0.2) if pulled_down else math.inf)
    part.heartbeat(False)                        # driven again: edges decide once more
    part.heartbeat(True)
    assert part.cut_at_s() == pytest.approx(0.22)


def test_a_killed_controller_runs_on_until_the_relay_drops(tmp_path, monkeypatch):
    """A process killed mid-move leaves its lines driving: the next world (the restart)
    runs the motor from the last record until the recorded heartbeat deadline, then
    coasts; without the part the record carries no deadline (simulated as a power cut)."""
    import urc.hardware.sim.world as world_mod

    profile = get_profile("tartu-urc")
    truth_file = tmp_path / "truth.json"
    record = {"version": world_mod.TRUTH_VERSION, "profile": "tartu-urc", "axes": {
        "az": {"gear_deg": 100.0, "gear_deg_per_s": 6.0, "load_deg": 100.0, "load_deg_per_s": 6.0,
               "brake_released": True, "drive": 1.0},
        "el": {"gear_deg": 10.0, "gear_deg_per_s": 0.0, "load_deg": 10.0, "load_deg_per_s": 0.0,
               "brake_released": False, "drive": 0.0}}}
    monkeypatch.setattr(world_mod.time, "time", lambda: 1000.0)     # restarted long after

    def restart(rec):
        truth_file.write_text(json.dumps(rec))
        w = world_mod.SimWorld(profile, _params(), _RealClock(), truth_path=truth_file, wind=False)
        return w.truth()["az"]["deg"] - 100.0

    coast_only = restart(record)
    with_part = restart({**record, "wall_s": 990.0, "power_cut_at_wall_s": 990.5})
    assert 0.0 < coast_only < with_part
    # half a second more at about the top speed, no more
    assert with_part - coast_only == pytest.approx(0.5 * profile.az.max_rate_deg_per_s, rel=0.3)


def test_without_the_part_a_dead_controllers_lines_drive_until_the_next_process_takes_them(tmp_path, monkeypatch):
    """On a Pi a killed process's lines keep their last level: without the safety part
    nothing cuts the motor until the next process (the I/O process's takeover, or the
    next start) opens the hardware and drives it safe. A model in which the outputs
    drop by themselves when the process dies gives the coast alone here."""
    import urc.hardware.sim.world as world_mod

    profile = get_profile("tartu-urc")
    truth_file = tmp_path / "truth.json"
    monkeypatch.setattr(world_mod.time, "time", lambda: 1000.0)
    moving = {"gear_deg": 100.0, "gear_deg_per_s": 6.0, "load_deg": 100.0, "load_deg_per_s": 6.0,
              "brake_released": True, "drive": 1.0}
    standing = {"gear_deg": 10.0, "gear_deg_per_s": 0.0, "load_deg": 10.0, "load_deg_per_s": 0.0,
                "brake_released": False, "drive": 0.0}

    def restart(wall_s):
        rec = {"version": world_mod.TRUTH_VERSION, "profile": "tartu-urc", "axes": {"az": moving, "el": standing}}
        if wall_s is not None:
            rec["wall_s"] = wall_s                       # no power_cut_at_wall_s: no part
        truth_file.write_text(json.dumps(rec))
        w = world_mod.SimWorld(profile, _params(), _RealClock(), truth_path=truth_file, wind=False)
        return w.truth()["az"]["deg"] - 100.0

    coast_only = restart(None)                           # (a record with no wall time)
    one_s, three_s = restart(999.0), restart(997.0)
    top = profile.az.max_rate_deg_per_s
    assert one_s - coast_only == pytest.approx(1.0 * top, rel=0.3)
    assert three_s - one_s == pytest.approx(2.0 * top, rel=0.2)


def test_an_orderly_close_lets_go_of_the_motors(tmp_path):
    """Only a process that dies leaves its lines driving: a world closed in order (the
    control process's shutdown) records no drive for the next one to run on."""
    truth_file = tmp_path / "truth.json"
    clock = _RealClock()
    hw = build_hardware("sim", get_profile("tartu-urc"), clock, tmp_path, {"wind": False, "truth_file": truth_file})
    hw.poll(0.0)
    hw.az.brake.set_released(True)
    hw.az.motor.set_drive(1.0)
    hw.close()
    rec = json.loads(truth_file.read_text())
    assert rec["wall_s"] > 0 and "power_cut_at_wall_s" not in rec
    assert rec["axes"]["az"]["drive"] == 0.0


def test_the_truth_log_keeps_the_history_the_cut_and_the_run_on_of_a_restart(tmp_path):
    """URC_SIM_TRUTH_LOG / truth_log: samples while the iron moves, the relay's cut at
    the time it happened (found late, after a freeze), and a restart's run-on."""
    from urc.hardware.sim.truthlog import read_log

    log_file, truth_file = tmp_path / "truth.log", tmp_path / "truth.json"
    clock = _StepClock()
    opts = {"wind": False, "truth_file": truth_file, "truth_log": log_file, "motor_enable_timeout_s": TIMEOUT_S}
    hw = build_hardware("sim", get_profile("tartu-urc"), clock, tmp_path, opts)
    hw.poll(0.0)
    hw.az.brake.set_released(True)
    for i in range(100):                          # 2 s of heartbeat, motor full on
        clock.t = 0.02 * (i + 1)
        hw.heartbeat.write(i % 2 == 0)
        hw.az.motor.set_drive(1.0)
        hw.poll(clock.t)
    last_edge_s = 0.02 * 99
    clock.t += 1.0                                # frozen a second: no edge, then caught up
    hw.poll(clock.t)
    world = hw.world
    # (the real-time truth writer's thread done first: a record it still held, written
    # after the edit below, replaced it on a machine at load 10)
    world._truth_writer.close()
    world._write_truth()
    world.log.close()
    entries = read_log(log_file)
    samples = [e for e in entries if e["t"] == "s"]
    # (a drive or power change is logged at once; mere motion at most every SAMPLE_S)
    assert len(samples) >= 3 and samples[0]["axes"]["az"]["powered"] is False   # (no edge yet)
    assert any(e["axes"]["az"]["drive"] > 0.5 and e["axes"]["az"]["powered"] for e in samples)
    assert samples[-1]["axes"]["az"]["drive"] == 0.0 and samples[-1]["axes"]["az"]["powered"] is False
    cut = [e for e in entries if e["t"] == "cut"]
    assert len(cut) == 1
    # logged 1 s after the cut, dated when it happened: the timeout after the last edge
    assert cut[0]["wall_s"] == pytest.approx(samples[-1]["wall_s"] - (clock.t - last_edge_s - TIMEOUT_S), abs=0.05)
    # a restart from a record of moving iron logs its run-on and coast
    rec = json.loads(truth_file.read_text())
    rec["axes"]["az"].update(drive=1.0, load_deg_per_s=6.0, gear_deg_per_s=6.0, brake_released=True)
    rec.pop("power_cut_at_wall_s")                # (as if no part: runs on until the restart)
    rec["wall_s"] = time.time() - 0.5
    truth_file.write_text(json.dumps(rec))
    build_hardware("sim", get_profile("tartu-urc"), _StepClock(), tmp_path, opts).world.log.close()
    started_by_wall_s = time.time()
    restore = [e for e in read_log(log_file) if e["t"] == "restore"]
    # ran on from the record until this restart read it (a loaded machine starts late)
    assert len(restore) == 1 and 0.5 <= restore[0]["run_on_s"] <= started_by_wall_s - rec["wall_s"], restore
    az = restore[0]["axes"]["az"]
    assert az["drive"] == 1.0 and az["to_deg"] - az["from_deg"] > 0.4 * 6.0
    assert restore[0]["off_wall_s"] == pytest.approx(rec["wall_s"] + restore[0]["run_on_s"])


class _StepClock:
    """A clock set by hand that is not a VirtualClock (a real clock's truth and log)."""

    t = 0.0

    def now_s(self) -> float:
        return self.t


class _RealClock:
    """A clock that is not a VirtualClock (the truth carries wall times only then)."""

    def now_s(self) -> float:
        return 0.0


def _params():
    from urc.hardware.sim import physics_for
    return physics_for("tartu-urc")


# ------------------------------------------------------- the emulated gpio backend
EXAMPLES = sorted(p for p in (__import__("pathlib").Path(__file__).resolve().parents[2] / "examples").glob("*.toml")
                  if 'backend = "gpio"' in p.read_text())   # (a bridge example has no parts of urc's)


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_emulated_examples_wire_the_part_and_a_freeze_cuts_the_motors(path, tmp_path):
    """Every gpio example has the safety part; emulated, the heartbeat pin (a mock
    pin) feeds the modelled monostable, so a controller frozen mid-move stops."""
    from test_gpio_emulated import emulated

    from urc.rotator.loop import run_virtual

    rot, clock = emulated(path, tmp_path)
    world = rot.hw.world
    assert world.enable is not None and world.enable.timeout_s <= 0.25
    top = rot.caps.az.max_rate_deg_per_s
    start = world.truth()["az"]["deg"]
    rot.goto_az(min(start + 120.0, rot.status().limits["az"][1] - 1.0))
    run_virtual(rot, clock, 60.0, until=lambda s: abs(s.sim_truth["az"]["rate_deg_per_s"]) > 0.8 * top)
    at_freeze = world.truth()["az"]["deg"]
    assert world.motor_power()
    clock.advance(2.0)                            # frozen: no tick, no heartbeat edge
    rot.hw.poll(clock.now_s())
    truth = rot.hw.sim_truth()
    assert truth["motor_enable"]["trips"] == 1 and not truth["motor_enable"]["powered"]
    assert truth["az"]["rate_deg_per_s"] == 0.0
    assert abs(truth["az"]["deg"] - at_freeze) <= top * (world.enable.timeout_s + 0.02) + 1.0
