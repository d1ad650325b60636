"""The step/dir driver table (urc.hardware.drivers.stepdir_chips) against the datasheet
figures as checked for issue 37 (the sources are named in the table's comments)."""

from __future__ import annotations

import pytest

from urc.hardware.drivers.stepdir_chips import HOME_SNAP_FULL_STEPS, STEPDIR_CHIPS, pulse_times_us

# name: (step high min, step low min, DIR setup, DIR hold) in ns, enable active low,
# microstep pins, wake-up, translator home on motor-supply loss, steps counted disabled
TIMING_NS = {
    "a4988": (1000, 1000, 200, 200),
    "drv8825": (1900, 1900, 650, 650),
    # max(tFILTSD, tCLK + 20 ns) at the slowest internal clock (11.5 MHz): not the 100 ns typical
    "tmc2208": (106.96, 106.96, 20, 20),
    "tmc2209": (106.96, 106.96, 20, 20),
}
MICROSTEPS = {
    "a4988": (("ms1", "ms2", "ms3"), {(0, 0, 0): 1, (1, 0, 0): 2, (0, 1, 0): 4, (1, 1, 0): 8, (1, 1, 1): 16}),
    "drv8825": (("mode0", "mode1", "mode2"), {(0, 0, 0): 1, (1, 0, 0): 2, (0, 1, 0): 4, (1, 1, 0): 8,
                                              (0, 0, 1): 16, (1, 0, 1): 32, (0, 1, 1): 32, (1, 1, 1): 32}),
    "tmc2208": (("ms1", "ms2"), {(0, 0): 8, (1, 0): 2, (0, 1): 4, (1, 1): 16}),
    "tmc2209": (("ms1", "ms2"), {(0, 0): 8, (1, 0): 32, (0, 1): 64, (1, 1): 16}),
}
WAKE_S = {"a4988": 1e-3, "drv8825": 1.7e-3, "tmc2208": None, "tmc2209": None}
HOME_ON_SUPPLY_LOSS = {"a4988": False, "drv8825": True, "tmc2208": True, "tmc2209": True}
STEPS_WHILE_DISABLED = {"a4988": True, "drv8825": False, "tmc2208": False, "tmc2209": False}


def test_the_table_has_the_four_chips():
    assert set(STEPDIR_CHIPS) == set(TIMING_NS)


@pytest.mark.parametrize("name", sorted(TIMING_NS))
def test_interface_timing(name):
    chip = STEPDIR_CHIPS[name]
    got = tuple(round(v * 1e9, 2) for v in (chip.step_high_min_s, chip.step_low_min_s,
                                             chip.dir_setup_s, chip.dir_hold_s))
    assert got == TIMING_NS[name]


@pytest.mark.parametrize("name", sorted(TIMING_NS))
def test_enable_microsteps_wake_and_translator(name):
    chip = STEPDIR_CHIPS[name]
    assert chip.enable_active_low                    # nENBL / ENABLE / ENN: high disables, all four
    assert (chip.microstep_pins, chip.microstep_table) == MICROSTEPS[name]
    assert chip.wake_s == WAKE_S[name]
    assert chip.home_on_motor_supply_loss is HOME_ON_SUPPLY_LOSS[name]
    assert chip.steps_while_disabled is STEPS_WHILE_DISABLED[name]
    assert chip.source


def test_only_the_drv8825_states_a_step_rate_limit():
    assert STEPDIR_CHIPS["drv8825"].max_step_hz == 250e3
    assert all(STEPDIR_CHIPS[n].max_step_hz is None for n in ("a4988", "tmc2208", "tmc2209"))


def test_home_snap_is_half_an_electrical_turn():
    assert HOME_SNAP_FULL_STEPS == 2                 # 4 full steps per electrical turn


@pytest.mark.parametrize("name", sorted(TIMING_NS))
def test_pulses_never_under_the_minima(name):
    chip = STEPDIR_CHIPS[name]
    for rate in (1.0, 800.0, 3200.0, 20000.0):
        high, low = pulse_times_us(rate, chip)
        assert high * 1e-6 >= chip.step_high_min_s and low * 1e-6 >= chip.step_low_min_s
