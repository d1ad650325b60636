"""SimWorld: truth persistence across restarts, fault injection, and the contracts."""

from __future__ import annotations

import json
import logging
import math

import pytest

from urc.clock import VirtualClock
from urc.errors import ConfigError, SensorError
from urc.hardware import build_hardware
from urc.hardware.interfaces import Brake, Hardware, LimitSwitch, Motor, PositionSensor
from urc.hardware.sim import FAULT_KINDS, physics_for
from urc.profiles import PROFILES
from sim_rig import rig  # noqa: F401  (fixture)


# ---------------------------------------------------------------- contracts
@pytest.mark.parametrize("profile", sorted(PROFILES))
def test_devices_satisfy_the_protocols(tmp_path, profile):
    hw = build_hardware("sim", PROFILES[profile], VirtualClock(), tmp_path, {"wind": False})
    assert isinstance(hw, Hardware) and hw.backend == "sim"
    for name in ("az", "el"):
        ax, caps = hw.axis(name), PROFILES[profile].axis(name)
        assert isinstance(ax.motor, Motor)
        assert isinstance(ax.sensor, PositionSensor)
        # (a stepper's sensor is its step count: an incremental encoder of the profile's resolution)
        assert ax.sensor.caps is caps.sensor or physics_for(profile).axis(name).stepper is not None
        assert ax.sensor.caps == caps.sensor
        assert (ax.brake is not None) == caps.brake
        if ax.brake is not None:
            assert isinstance(ax.brake, Brake)
        assert (ax.limit_min is not None) == caps.limit_switches
        for sw in (ax.limit_min, ax.limit_max):
            if sw is not None:
                assert isinstance(sw, LimitSwitch) and not sw.is_active()
        assert isinstance(ax.sensor.read_deg(), float)
        assert isinstance(ax.sensor.calibration(), dict)
        assert isinstance(ax.motor.read_current_a(), float)
    hw.poll(0.0)
    hw.poll(0.5)
    truth = hw.sim_truth()
    assert set(truth) == {"az", "el", "heartbeat"}
    assert {"deg", "rate_deg_per_s", "gear_deg", "current_a", "brake_released"} <= set(truth["az"])
    hw.close()
    assert (tmp_path / "simulator-truth.json").exists()


def test_limit_switches_follow_the_antenna(rig):
    r = rig("bigras", start_az_deg=449.0)
    p = physics_for("bigras").az
    hi, lo = r.hw.az.limit_max, r.hw.az.limit_min
    r.hw.az.motor.set_drive(1.0)
    r.run(3.0)
    assert r.truth("az")["deg"] == p.hard_max_deg
    assert hi.is_active() and not lo.is_active()
    assert r.caps.az.max_deg < p.switch_max_deg < p.hard_max_deg


# ---------------------------------------------------------------- truth persistence
def _opts(tmp_path, **kw):
    return dict(truth_file=tmp_path / "truth.json", truth_wall_interval_s=0.0, **kw)


def test_truth_survives_a_clean_restart(rig, tmp_path):
    r = rig("berkeley", **_opts(tmp_path, start_az_deg=10.0))
    r.hw.az.motor.set_drive(0.5)
    r.run(2.0)
    r.hw.az.motor.set_drive(0.0)
    r.run(1.0)
    before = r.world.truth()
    r.hw.close()
    r2 = rig("berkeley", **_opts(tmp_path))
    after = r2.world.truth()
    for axis in ("az", "el"):
        assert after[axis]["deg"] == before[axis]["deg"]
        assert after[axis]["gear_deg"] == before[axis]["gear_deg"]
    # an absolute sensor reads the true angle at once
    assert r2.hw.az.sensor.read_deg() == pytest.approx(before["az"]["deg"], abs=0.1)


def test_killed_mid_move_coasts_down_on_restart(rig, tmp_path):
    r = rig("tartu-urc", **_opts(tmp_path, start_az_deg=10.0))
    r.release_brake("az")
    r.hw.az.motor.set_drive(1.0)
    r.run(2.0)
    saved = json.loads((tmp_path / "truth.json").read_text())["axes"]["az"]
    assert saved["load_deg_per_s"] > 5.0 and saved["brake_released"]
    # no close(): the process was killed; the next controller finds the rotator stopped
    r2 = rig("tartu-urc", **_opts(tmp_path))
    t = r2.truth("az")
    assert t["rate_deg_per_s"] == 0.0 and t["gear_rate_deg_per_s"] == 0.0
    coast_deg = t["deg"] - saved["load_deg"]
    assert 0.0 < coast_deg < 1.0                   # coasted, brake closed after 0.1 s
    assert t["brake_released"] is False and not r2.hw.az.brake.is_released()
    # the encoder lost power: it counts from 0 again
    assert r2.hw.az.sensor.read_deg() == 0.0 and r2.hw.az.sensor.counts() == 0
    r2.hw.az.sensor.set_reference_deg(t["gear_deg"])    # the controller re-references


def test_relay_axis_coasts_longer_after_a_kill(rig, tmp_path):
    r = rig("g5500", **_opts(tmp_path, start_az_deg=10.0))
    r.hw.az.motor.set_drive(1.0)
    r.run(2.0)
    saved = json.loads((tmp_path / "truth.json").read_text())["axes"]["az"]
    r2 = rig("g5500", **_opts(tmp_path))
    assert r2.truth("az")["deg"] - saved["load_deg"] == pytest.approx(
        PROFILES["g5500"].az.overshoot_deg, rel=0.5)


def test_truth_not_written_when_idle(rig, tmp_path, monkeypatch):
    r = rig("berkeley", **_opts(tmp_path))
    writes = []
    monkeypatch.setattr(r.world, "_write_truth", lambda: writes.append(1))
    r.run(5.0)
    assert len(writes) <= 1
    r.hw.az.motor.set_drive(1.0)
    r.run(1.0)
    assert 30 <= len(writes) <= 51                  # at most every 20 ms of clock time


def test_corrupt_truth_file_warns_and_starts_from_defaults(rig, tmp_path, caplog):
    (tmp_path / "truth.json").write_text("{not json")
    with caplog.at_level(logging.WARNING):
        r = rig("g4jnt", **_opts(tmp_path))
    assert "unusable" in caplog.text
    assert r.truth("az")["deg"] == PROFILES["g4jnt"].az.park_deg
    (tmp_path / "truth.json").write_text(json.dumps(
        {"version": 1, "profile": "g4jnt", "axes": {"az": {"load_deg": "nan"}}}))
    r = rig("g4jnt", **_opts(tmp_path))
    assert r.truth("az")["deg"] == PROFILES["g4jnt"].az.park_deg


def test_truth_of_another_profile_is_ignored(rig, tmp_path, caplog):
    r = rig("berkeley", **_opts(tmp_path, start_az_deg=77.0))
    r.hw.close()
    with caplog.at_level(logging.WARNING):
        r2 = rig("g5500", **_opts(tmp_path))
    assert "profile" in caplog.text
    assert r2.truth("az")["deg"] == 0.0


# ---------------------------------------------------------------- faults
def test_sensor_faults(rig):
    r = rig("berkeley", start_az_deg=50.0, sensor_noise=False)
    w, s, m = r.world, r.hw.az.sensor, r.hw.az.motor
    w.inject("az", "sensor_stuck")
    stuck = s.read_deg()
    m.set_drive(0.5)
    r.run(1.0)
    assert r.truth("az")["deg"] > 55.0 and s.read_deg() == stuck
    w.clear("az", "sensor_stuck")
    assert s.read_deg() == pytest.approx(r.truth("az")["deg"], abs=0.1)
    m.set_drive(0.0)
    r.run(0.5)
    true_read = s.read_deg()
    w.inject("az", "sensor_jump", deg=25.0)
    assert s.read_deg() == pytest.approx(true_read + 25.0)
    w.clear("az", "sensor_jump")
    w.inject("az", "sensor_dead")
    with pytest.raises(SensorError):
        s.read_deg()
    assert w.faults()["az"] == {"sensor_dead": {}}
    assert r.world.truth()["az"]["faults"] == ["sensor_dead"]
    w.clear("az")
    assert s.read_deg() == true_read and w.faults()["az"] == {}


def test_jam_stalls_the_motor(rig):
    r = rig("bigras", start_az_deg=100.0)
    r.world.inject("az", "jam")
    r.hw.az.motor.set_drive(1.0)
    r.run(1.0)
    assert r.truth("az")["deg"] == 100.0
    assert r.hw.az.motor.read_current_a() == pytest.approx(physics_for("bigras").az.stall_current_a)
    r.world.clear("az", "jam")
    r.run(1.0)
    assert r.truth("az")["deg"] > 102.0


@pytest.mark.parametrize("profile", ["g4jnt", "berkeley"])
def test_runaway_ignores_the_command(rig, profile):
    r = rig(profile, start_az_deg=100.0)
    r.world.inject("az", "runaway", duty=-1.0)          # e.g. a welded relay
    r.hw.az.motor.set_drive(0.0)
    r.run(1.0)
    assert r.truth("az")["rate_deg_per_s"] == pytest.approx(-r.caps.az.max_rate_deg_per_s, rel=0.05)
    r.hw.az.motor.set_drive(1.0)
    r.run(0.5)
    assert r.truth("az")["rate_deg_per_s"] < 0
    r.world.clear("az", "runaway")
    r.run(1.0)
    assert r.truth("az")["rate_deg_per_s"] > 0


def test_reverse_wiring(rig):
    r = rig("tartu-urc", start_el_deg=90.0)
    r.release_brake("el")
    r.world.inject("el", "reverse_wiring")
    r.hw.el.motor.set_drive(1.0)
    r.run(1.0)
    assert r.truth("el")["deg"] < 86.0
    assert r.hw.el.sensor.read_deg() < 86.0             # the encoder sees it (quadrature)


def test_forced_limit_switch(rig):
    r = rig("bigras", start_el_deg=45.0)
    r.world.inject("el", "limit_switch", which="min")
    assert r.hw.el.limit_min.is_active() and not r.hw.el.limit_max.is_active()
    r.world.clear("el", "limit_switch")
    assert not r.hw.el.limit_min.is_active()
    with pytest.raises(ValueError):
        rig("berkeley").world.inject("az", "limit_switch")
    with pytest.raises(ValueError):
        r.world.inject("az", "gremlins")


def test_fault_injection_option(rig, tmp_path):
    r = rig("bigras", fault_injection=[{"axis": "az", "kind": "sensor_jump", "deg": 5}])
    assert r.world.faults()["az"] == {"sensor_jump": {"deg": 5}}
    r = rig("bigras", fault_injection={"el": {"jam": {}}})
    assert "jam" in r.world.faults()["el"]
    with pytest.raises(ConfigError):
        rig("bigras", fault_injection=[{"axis": "up", "kind": "jam"}])
    assert set(FAULT_KINDS) == {"sensor_stuck", "sensor_jump", "sensor_dead", "jam",
                                "runaway", "limit_switch", "reverse_wiring", "slow_read"}


def test_unknown_caps_get_generic_physics(tmp_path):
    from dataclasses import replace
    caps = replace(PROFILES["tartu-urc"], name="tartu-fast",
                   az=replace(PROFILES["tartu-urc"].az, max_rate_deg_per_s=12.0))
    hw = build_hardware("sim", caps, VirtualClock(), tmp_path, {"wind": False, "truth_file": None})
    w = hw.world
    assert not math.isclose(w.params.az.kt_nm_per_a, physics_for("tartu-urc").az.kt_nm_per_a)


# ---------------------------------------------------------------- a frozen controller
@pytest.mark.parametrize("profile,axis", [("tartu-urc", "az"), ("g5500", "az"), ("bigras", "el")])
@pytest.mark.parametrize("freeze_s", [2.0, 10.0])
def test_a_freeze_runs_on_with_the_drive_the_hardware_last_had(tmp_path, profile, axis, freeze_s):
    """Issue 9.8: while the controller is frozen the iron keeps the last drive; a motor
    switched off on waking stops only from then on."""
    clock = VirtualClock()
    hw = build_hardware("sim", PROFILES[profile], clock, tmp_path, {"wind": False, "start_az_deg": 10.0,
                                                                    "start_el_deg": 5.0})
    world = hw.world
    hw.poll(clock.now_s())
    ax = hw.axis(axis)
    if ax.brake is not None:
        ax.brake.set_released(True)
    ax.motor.set_drive(0.5)
    for _ in range(100):  # up to speed
        clock.advance(0.02)
        hw.poll(clock.now_s())
    rate = world.truth()[axis]["rate_deg_per_s"]
    assert rate > 0.1
    before = world.truth()[axis]["deg"]
    clock.advance(freeze_s)           # the controller hangs: no poll, no command
    ax.motor.set_drive(0.0)           # on waking, a fault switches the motor off
    hw.poll(clock.now_s())
    moved = world.truth()[axis]["deg"] - before
    hard_max = physics_for(profile).axis(axis).hard_max_deg
    expected = min(rate * freeze_s, (hard_max if hard_max is not None else math.inf) - before)
    assert moved >= 0.8 * expected, (moved, rate * freeze_s)


def test_close_right_after_the_brake_is_switched_off_saves_it_engaged(tmp_path):
    """A brake engages its delay after its coil is switched off, powered or not: a close
    within that delay (every orderly stop: outputs safe, then close) saved it released."""
    clock = VirtualClock()
    hw = build_hardware("sim", PROFILES["tartu-urc"], clock, tmp_path, {"wind": False})
    hw.poll(0.0)
    hw.az.brake.set_released(True)
    clock.advance(1.0)
    hw.poll(1.0)
    assert hw.sim_truth()["az"]["brake_released"] is True
    hw.drive_safe()
    hw.close()
    saved = json.loads((tmp_path / "simulator-truth.json").read_text())["axes"]
    assert saved["az"]["brake_released"] is False and saved["el"]["brake_released"] is False


# ---------------------------------------------------------------- threads
def test_the_world_is_one_iron_for_every_thread(tmp_path):
    """The control process's tick-watch thread drives the outputs safe while the loop
    thread ticks (both wake together after a SIGSTOP): the world must take their calls
    one at a time, as the iron does. Unserialised, two threads stepped the same substeps
    (the physics ran twice as far) or both took the same brake event (KeyError: the
    control loop died after a thaw)."""
    import sys
    import threading

    clock = VirtualClock()
    hw = build_hardware("sim", PROFILES["tartu-urc"], clock, tmp_path, {"wind": False})
    world = hw.world
    hw.poll(0.0)
    brake_s = PROFILES["tartu-urc"].az.brake_release_s
    errors: list[BaseException] = []
    old_interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)     # switch threads as often as the interpreter can
    try:
        for _ in range(300):
            hw.az.brake.set_released(world.axes["az"].brake_engaged)   # (a brake event each round)
            clock.advance(brake_s + 0.05)       # the brake event is due: both threads see it
            gate = threading.Barrier(2)

            def act(call):
                try:
                    gate.wait()
                    call()
                except BaseException as exc:  # noqa: BLE001 (reported below)
                    errors.append(exc)
            threads = [threading.Thread(target=act, args=(lambda: hw.poll(clock.now_s()),)),
                       threading.Thread(target=act, args=(hw.drive_safe,))]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
            assert not errors, errors
            # each axis stepped exactly to the present: no substep run twice
            assert world.time_s == pytest.approx(clock.now_s(), abs=world.dt_s)
            for phys in world.axes.values():
                assert phys.tick == world.axes["az"].tick
    finally:
        sys.setswitchinterval(old_interval)
