"""The safety chain's read-back watched on every tick (review of issue 35, finding 1).
The relay dropping on its own while urc drives (the chain's ``contact_open`` fault: its
coil supply, an e-stop in the coil circuit) is a ``motor_power`` fault on every motor
kind. The fault never clears by itself, and a step/dir axis loses its position. A
legitimate cut (a frozen controller) and a single bouncing reading are not faults. Each
supply loss, the self-test's cut included, widens a step/dir count's bound by the 2 full
steps of its indexer's reset. All on a virtual clock."""

from __future__ import annotations

from pathlib import Path

import pytest

from urc.assembly import build_rotator
from urc.cli import with_emulation
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.errors import CommandRejected
from urc.hardware import build_hardware
from urc.hardware.safety_test import self_test
from urc.profiles import get_profile
from urc.rotator.loop import run_virtual
from urc.rotator.rotator import Rotator, RotatorSettings

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
FULL_STEP_DEG = 8 / 240.0          # satnogs-v3: 1/8 microstep, 1/240 deg a microstep


def satnogs(tmp_path, chip: str = "a4988"):
    """examples/satnogs-v3.toml emulated (its A4988s, or ``chip``, on the lgpio queue, the
    chain modelled)."""
    data = with_emulation(load_config(EXAMPLES / "satnogs-v3.toml")).to_dict()
    data["hardware"].setdefault("sim", {}).update({"wind": False})
    for axis in ("az", "el"):
        data["hardware"]["gpio"][axis]["stepper_driver"] = chip
    clock = VirtualClock(1000.0)
    rot = build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False, fast_virtual=True)
    return rot, clock


def settle(rot, clock, az, el, limit_s=120.0):
    return run_virtual(rot, clock, limit_s, until=lambda s: not s.moving and abs(s.az_deg - az) < 0.2
                       and abs(s.el_deg - el) < 0.2)


def kinds(s):
    return [(f.kind, f.axis) for f in s.faults]


def test_a_relay_dropping_mid_move_on_a_stepper_is_a_fault_and_loses_the_count(tmp_path):
    """The review's probe (probe_power_drop.py): the motor supply gone for 2 s mid-goto.
    Before: no fault, position_lost empty, urc at 200.05 with the truth at 175.7."""
    rot, clock = satnogs(tmp_path)
    rot.goto(20.0, 10.0)
    settle(rot, clock, 20.0, 10.0)
    rot.goto(200.0, 10.0)
    s = run_virtual(rot, clock, 1.0)
    assert s.moving and not s.faults
    world = rot.hw.world
    world.inject("chain", "contact_open")          # the relay drops, the heartbeat runs on
    s = run_virtual(rot, clock, 2.0, until=lambda s: bool(s.faults))
    assert kinds(s) == [("motor_power", None)]
    # the train was cut at the trip: no more steps into a driver without its supply
    az_motor = rot.hw.axis("az").motor
    count = az_motor.steps()
    assert not az_motor.pulses.busy()
    s = run_virtual(rot, clock, 2.0)
    assert az_motor.steps() == count
    reason = next(f.reason for f in s.faults if f.kind == "motor_power")
    assert "motor supply lost" in reason and "the relay's contact" in reason
    for axis in ("az", "el"):                      # the moving axis and the holding one
        lost = rot.hw.axis(axis).motor.position_lost
        assert "motor supply lost" in lost, axis
    assert "while moving" in rot.hw.axis("az").motor.position_lost
    assert "while holding" in rot.hw.axis("el").motor.position_lost
    # the supply back: nothing resumes by itself, and the count stays untrusted
    world.clear("chain", "contact_open")
    s = run_virtual(rot, clock, 5.0)
    assert ("motor_power", None) in kinds(s) and not s.moving
    assert not s.position_known and s.az.uncertainty_deg == pytest.approx(rot.caps.az.span_deg)
    rot.clear_faults()
    with pytest.raises(CommandRejected, match="uncertain"):
        rot.goto(200.0, 10.0)
    rot.hw.close()


def test_a_fault_cleared_with_the_supply_still_gone_latches_again(tmp_path):
    rot, clock = satnogs(tmp_path)
    run_virtual(rot, clock, 0.5)
    rot.hw.world.inject("chain", "contact_open")
    s = run_virtual(rot, clock, 0.2)
    assert ("motor_power", None) in kinds(s)
    rot.clear_faults()
    s = run_virtual(rot, clock, 0.1)
    assert ("motor_power", None) in kinds(s)
    rot.hw.close()


@pytest.mark.parametrize("profile", ["tartu-urc", "g5500"])
def test_every_motor_kind_gets_the_fault(tmp_path, profile):
    """The plain simulator: tartu-urc's relay motors, g5500's AC motors."""
    settings = RotatorSettings.from_caps(get_profile(profile))
    clock = VirtualClock(0.0)
    hw = build_hardware("sim", settings.caps, clock, tmp_path,
                        {"wind": False, "truth_file": None, "motor_enable_timeout_s": 0.22})
    rot = Rotator(settings, hw, clock)
    start = hw.world.truth()["az"]["deg"]
    rot.goto_az(start + 90.0)
    s = run_virtual(rot, clock, 2.0)
    assert s.moving and not s.faults
    hw.world.inject("chain", "contact_open")
    s = run_virtual(rot, clock, 0.2)
    assert kinds(s) == [("motor_power", None)]
    hw.world.clear("chain", "contact_open")
    s = run_virtual(rot, clock, 3.0)
    assert kinds(s) == [("motor_power", None)] and not s.moving


def test_a_frozen_controller_or_one_bouncing_reading_is_no_fault(tmp_path):
    """The relay drops by design when the ticks stop (a freeze longer than its timeout):
    the heartbeat did not run, so the OFF readings after the thaw are no fault. A
    single OFF reading (a contact bounce) is none either."""
    rot, clock = satnogs(tmp_path)
    rot.goto(60.0, 0.0)
    run_virtual(rot, clock, 2.0)
    clock.advance(1.0)                              # frozen: the relay drops
    s = run_virtual(rot, clock, 3.0)
    assert rot.hw.world.enable.trips >= 1
    assert ("motor_power", None) not in kinds(s)
    sense = rot.hw.enable_sense
    real, calls = sense.read, {"n": 0}

    def bouncing() -> bool:
        calls["n"] += 1
        return False if calls["n"] == 5 else real()   # one reading OFF
    sense.read = bouncing
    s = run_virtual(rot, clock, 0.5)
    sense.read = real
    assert calls["n"] >= 20                         # read on every tick
    assert ("motor_power", None) not in kinds(s)
    rot.hw.close()


@pytest.mark.parametrize("chip, full_steps", [("drv8825", 2), ("tmc2209", 2), ("a4988", 0)])
def test_the_self_tests_cut_widens_the_step_counts_bound_by_two_full_steps(tmp_path, chip, full_steps):
    """Finding 5: the self-test drops the motor supply, which resets the indexer of a chip
    whose logic runs on it (DRV8825, TMC22xx; an A4988's runs on VDD): the count's bound
    widens by 2 full steps per loss (and homing clears it)."""
    rot, clock = satnogs(tmp_path, chip)
    hw = rot.hw
    result = self_test(hw, hw.motor_enable_timeout_s, clock=clock)
    assert result.ok, result.why
    for axis in ("az", "el"):
        motor = hw.axis(axis).motor
        assert motor.supply_offs == 1              # the cut (the model's relay picks up at once)
        assert motor.position_bound_deg == pytest.approx(full_steps * FULL_STEP_DEG)
        assert not motor.position_lost            # no motor_power fault: the test's own cut
        assert ("motor-supply loss" in motor.identify()) == bool(full_steps)
    hw.axis("az").sensor.set_reference_deg(10.0)
    assert hw.axis("az").motor.position_bound_deg == 0.0
    hw.close()


def test_a_chain_cut_at_rest_on_a_drv8825_bounds_the_position_until_homed(tmp_path):
    """End to end on a whole rotator (issue 37): goto, settle, the controller frozen long
    enough for the chain to cut by design, back. The DRV8825's indexer reset snaps the
    rotor by up to 2 full steps (the model's truth); urc keeps the position, bounded by
    those 2 full steps as its uncertainty, refuses gotos as uncertain, and homing on the
    endstops clears it. Before: the thaw's rising edge picked the relay up again before
    the tick read the read-back, the OFF went unseen and the count claimed to be exact."""
    rot, clock = satnogs(tmp_path, "drv8825")
    rot.goto(20.0, 10.0)
    settle(rot, clock, 20.0, 10.0)
    motors = {n: rot.hw.axis(n).motor for n in ("az", "el")}
    # at rest: the last queued pulses out too (a cut before is a cut while stepping)
    s = run_virtual(rot, clock, 1.0, until=lambda s: all(m.at_rest() for m in motors.values()))
    assert all(m.at_rest() for m in motors.values()) and not s.faults
    chips = {n: rot.hw.gpio.emulation[f"{n} stepper"] for n in motors}
    before = {n: s.sim_truth[n]["deg"] for n in motors}
    resets = {n: chips[n].translator_resets for n in motors}       # (the first power-on's)
    snapped = {n: chips[n].axis.snapped_steps for n in motors}
    for n in motors:
        assert getattr(s, n).pos_deg == pytest.approx(before[n], abs=FULL_STEP_DEG / 8)   # a microstep
    clock.advance(1.0)                             # frozen: no heartbeat, the relay drops
    s = run_virtual(rot, clock, 1.0)
    assert rot.hw.world.enable.trips == 1 and not s.faults
    for n, m in motors.items():
        assert chips[n].translator_resets == resets[n] + 1 and chips[n].axis.steps_lost == 0
        snap_deg = (chips[n].axis.snapped_steps - snapped[n]) / m.steps_per_deg
        assert s.sim_truth[n]["deg"] == pytest.approx(before[n] + snap_deg, abs=1e-9)
        assert not m.position_lost, m.position_lost        # at rest: bounded, not lost
        assert m.position_bound_deg == pytest.approx(2 * FULL_STEP_DEG)
        ax = getattr(s, n)
        assert ax.uncertainty_deg == pytest.approx(2 * FULL_STEP_DEG)
        assert abs(ax.pos_deg - s.sim_truth[n]["deg"]) <= 2 * FULL_STEP_DEG + FULL_STEP_DEG / 8
    assert chips["az"].axis.snapped_steps != snapped["az"]  # (20 deg: the rotor did move)
    assert not s.position_known
    with pytest.raises(CommandRejected, match="uncertain"):
        rot.goto(40.0, 20.0)
    from urc.procedures import calibration as cal
    for n in ("az", "el"):
        proc = cal.LimitSwitchHoming(rot, n)
        run_virtual(rot, clock, 600.0, on_tick=proc.poll, until=lambda s: proc.finished)
        assert proc.state == "done", proc.as_dict()
    s = run_virtual(rot, clock, 0.2)
    assert s.position_known and s.az.uncertainty_deg == 0.0 and s.el.uncertainty_deg == 0.0
    assert all(m.position_bound_deg == 0.0 for m in motors.values())
    rot.goto(40.0, 20.0)                                   # accepted again
    s = settle(rot, clock, 40.0, 20.0)
    assert not s.faults
    rot.hw.close()
