"""A step/dir driver's translator after a safety-chain cut or a disable (issue 37.4), as the
datasheet table has it (urc.hardware.drivers.stepdir_chips): a DRV8825's or TMC22xx's
logic runs on the motor supply, so the chain's cut resets its translator to the home
state and the rotor snaps, when power returns, to the nearest position in that state (up
to 2 full steps: half an electrical turn); an A4988's runs on VDD and keeps it. A disable
at rest keeps the translator on all four. The count then is the position only to within
the bound, until the axis is homed."""

from __future__ import annotations

import pytest
from gpiozero.pins.mock import MockFactory

from urc.caps import SensorCaps
from urc.clock import VirtualClock
from urc.hardware.drivers.stepper import ENVELOPE_ACCEL_FACTOR, StepCountSensor, StepDirMotor
from urc.hardware.gpio.emulate_stepdir import EmulatedStepDirChip, EmulatedTxQueue
from urc.hardware.gpio.pins import PinOut
from urc.hardware.gpio.stepdir import STEPDIR_CHIPS
from urc.hardware.sim.stepper import StepperAxis, satnogs_v3_stepper
from urc.profiles import PROFILES

SATNOGS = PROFILES["satnogs-v3"].az
STEPS_PER_DEG = 240.0
FULL_STEP_DEG = 8 / STEPS_PER_DEG


class Rig:
    """Driver, emulated lg queue and chip, the stepper model, and a motor supply the
    test cuts (the safety chain, read back as the chip sees it)."""

    def __init__(self, chip: str):
        self.clock = VirtualClock()
        self.factory = MockFactory()
        self.supply = True
        self.dir_out = PinOut(self.factory, 20)
        self.en_out = PinOut(self.factory, 21, active_low=True)
        self.axis = StepperAxis(satnogs_v3_stepper(), 0.0)
        self.chip = EmulatedStepDirChip(STEPDIR_CHIPS[chip], self.axis, self.dir_out.pin, self.en_out.pin,
                                        powered=lambda: self.supply)
        self.queue = EmulatedTxQueue(self.clock.now_s, self.chip.on_pulses)
        self.motor = StepDirMotor("az", STEPDIR_CHIPS[chip], self.queue, self.dir_out, self.en_out,
                                  self.clock.now_s, steps_per_deg=STEPS_PER_DEG,
                                  max_rate_deg_per_s=SATNOGS.max_rate_deg_per_s,
                                  max_accel_deg_per_s2=ENVELOPE_ACCEL_FACTOR * SATNOGS.accel_deg_per_s2)
        self._supply_was = True
        self.sensor = StepCountSensor(SensorCaps(kind="encoder", resolution_deg=1 / 240, absolute=False), "az",
                                      self.motor)
        self.sensor.set_reference_deg(0.0)

    def tick(self, duty: float = 0.0, dt: float = 0.02) -> None:
        self.motor.set_drive(duty)
        self.clock.advance(dt)
        self.queue.advance()
        self.chip.poll_power()
        if self._supply_was and not self.supply:   # (urc.hardware.supply_watch: each OFF episode)
            self.motor.supply_off()
        self._supply_was = self.supply
        self.motor.driver_fault()

    def move_then_rest(self, seconds: float) -> None:
        for _ in range(round(seconds / 0.02)):
            self.tick(0.3)
        for _ in range(100):
            self.tick(0.0)
        assert self.motor.at_rest() and self.axis.steps_lost == 0

    def cut_and_restore(self) -> None:
        self.supply = False
        for _ in range(10):
            self.tick()
        self.supply = True
        for _ in range(10):
            self.tick()

    def error_deg(self) -> float:
        return self.sensor.read_deg() - self.axis.angle_deg


def rest_off_home(rig: Rig) -> None:
    """Move until the translator is not in its home state nor half a turn from it."""
    rig.move_then_rest(1.3)
    turn = rig.axis.electrical_turn
    assert rig.axis.translator_index not in (0, turn // 2), rig.axis.translator_index


@pytest.mark.parametrize("chip", ["drv8825", "tmc2208", "tmc2209"])
def test_a_supply_cut_at_rest_resets_the_translator_and_bounds_the_count(chip):
    rig = Rig(chip)
    rest_off_home(rig)
    assert rig.error_deg() == pytest.approx(0.0, abs=1e-9)
    rig.cut_and_restore()
    assert rig.chip.translator_resets == 1
    assert rig.axis.snapped_steps != 0                         # the rotor moved, the count did not
    assert rig.error_deg() != pytest.approx(0.0, abs=1e-9)
    bound = rig.motor.position_bound_deg
    assert bound == pytest.approx(2 * FULL_STEP_DEG)           # 2 full steps at 1/8 after the worm
    assert abs(rig.error_deg()) <= bound + 1e-9
    assert rig.motor.position_lost == ""                       # bounded, not lost
    rig.sensor.set_reference_deg(rig.axis.angle_deg)           # homing re-references it
    assert rig.motor.position_bound_deg == 0.0 and rig.error_deg() == pytest.approx(0.0, abs=1e-9)


def test_an_a4988_keeps_its_translator_through_a_supply_cut():
    rig = Rig("a4988")
    rest_off_home(rig)
    rig.cut_and_restore()
    assert rig.chip.translator_resets == 0 and rig.axis.snapped_steps == 0
    assert rig.motor.position_bound_deg == 0.0
    assert rig.error_deg() == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("chip", sorted(STEPDIR_CHIPS))
def test_a_disable_at_rest_keeps_the_translator_and_the_count(chip):
    rig = Rig(chip)
    rest_off_home(rig)
    rig.motor.force_safe()                                     # the chip disabled, the supply on
    for _ in range(10):
        rig.tick()
    assert rig.axis.snapped_steps == 0 and rig.motor.position_bound_deg == 0.0
    assert rig.motor.position_lost == "" and rig.error_deg() == pytest.approx(0.0, abs=1e-9)


def test_a_supply_cut_while_stepping_loses_the_position():
    rig = Rig("drv8825")
    for _ in range(50):
        rig.tick(0.5)
    rig.supply = False
    rig.tick(0.5)
    assert "motor supply lost while moving" in rig.motor.position_lost


def test_the_model_snaps_within_half_an_electrical_turn():
    axis = StepperAxis(satnogs_v3_stepper(), 0.0)
    turn = axis.electrical_turn
    for idx in range(turn):
        axis.translator_index, before = idx, axis.angle_deg
        delta = axis.reset_translator()
        assert -turn // 2 <= delta < turn // 2 and (idx + delta) % turn == 0
        assert axis.angle_deg - before == pytest.approx(delta / axis.p.steps_per_deg)
