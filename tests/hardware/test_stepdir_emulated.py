"""examples/satnogs-v3.toml on emulated pins: urc's trajectories on the profile never lose
a step (the count is the simulator's steps), a forced lost step is a fault where an
AS5600 checks the count and goes unseen where none does until homing on the endstop
re-references it; a fault while moving leaves the position uncertain until then."""

from __future__ import annotations

from pathlib import Path

import pytest

from urc.errors import CommandRejected

from urc.assembly import build_rotator
from urc.cli import with_emulation
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.errors import ConfigError
from urc.procedures import calibration as cal
from urc.rotator.loop import run_virtual

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "satnogs-v3.toml"
STEP_DEG = 1.0 / 240.0


def rig(tmp_path, **az_cfg):
    data = with_emulation(load_config(EXAMPLE)).to_dict()
    data["hardware"].setdefault("sim", {}).update({"wind": False})
    data["hardware"]["gpio"]["az"].update(az_cfg)
    clock = VirtualClock(1000.0)
    rot = build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False, fast_virtual=True)
    return rot, clock


def settle(rot, clock, az, el, limit_s=120.0):
    return run_virtual(rot, clock, limit_s, until=lambda s: not s.moving and s.az.mode in ("holding", "idle")
                       and s.el.mode in ("holding", "idle") and abs(s.az_deg - az) < 0.2 and abs(s.el_deg - el) < 0.2)


def model(rot, axis):
    return rot.hw.gpio.emulation[f"{axis} stepper"].axis


def test_gotos_on_the_profile_never_lose_a_step(tmp_path):
    rot, clock = rig(tmp_path)
    for az, el in ((40.0, 30.0), (350.0, 85.0), (10.0, 2.0)):
        rot.goto(az, el)
        s = settle(rot, clock, az, el)
        assert not s.faults, s.faults
        for n in ("az", "el"):
            m = model(rot, n)
            assert m.steps_lost == 0 and m.worst_margin > 1.3
            assert rot.hw.axis(n).motor.steps() == m.steps_taken          # the count is the steps
            assert rot.hw.gpio.emulation[f"{n} stepper"].dir_violations == 0
        assert s.sim_truth["az"]["deg"] == pytest.approx(az, abs=rot.caps.az.restart_deg + STEP_DEG)
        assert s.sim_truth["el"]["deg"] == pytest.approx(el, abs=rot.caps.el.restart_deg + STEP_DEG)
        assert s.az_deg == pytest.approx(s.sim_truth["az"]["deg"], abs=STEP_DEG)   # open loop, exact
    rot.hw.close()


def test_a_goto_to_the_limit_ends_there_within_the_tolerance(tmp_path):
    """The reference runs at its slowest speed to a standing target and stops there: the
    guard took that speed's braking distance as still ahead of an axis that follows as
    fast as a stepper, and cut a goto to az 0 short at the limit ("guard: az stopped at
    0.00 deg before its limit"). And the steps queued ahead of the tick are where the
    axis goes: counted as such, the law stops it within the tolerance (it ended 0.06 deg
    past az 0, past the 0.05 deg tolerance, the steps it had queued)."""
    rot, clock = rig(tmp_path)
    tol = rot.caps.az.tolerance_deg
    for i, start in enumerate((30.0, 60.0, 12.0, 150.0)):
        rot.goto(start, 30.0 + i)
        settle(rot, clock, start, 30.0 + i)
        rot.goto(0.0, 60.0)
        s = settle(rot, clock, 0.0, 60.0)
        s = run_virtual(rot, clock, 0.5)          # every queued step out
        assert not [e for e in s.events if e.startswith("guard")], (start, s.events)
        assert abs(s.sim_truth["az"]["deg"]) <= tol + STEP_DEG, (start, s.sim_truth["az"]["deg"])
        assert (s.az_deg - s.sim_truth["az"]["deg"] + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=STEP_DEG)
        assert not s.faults
    rot.hw.close()


def test_a_lost_step_is_a_fault_with_an_as5600(tmp_path):
    rot, clock = rig(tmp_path, as5600_check=True)
    rot.goto(20.0, 10.0)
    settle(rot, clock, 20.0, 10.0)
    assert not rot.status().faults
    # 9 full steps slip (a jam): more than the check's tolerance (2 AS5600 counts, 0.18
    # deg) plus the count either reading is off by, so seen wherever the axis ends on the
    # AS5600's grid (6 full steps, 0.2 deg, were seen or not by where the goto ended)
    model(rot, "az").lose_next_steps(72)
    rot.goto(60.0, 10.0)
    s = run_virtual(rot, clock, 30.0, until=lambda s: bool(s.faults))
    assert [(f.kind, f.axis) for f in s.faults] == [("driver", "az")]
    assert "absolute sensor differ" in s.faults[0].reason
    rot.hw.close()


def test_a_lost_step_without_a_sensor_is_unseen_until_homing(tmp_path):
    rot, clock = rig(tmp_path)
    rot.goto(20.0, 10.0)
    settle(rot, clock, 20.0, 10.0)
    model(rot, "az").lose_next_steps(240)          # a whole degree slips
    rot.goto(30.0, 10.0)
    s = settle(rot, clock, 30.0, 10.0)
    assert not s.faults                            # open loop: nothing can see it
    assert s.az_deg - s.sim_truth["az"]["deg"] == pytest.approx(1.0, abs=STEP_DEG)
    proc = cal.LimitSwitchHoming(rot, "az")        # homing on the endstop re-references it
    run_virtual(rot, clock, 600.0, on_tick=proc.poll, until=lambda s: proc.finished)
    assert proc.state == "done", proc.as_dict()
    s = run_virtual(rot, clock, 0.2)
    # (LimitSwitchHoming looks for the switch's release only 0.2 s into its back-off:
    # at its 1.33 deg/s that is up to 0.27 deg late, whatever the sensor)
    assert s.az.pos_deg == pytest.approx(s.sim_truth["az"]["deg"], abs=0.3)
    assert proc.result["correction_deg"] == pytest.approx(-1.0, abs=0.3)
    rot.hw.close()


def test_a_fault_while_moving_makes_the_position_uncertain(tmp_path):
    rot, clock = rig(tmp_path)
    rot.goto(90.0, 0.0)
    run_virtual(rot, clock, 3.0)
    assert rot.status().moving
    rot.hw.drive_safe()                             # what a fault, the watch or power-fail do
    s = run_virtual(rot, clock, 0.1)
    assert ("driver", "az") in [(f.kind, f.axis) for f in s.faults]
    assert "cut while moving" in next(f.reason for f in s.faults if f.axis == "az")
    assert rot.hw.axis("az").motor.position_lost
    # clearing the fault does not make the count the position again: uncertain until homed
    rot.clear_faults()
    s = run_virtual(rot, clock, 0.1)
    assert not s.position_known and s.az.uncertainty_deg > 0
    with pytest.raises(CommandRejected, match="uncertain"):
        rot.goto(10.0, 0.0)
    rot.hw.close()


def test_stepdir_config_errors(tmp_path):
    data = load_config(EXAMPLE).to_dict()
    data["hardware"]["gpio"]["az"]["stepper_driver"] = "a4899"
    with pytest.raises(ConfigError, match="stepper_driver"):
        Config.from_dict(data)
    data = load_config(EXAMPLE).to_dict()
    data["hardware"]["gpio"]["az"]["microsteps"] = 32             # the A4988 stops at 1/16
    with pytest.raises(ConfigError, match="microsteps"):
        Config.from_dict(data)
    data = load_config(EXAMPLE).to_dict()
    data["hardware"]["gpio"]["az"].update(stepper_driver="tmc2209", pins={"step": 17, "dir": 27, "ms3": 22})
    with pytest.raises(ConfigError, match="ms3"):
        Config.from_dict(data)
    data = load_config(EXAMPLE).to_dict()          # two AS5600 checks on one bus: one address
    for n in ("az", "el"):
        data["hardware"]["gpio"][n]["as5600_check"] = True
    with pytest.raises(ConfigError, match="two AS5600"):
        Config.from_dict(data)
    data["hardware"]["gpio"]["el"]["i2c_bus"] = 3
    Config.from_dict(data)
