"""The plain simulator drives a stepper profile (satnogs-v3) through its step/dir stage
(urc.hardware.sim.stepdrive): urc's step/dir driver on the simulated pulse queue, the
step count as the axis' sensor, the stepper model moving the axis. Steps move it
exactly while they stay under the pull-out curve; beyond it, against a jam or a hard
stop, they are lost and the count runs away from the truth (issue 37)."""

from __future__ import annotations

import pytest

from urc.hardware.drivers.stepper import StepCountSensor, StepDirMotor

from sim_rig import rig  # noqa: F401  (fixture)


def _drive(r, axis: str, duty: float, seconds: float) -> None:
    """The law's way: a drive every tick (a stepper queues a tick or two ahead)."""
    motor = r.hw.axis(axis).motor
    for _ in range(round(seconds / 0.02)):
        motor.set_drive(duty)
        r.run(0.02)


def _stop(r, axis: str) -> None:
    motor = r.hw.axis(axis).motor
    for _ in range(200):
        motor.set_drive(0.0)
        r.run(0.02)
        if motor.at_rest():
            return
    raise AssertionError("the axis did not come to rest")


@pytest.mark.parametrize("axis", ["az", "el"])
def test_sim_satnogs_position_is_the_step_count(rig, axis):
    r = rig("satnogs-v3", start_az_deg=100.0, start_el_deg=45.0)
    ax = r.hw.axis(axis)
    assert isinstance(getattr(ax.motor, "driver", ax.motor), StepDirMotor)
    assert isinstance(ax.sensor, StepCountSensor)
    chip = dict(r.hw.parts)[f"{axis} stepper"]
    x0 = r.truth(axis)["deg"]
    assert ax.sensor.read_deg() == pytest.approx(x0, abs=1e-9)
    _drive(r, axis, 1.0, 3.0)
    _drive(r, axis, -0.3, 2.0)
    _stop(r, axis)
    x1 = r.truth(axis)["deg"]
    assert x1 - x0 > 10.0                          # it went somewhere, at speed
    # exact: every step moved the axis by one microstep after the worm, none lost
    steps = ax.motor.steps()
    assert chip.axis.steps_lost == 0 and chip.axis.steps_taken == steps
    assert x1 == pytest.approx(x0 + steps / ax.motor.steps_per_deg, abs=1e-9)
    assert ax.sensor.read_deg() == pytest.approx(x1, abs=1e-9)
    assert chip.axis.worst_margin > 1.0


def test_sim_satnogs_jam_loses_the_steps(rig):
    """A jammed axis (a fault injected in the world) slips every step: the count moves,
    the antenna does not (open loop: nothing in urc can see it)."""
    r = rig("satnogs-v3", start_az_deg=100.0)
    ax = r.hw.axis("az")
    chip = dict(r.hw.parts)["az stepper"]
    r.world.inject("az", "jam")
    _drive(r, "az", 1.0, 1.0)
    _stop(r, "az")
    assert r.truth("az")["deg"] == pytest.approx(100.0, abs=1e-9)
    assert ax.sensor.read_deg() > 103.0
    assert chip.axis.steps_lost == ax.motor.steps() > 0


def test_sim_satnogs_train_beyond_pull_out_slips(rig):
    """Steps demanded faster than the motor's pull-out torque allows (a train queued
    straight on the STEP pin, past urc's envelope: 1000 full steps/s from standstill)
    move nothing."""
    r = rig("satnogs-v3", start_az_deg=100.0)
    motor = r.hw.axis("az").motor
    chip = dict(r.hw.parts)["az stepper"]
    assert motor.pulses.queue(10, 115, 800) >= 0       # 8000 microsteps/s
    r.run(0.5)
    assert motor.pulses.emitted == 800
    assert chip.axis.steps_lost == 800
    assert r.truth("az")["deg"] == pytest.approx(100.0, abs=1e-9)


def test_sim_satnogs_hard_stop_stalls_the_rotor(rig):
    """Past the hard stop (5 deg below the range) the rotor stalls: the steps are lost."""
    r = rig("satnogs-v3", start_az_deg=-3.0)
    chip = dict(r.hw.parts)["az stepper"]
    _drive(r, "az", -0.5, 2.0)
    _stop(r, "az")
    assert r.truth("az")["deg"] == pytest.approx(-5.0, abs=1e-2)
    assert chip.axis.steps_lost > 0


def test_sim_stepper_driver_option(rig):
    r = rig("satnogs-v3", stepper_driver="drv8825")
    assert r.hw.axis("az").motor.chip.name.lower().startswith("drv8825")
    from urc.errors import ConfigError
    with pytest.raises(ConfigError, match="stepper_driver"):
        rig("satnogs-v3", stepper_driver="l298")
