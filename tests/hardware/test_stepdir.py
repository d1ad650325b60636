"""Step/dir steppers: the datasheet table, the driver's step count against the emulated
lgpio pulse queue and chip on mock pins, the simulator's pull-out model, and lost steps
(caught by an absolute sensor where there is one)."""

from __future__ import annotations

import pytest
from gpiozero.pins.mock import MockFactory

from urc.caps import SensorCaps
from urc.clock import VirtualClock
from urc.hardware.drivers.stepper import ENVELOPE_ACCEL_FACTOR, StepCountSensor, StepDirMotor
from urc.hardware.gpio.emulate_stepdir import EmulatedStepDirChip, EmulatedTxQueue
from urc.hardware.gpio.pins import PinOut
from urc.hardware.gpio.stepdir import STEPDIR_CHIPS, pulse_times_us
from urc.hardware.sim.stepper import StepperAxis, satnogs_v3_stepper
from urc.profiles import PROFILES

SATNOGS = PROFILES["satnogs-v3"].az
STEPS_PER_DEG = 240.0          # 1600 steps a motor turn x 54 / 360 (the firmware's)


def test_datasheet_table():
    a, d, t8, t9 = (STEPDIR_CHIPS[k] for k in ("a4988", "drv8825", "tmc2208", "tmc2209"))
    # A4988 Figure 1: 1 us high and low, 200 ns setup and hold; Table 1 MS1-3
    assert (a.step_high_min_s, a.step_low_min_s, a.dir_setup_s, a.dir_hold_s) == (1e-6, 1e-6, 200e-9, 200e-9)
    assert a.levels_for(8) == (1, 1, 0) and a.levels_for(16) == (1, 1, 1) and a.levels_for(1) == (0, 0, 0)
    # DRV8825 7.6: 1.9 us, 650 ns, 250 kHz; MODE 0-2 up to 1/32
    assert (d.step_high_min_s, d.dir_setup_s, d.max_step_hz) == (1.9e-6, 650e-9, 250e3)
    assert d.levels_for(8) == (1, 1, 0) and d.levels_for(16) == (0, 0, 1) and d.microstep_table[(1, 1, 1)] == 32
    # TMC2208 and TMC2209 differ in MS1/MS2 (1/2, 1/4 against 1/32, 1/64); both default 1/8
    assert t8.levels_for(8) == t9.levels_for(8) == (0, 0)
    assert t8.microstep_table[(1, 0)] == 2 and t9.microstep_table[(1, 0)] == 32
    assert all(c.enable_active_low for c in STEPDIR_CHIPS.values())
    with pytest.raises(ValueError):
        a.levels_for(32)
    # pulses never under the chip's minimum, a period whole microseconds
    assert pulse_times_us(3200.0, d) == (156, 156)
    assert pulse_times_us(20000.0, d) == (25, 25)


class Rig:
    """A driver on MockFactory pins, its pulses through the emulated lgpio queue into
    the emulated chip and the simulator's stepper axis."""

    def __init__(self, chip="a4988", check=False, start_deg=0.0):
        self.clock = VirtualClock()
        self.factory = MockFactory()
        self.dir_out = PinOut(self.factory, 20)
        self.en_out = PinOut(self.factory, 21, active_low=True)
        self.axis = StepperAxis(satnogs_v3_stepper(), start_deg)
        self.chip = EmulatedStepDirChip(STEPDIR_CHIPS[chip], self.axis, self.dir_out.pin, self.en_out.pin)
        self.queue = EmulatedTxQueue(self.clock.now_s, self.chip.on_pulses)
        self.motor = StepDirMotor("az", STEPDIR_CHIPS[chip], self.queue, self.dir_out, self.en_out,
                                  self.clock.now_s, steps_per_deg=STEPS_PER_DEG,
                                  max_rate_deg_per_s=SATNOGS.max_rate_deg_per_s,
                                  max_accel_deg_per_s2=ENVELOPE_ACCEL_FACTOR * SATNOGS.accel_deg_per_s2)
        self.check = None
        if check:
            axis = self.axis

            class As5600Like:   # the AS5600's 12-bit reading of the true axis angle
                caps = SensorCaps(kind="as5600", resolution_deg=360 / 4096, absolute=True, modulo_deg=360.0)

                def read_deg(self):
                    return round((axis.angle_deg % 360.0) / self.caps.resolution_deg) * self.caps.resolution_deg % 360
            self.check = As5600Like()
        self.sensor = StepCountSensor(SensorCaps(kind="encoder", resolution_deg=1 / 240, absolute=False), "az",
                                      self.motor, check=self.check)
        self.sensor.set_reference_deg(start_deg)

    def run(self, duty_of_t, seconds, dt=0.02):
        for _ in range(round(seconds / dt)):
            self.motor.set_drive(duty_of_t(self.clock.now_s()))
            self.clock.advance(dt)
            self.queue.advance()
            self.sensor.read_deg()


def test_count_is_the_steps_the_chip_took():
    rig = Rig()
    rig.run(lambda t: 1.0 if t < 3 else -0.4 if t < 6 else 0.0, 9.0)
    assert rig.queue.emitted > 5000
    assert rig.motor.steps() == rig.axis.steps_taken          # every pulse counted, each way
    assert rig.sensor.read_deg() == pytest.approx(rig.axis.angle_deg, abs=1e-9)
    assert rig.axis.steps_lost == 0 and rig.chip.dir_violations == 0
    assert rig.motor.driver_fault() == ""
    # mid-train the count leads the pulses by at most lg's start delay (20 ms) and a period
    rig.run(lambda t: 0.5, 1.01)
    assert rig.queue.busy()
    assert 0 <= rig.motor.steps() - rig.axis.steps_taken <= 0.5 * 3200 * 0.025


def test_rate_and_acceleration_stay_in_the_envelope():
    rig = Rig()
    rates = []
    for _ in range(200):                  # full speed one way, then at once the other
        rig.motor.set_drive(1.0 if len(rates) < 100 else -1.0)
        rates.append(rig.motor.rate_sps)
        rig.clock.advance(0.02)
    top = SATNOGS.max_rate_deg_per_s * STEPS_PER_DEG
    assert max(abs(r) for r in rates) == pytest.approx(top)
    accel = ENVELOPE_ACCEL_FACTOR * SATNOGS.accel_deg_per_s2 * STEPS_PER_DEG
    assert max(abs(b - a) for a, b in zip(rates, rates[1:])) <= accel * 0.02 + 1e-6
    rig.clock.advance(0.5)                # (lg's queue drained: the count is exact then)
    rig.queue.advance()
    assert rig.chip.dir_violations == 0 and rig.axis.steps_lost == 0
    assert rig.motor.steps() == rig.axis.steps_taken


def test_profile_never_nears_pull_out_but_a_jump_does():
    p = satnogs_v3_stepper()
    top = SATNOGS.max_rate_deg_per_s * STEPS_PER_DEG              # 3200 steps/s
    accel = SATNOGS.accel_deg_per_s2 * STEPS_PER_DEG              # 1600 steps/s^2
    assert p.margin(top, accel) > 1.5 and p.margin(top, -accel) > 1.5
    # the driver's envelope (8x the ramp) still leaves a margin at full speed
    assert p.margin(top, ENVELOPE_ACCEL_FACTOR * accel) > 1.3
    # what the envelope prevents: full speed from rest in one tick, or 4x the top speed
    assert p.margin(top, top / 0.0005) < 1.0
    assert p.margin(4 * top, 0.0) < 1.0
    rig = Rig()
    rig.run(lambda t: 1.0 if t < 5 else -1.0 if t < 12 else 0.0, 16.0)
    assert rig.axis.steps_lost == 0 and rig.axis.worst_margin > 1.5


def test_cut_while_moving_makes_the_position_uncertain_until_re_referenced():
    rig = Rig()
    rig.run(lambda t: 1.0, 2.0)
    rig.motor.force_safe()
    assert not rig.en_out.read_back()                 # the chip disabled
    why = rig.motor.driver_fault()
    assert "cut while moving" in why and rig.motor.driver_fault() == ""   # reported once
    assert rig.motor.position_lost
    rig.sensor.set_reference_deg(10.0)                # homing on the endstop
    assert not rig.motor.position_lost
    # stopped first, then made safe: nothing lost
    rig.run(lambda t: 0.0, 3.0)
    rig.motor.force_safe()
    assert rig.motor.driver_fault() == "" and not rig.motor.position_lost


def test_a_lost_step_is_caught_by_the_absolute_sensor():
    rig = Rig(check=True)
    rig.run(lambda t: 0.6, 1.0)
    rig.axis.lose_next_steps(40)                      # a jam: 40 microsteps (5 full steps) slip
    rig.run(lambda t: 0.6, 1.0)
    assert rig.axis.steps_lost == 40
    assert rig.motor.driver_fault() == ""             # compared at rest only (an I2C read's age)
    rig.run(lambda t: 0.0, 2.0)
    assert rig.motor.steps() - rig.axis.steps_taken == 40
    assert "absolute sensor differ" in rig.motor.driver_fault()


def test_a_lost_step_without_a_sensor_goes_unseen():
    """What is left: open loop, a slip the driver did not cause is invisible until the
    next homing; the count is then off by exactly the steps lost."""
    rig = Rig()
    rig.run(lambda t: 0.6, 1.0)
    rig.axis.lose_next_steps(40)
    rig.run(lambda t: 0.6, 1.0)
    rig.run(lambda t: 0.0, 2.0)
    assert rig.motor.driver_fault() == ""
    assert rig.sensor.read_deg() - rig.axis.angle_deg == pytest.approx(40 / STEPS_PER_DEG)


def test_disabled_chip_takes_no_steps():
    rig = Rig()
    rig.en_out.write(False)                  # ENABLE high: the A4988's outputs off
    rig.motor.enable = None                  # (nothing turns it back on)
    rig.run(lambda t: 0.5, 1.0)
    assert rig.axis.steps_taken == 0 and rig.axis.steps_lost == rig.queue.emitted > 0
