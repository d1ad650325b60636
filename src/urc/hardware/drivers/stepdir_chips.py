"""Step/dir stepper driver chips: their datasheet table (interface timing, enable level,
microstep pins) and the pulse times a rate needs in lgpio's units (whole microseconds,
a period over lg's floor; the pulse train itself: :mod:`..gpio.stepdir`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

#: the highest step rate the library-timed train is asked for (urc.hardware.gpio.stepdir)
MAX_LIBRARY_TIMED_HZ = 20000.0
#: lgMinTxDelay (lgPthTx.c): one period must be longer than this
LG_MIN_PERIOD_US = 11
#: LG_TX_BUF (lgPthTx.h): entries per pin
LG_TX_BUF = 10


@dataclass(frozen=True)
class StepDirChip:
    """A step/dir driver's interface timing and its microstep pins, from its datasheet."""

    name: str
    step_high_min_s: float
    step_low_min_s: float
    #: DIR (and the mode pins) stable before the STEP rising edge, and after it
    dir_setup_s: float
    dir_hold_s: float
    #: the enable input: True when LOW enables the outputs (nENBL / ENN / ENABLE)
    enable_active_low: bool
    #: the microstep inputs, in the order of the table's bits
    microstep_pins: tuple[str, ...]
    #: microstep pin levels (in ``microstep_pins`` order) -> microsteps per full step
    microstep_table: dict[tuple[int, ...], int] = field(default_factory=dict)
    #: the highest step rate the chip takes, steps/s (None: the datasheet gives none)
    max_step_hz: float | None = None
    source: str = ""

    def levels_for(self, microsteps: int) -> tuple[int, ...]:
        """The pin levels that select ``microsteps`` (the first row that does)."""
        for levels, n in self.microstep_table.items():
            if n == microsteps:
                return levels
        raise ValueError(f"{self.name}: no microstep setting gives 1/{microsteps}; "
                         f"it has {sorted(set(self.microstep_table.values()))}")


STEPDIR_CHIPS: dict[str, StepDirChip] = {
    # Allegro A4988 datasheet (A4988-DS rev. 6): Figure 1 "Logic Interface Timing
    # Diagram" and its table (A: STEP minimum HIGH 1 us, B: minimum LOW 1 us, C: setup
    # input change to STEP 200 ns, D: hold 200 ns); Table 1 "Microstepping Resolution
    # Truth Table" (MS1 MS2 MS3); ENABLE: "a logic high ... disables", active low.
    "a4988": StepDirChip(
        "a4988", step_high_min_s=1e-6, step_low_min_s=1e-6, dir_setup_s=200e-9, dir_hold_s=200e-9,
        enable_active_low=True, microstep_pins=("ms1", "ms2", "ms3"),
        microstep_table={(0, 0, 0): 1, (1, 0, 0): 2, (0, 1, 0): 4, (1, 1, 0): 8, (1, 1, 1): 16},
        source="Allegro A4988 datasheet: Figure 1 timing table; Table 1 microstepping truth table"),
    # TI DRV8825 datasheet (SLVSA73F): 7.6 "Timing Requirements" (1 fSTEP max 250 kHz,
    # 2 tWH(STEP) 1.9 us, 3 tWL(STEP) 1.9 us, 4 tSU(STEP) 650 ns, 5 tH(STEP) 650 ns);
    # Table 1 "Stepping Format" (MODE2 MODE1 MODE0; 101-111 all 1/32); nENBL active low.
    "drv8825": StepDirChip(
        "drv8825", step_high_min_s=1.9e-6, step_low_min_s=1.9e-6, dir_setup_s=650e-9, dir_hold_s=650e-9,
        enable_active_low=True, microstep_pins=("mode0", "mode1", "mode2"),
        microstep_table={(0, 0, 0): 1, (1, 0, 0): 2, (0, 1, 0): 4, (1, 1, 0): 8, (0, 0, 1): 16,
                         (1, 0, 1): 32, (0, 1, 1): 32, (1, 1, 1): 32},
        max_step_hz=250e3,
        source="TI DRV8825 (SLVSA73F): 7.6 Timing Requirements; Table 1 Stepping Format"),
    # Trinamic TMC2208 datasheet (Rev. 1.13): STEP/DIR timing in the "Electrical
    # Characteristics" (tSH, tSL >= max(tFILTSD, tCLK + 20 ns): about 100 ns; tDSU DIR to
    # STEP setup 20 ns, tDSH hold 20 ns); "MS1/MS2 microstep resolution" table (MS2 MS1:
    # 00 1/8, 01 1/2, 10 1/4, 11 1/16; interpolated to 1/256); ENN active low.
    "tmc2208": StepDirChip(
        "tmc2208", step_high_min_s=100e-9, step_low_min_s=100e-9, dir_setup_s=20e-9, dir_hold_s=20e-9,
        enable_active_low=True, microstep_pins=("ms1", "ms2"),
        microstep_table={(0, 0): 8, (1, 0): 2, (0, 1): 4, (1, 1): 16},
        source="Trinamic TMC2208 datasheet: STEP/DIR timing (tSH, tSL, tDSU, tDSH); MS1/MS2 table"),
    # Trinamic TMC2209 datasheet (Rev. 1.09): the same STEP/DIR timing as the TMC2208;
    # its own MS1/MS2 table (MS2 MS1: 00 1/8, 01 1/32, 10 1/64, 11 1/16); ENN active low.
    "tmc2209": StepDirChip(
        "tmc2209", step_high_min_s=100e-9, step_low_min_s=100e-9, dir_setup_s=20e-9, dir_hold_s=20e-9,
        enable_active_low=True, microstep_pins=("ms1", "ms2"),
        microstep_table={(0, 0): 8, (1, 0): 32, (0, 1): 64, (1, 1): 16},
        source="Trinamic TMC2209 datasheet Rev 1.09: STEP/DIR timing; MS1/MS2 table"),
}


def pulse_times_us(rate_hz: float, chip: StepDirChip) -> tuple[int, int]:
    """(high, low) in whole microseconds for ``rate_hz`` (lg's units): half a period
    each, rounded, never under the chip's minima nor a period under lg's floor."""
    if not 0.0 < rate_hz <= MAX_LIBRARY_TIMED_HZ:
        raise ValueError(f"step rate {rate_hz!r} outside 0 < rate <= {MAX_LIBRARY_TIMED_HZ:g} steps/s")
    period = max(LG_MIN_PERIOD_US, round(1e6 / rate_hz))
    high = max(math.ceil(chip.step_high_min_s * 1e6), period // 2)
    low = max(math.ceil(chip.step_low_min_s * 1e6), period - high)
    return high, low
