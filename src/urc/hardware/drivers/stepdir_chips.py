"""Step/dir stepper driver chips: their datasheet table (interface timing, enable level,
microstep pins) and the pulse times a rate needs in lgpio's units (whole microseconds,
a period over lg's floor; the pulse train itself: :mod:`..gpio.stepdir`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

#: the highest step rate the library-timed train is asked for (urc.hardware.gpio.stepdir)
MAX_LIBRARY_TIMED_HZ = 20000.0
#: lgMinTxDelay (lgPthTx.c): one period must be longer than this
LG_MIN_PERIOD_US = 11
#: LG_TX_BUF (lgPthTx.h): entries per pin
LG_TX_BUF = 10


# lg's statuses the step train can meet (joan2937/lg bcccd78, lgpio.h:2960, :2970, :2988)
LG_TX_QUEUE_FULL = -96
LG_BAD_PWM_MICROS = -86    # a period of lgMinTxDelay or less, or a cut (0, 0) with no train running
LG_GPIO_NOT_AN_OUTPUT = -104
#: lgpio's ``error_text`` for each (lgpio 0.2.2.0; tests compare them with the library's)
LG_ERROR_TEXT = {LG_TX_QUEUE_FULL: "TX queue full", LG_BAD_PWM_MICROS: "bad PWM micros",
                 LG_GPIO_NOT_AN_OUTPUT: "GPIO not set as an output"}


def lg_error_code(exc: BaseException, error_text: Callable[[int], str] | None = None) -> int:
    """lg's status back from an ``lgpio.error``. lgpio's Python raises
    ``error(error_text(status))`` (``_u2i``): the exception carries the text only
    (``.value``), no code. The text is matched with ``error_text(code)`` (lgpio's own,
    else :data:`LG_ERROR_TEXT`) for the codes above; -1 for any other."""
    text = getattr(exc, "value", None)
    if text is None and exc.args:
        text = exc.args[0]
    for code, known in LG_ERROR_TEXT.items():
        if text == (error_text(code) if error_text is not None else known):
            return code
    return -1


#: the Trinamic STEP/DIR inputs' minimum high and low time: max(tFILTSD, tCLK + 20 ns)
#: ("STEP and DIR interface timing", AC-Characteristics; the table's 100 ns is its typical
#: column). tCLK at the slowest factory-calibrated internal clock, 11.5 MHz (fCLKOSC at
#: 25 C, "Clock oscillator and input timing"): 87 ns + 20 ns; tFILTSD is 30 ns at most.
TMC_STEP_MIN_S = 1.0 / 11.5e6 + 20e-9


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
    #: from leaving sleep to the first STEP it takes (None: the chip has no sleep input)
    wake_s: float | None = None
    #: the translator (indexer, sequencer) goes back to its home microstep state when the
    #: motor supply is lost (the safety chain's cut): its logic is powered from that supply.
    #: The rotor then snaps to the nearest pole matching the home state on power-up: up to
    #: :data:`HOME_SNAP_FULL_STEPS` full steps from where the count has it
    home_on_motor_supply_loss: bool = False
    #: STEP edges while disabled still move the translator (A4988: "remain active");
    #: False: they are ignored (DRV8825: nENBL disables "indexer operation")
    steps_while_disabled: bool = False
    source: str = ""

    def levels_for(self, microsteps: int) -> tuple[int, ...]:
        """The pin levels that select ``microsteps`` (the first row that does)."""
        for levels, n in self.microstep_table.items():
            if n == microsteps:
                return levels
        raise ValueError(f"{self.name}: no microstep setting gives 1/{microsteps}; "
                         f"it has {sorted(set(self.microstep_table.values()))}")


#: one electrical turn is 4 full steps; a translator reset to its home state pulls the
#: rotor to the nearest rotor position in that state: at most half a turn, 2 full steps
HOME_SNAP_FULL_STEPS = 2


# Checked (issue 37) against what the reference search finds; where it finds only a
# secondary source, that source is named. Not checked against a part: there is none.
STEPDIR_CHIPS: dict[str, StepDirChip] = {
    # Allegro A4988 datasheet, "Logic Interface Timing" (Figure 1 and its table): minimum
    # command active time before the STEP pulse (data set-up) 200 ns, after it (data hold)
    # 200 ns; minimum STEP pulse width high 1 us, low 1 us; maximum wake-up time 1 ms
    # ("Sleep Mode": 1 ms before a STEP after nSLEEP goes high). Table 1 "Microstepping
    # Resolution Truth Table" (MS1 MS2 MS3: LLL full, HLL 1/2, LHL 1/4, HHL 1/8, HHH 1/16).
    # ENABLE: "a logic high, the outputs are disabled"; "the translator inputs STEP, DIR and
    # MSx, as well as the internal sequencing logic, all remain active, independent of the
    # ENABLE input state". RESET "sets the translator to a predefined Home state". Its logic
    # runs on VDD, not VBB: a VBB (motor supply) loss only disables the FET outputs
    # ("Shutdown": undervoltage on VCP); the UVLO's translator reset is at (VDD) power-on.
    # Search: the 1/1/0.2/0.2 us and 1 ms figures agree with the Duet driver-timings table,
    # Marlin's Configuration_adv.h and laurb9/StepperDriver; the truth table and the
    # ENABLE/RESET text with the datasheet as quoted by Pololu-carrier pages. The VDD/VBB
    # split of the reset is from the datasheet as remembered, not found by the search.
    "a4988": StepDirChip(
        "a4988", step_high_min_s=1e-6, step_low_min_s=1e-6, dir_setup_s=200e-9, dir_hold_s=200e-9,
        enable_active_low=True, microstep_pins=("ms1", "ms2", "ms3"),
        microstep_table={(0, 0, 0): 1, (1, 0, 0): 2, (0, 1, 0): 4, (1, 1, 0): 8, (1, 1, 1): 16},
        wake_s=1e-3, home_on_motor_supply_loss=False, steps_while_disabled=True,
        source="Allegro A4988 datasheet: Logic Interface Timing (Figure 1); Table 1 Microstepping "
               "Resolution Truth Table; ENABLE, RESET, Sleep Mode, Shutdown"),
    # TI DRV8825 datasheet (SLVSA73F): "Timing Requirements" (fSTEP max 250 kHz; tWH(STEP)
    # 1.9 us; tWL(STEP) 1.9 us; tSU(STEP) 650 ns; tH(STEP) 650 ns); tWAKE 1.7 ms (nSLEEP
    # high to STEP accepted); "Stepping Format" table (MODE2 MODE1 MODE0; 000 full ...
    # 100 1/16, 101-111 1/32). Pin functions: nENBL "logic high to disable device outputs
    # and indexer operation", nRESET "initializes the indexer logic". The device has no
    # logic supply of its own (V3P3OUT comes from VM): "VM undervoltage lockout" disables
    # the bridges and resets the internal logic, the indexer with it.
    # Search: 1.9/1.9/0.65/0.65 us in the Duet table and Marlin; 1.7 ms in StepperDriver;
    # the nENBL/nRESET text in TI's pin table (DRV8824, the same die family) and the
    # Pololu/RpiMotorLib DRV8825 pages. The section numbers are not given: they differ by
    # revision.
    "drv8825": StepDirChip(
        "drv8825", step_high_min_s=1.9e-6, step_low_min_s=1.9e-6, dir_setup_s=650e-9, dir_hold_s=650e-9,
        enable_active_low=True, microstep_pins=("mode0", "mode1", "mode2"),
        microstep_table={(0, 0, 0): 1, (1, 0, 0): 2, (0, 1, 0): 4, (1, 1, 0): 8, (0, 0, 1): 16,
                         (1, 0, 1): 32, (0, 1, 1): 32, (1, 1, 1): 32},
        max_step_hz=250e3, wake_s=1.7e-3, home_on_motor_supply_loss=True, steps_while_disabled=False,
        source="TI DRV8825 (SLVSA73F): Timing Requirements; tWAKE; Stepping Format table; "
               "nENBL/nRESET pin functions; VM undervoltage lockout"),
    # Trinamic (ADI) TMC2208 datasheet: "STEP and DIR interface timing" (AC-Characteristics:
    # tSL, tSH min max(tFILTSD, tCLK+20 ns), 100 ns typical; tDSU DIR to STEP setup 20 ns;
    # tDSH hold 20 ns; tFILTSD 13/20/30 ns): :data:`TMC_STEP_MIN_S`. "MS1/MS2 microstep
    # selection" (MS2 MS1: 00 1/8, 01 1/2, 10 1/4, 11 1/16; interpolated to 1/256). ENN
    # "power stage switched off (all motor outputs floating)" when high. The digital core
    # runs from the internal 5VOUT regulator fed by VS: a VS loss is a reset (GSTAT.reset,
    # MSCNT from its power-up value). No sleep input (TMC2208).
    # Search: the timing table as the Trinamic family has it (TMC5160 rev 1.14, 15.1, found
    # verbatim) and as a TMC2209 rev 1.09 digest gives it (10.4, 13/20/30 ns, 11.5-12.5 MHz);
    # the TMC2208's own table is not in the search's corpus, nor is its MS table (from the
    # datasheet as remembered; its cover, found, lists pin-set microsteps of 2 to 32).
    "tmc2208": StepDirChip(
        "tmc2208", step_high_min_s=TMC_STEP_MIN_S, step_low_min_s=TMC_STEP_MIN_S, dir_setup_s=20e-9,
        dir_hold_s=20e-9, enable_active_low=True, microstep_pins=("ms1", "ms2"),
        microstep_table={(0, 0): 8, (1, 0): 2, (0, 1): 4, (1, 1): 16},
        home_on_motor_supply_loss=True,
        source="Trinamic TMC2208 datasheet: STEP and DIR interface timing (tSH, tSL, tDSU, tDSH, "
               "tFILTSD); MS1/MS2 microstep table; ENN; clock oscillator"),
    # Trinamic (ADI) TMC2209 datasheet rev 1.09: the same STEP/DIR timing (section "STEP/DIR
    # interface"), internal clock 11.5-12.5 MHz at 25 C; its own MS2 MS1 table (00 1/8,
    # 01 1/32, 10 1/64, 11 1/16, the UART address too); ENN high disables the bridges; the
    # core on 5VOUT from VS as the TMC2208's. Search: the rev 1.09 digest (2.1, 10.4) and an
    # ESP32 design note ("MS1 and MS2 both tied to VIO" = 16).
    "tmc2209": StepDirChip(
        "tmc2209", step_high_min_s=TMC_STEP_MIN_S, step_low_min_s=TMC_STEP_MIN_S, dir_setup_s=20e-9,
        dir_hold_s=20e-9, enable_active_low=True, microstep_pins=("ms1", "ms2"),
        microstep_table={(0, 0): 8, (1, 0): 32, (0, 1): 64, (1, 1): 16},
        home_on_motor_supply_loss=True,
        source="Trinamic TMC2209 datasheet rev 1.09: STEP/DIR interface timing; MS1/MS2 table; "
               "ENN; clock oscillator"),
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
