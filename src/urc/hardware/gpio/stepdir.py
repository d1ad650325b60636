"""Step/dir stepper drivers on the Pi: their datasheet table and the step pulse train.

The datasheet figures (:data:`STEPDIR_CHIPS`) are the interface timing a STEP/DIR/ENABLE
input needs; the pulse train writes pulses no shorter and a DIR change no closer to a
STEP edge than the chip allows.

Step pulses are library-timed, never a Python loop per step: lgpio's ``tx_pulse``
(lg 0.2.2, lgGpio.c ``xSetAsPwm`` and lgPthTx.c ``lgPthTx``, read at joan2937/lg
bcccd78). What it does, and what that means here:

* ``tx_pulse(handle, gpio, on_us, off_us, offset, cycles)`` appends an entry (on, off,
  cycles) to the pin's queue of ``LG_TX_BUF`` = 10 entries and returns the free slots
  (``LG_TX_QUEUE_FULL`` when none). Times are whole microseconds and one period must
  exceed ``lgMinTxDelay`` = 10 us. An entry with ``cycles`` > 0 emits exactly that many
  pulses, then the next entry starts; the last finite entry ends with the pin low. So
  the count is exact: a pulse queued is emitted unless the queue is cut
  (``tx_pulse(h, g, 0, 0)``: the record goes inactive at once, mid-entry).
* ``tx_room`` is 10 minus the entries queued, ``tx_busy`` whether any is running. lg
  does not say how many pulses of the running entry are out, so the driver keeps its
  own schedule of the entries it queued (:class:`TxSchedule`) and reads the count from
  it; it is exact whenever the queue has drained (every normal stop) and within the
  pulses of one entry while one runs.
* The pulses are timed by lg's own thread (``lgPthTx``), on a Pi 4 and a Pi 5 alike
  (lg has no DMA path; on a Pi 5 the pins are the RP1's, /dev/gpiochip4 before kernel
  6.6.45, gpiochip0 after): it sleeps with ``clock_nanosleep`` to an absolute deadline
  for every edge and writes the line through the gpiochip character device. Every
  pulse is therefore two thread wake-ups and two ioctls: the edges jitter by the
  kernel's wake-up latency (tens of microseconds typical on a stock kernel, into
  hundreds under load; not measured on a Pi here: there is none) and a late edge is
  late, never dropped, because deadlines are absolute (``pthTxReq`` advances by the
  nominal period whatever the wake-up was).
* The SatNOGS rate, 3200 steps/s (1/8 microstep, the firmware's top speed), is a
  period of 312 us: 6400 wake-ups a second, and a jitter of 50 us is a sixth of a
  period. A stepper driver counts rising edges, so jitter moves steps in time (a
  speed ripple the rotor's inertia filters) but loses none as long as each pulse
  stays over the chip's minimum width; the high time is set to half the period, far
  over the 1-2 us minima. At 1/16 microstep with the same axis speed the rate doubles
  (6400 steps/s); the 51 kHz of 3200 full-step-equivalent speed at x16 would be 102 000
  wake-ups a second, over what a Python-free but unprivileged thread keeps up with:
  pulses then fall behind (late, still counted). :data:`MAX_LIBRARY_TIMED_HZ` is the
  ceiling this module accepts; a faster axis needs a hardware PWM channel with a
  counted burst or a driver with its own pulse generator (TMC2209's VACTUAL).

Hardware PWM (the PWM peripheral's clock, jitter-free) was not chosen: it has no
pulse count, so a stop would cut a period at an unknown step, and the peripheral's two
(Pi 4) or four (Pi 5) channels are taken by the DC bridges' PWM on other machines.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

#: the highest step rate the library-timed train is asked for (see the module's text)
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


class LgpioStepPulses:
    """The STEP pin as lgpio's pulse queue (on a Pi; the emulation has its own,
    :class:`..gpio.emulate_stepdir.EmulatedTxQueue`, with the same calls)."""

    def __init__(self, factory: object, pin: int):
        import lgpio
        self._lg = lgpio
        self.handle = getattr(factory, "_handle")   # gpiozero's LGPIOFactory chip handle
        self.pin = pin
        lgpio.gpio_claim_output(self.handle, pin, 0)

    def queue(self, high_us: int, low_us: int, cycles: int) -> int:
        """``cycles`` pulses appended; the free entries left (negative: lg's error)."""
        return int(self._lg.tx_pulse(self.handle, self.pin, high_us, low_us, 0, cycles))

    def room(self) -> int:
        return int(self._lg.tx_room(self.handle, self.pin, self._lg.TX_PWM))

    def busy(self) -> bool:
        return bool(self._lg.tx_busy(self.handle, self.pin, self._lg.TX_PWM) > 0)

    def cut(self) -> None:
        """Every queued pulse dropped now, the pin low (mid-entry: the count is lost)."""
        self._lg.tx_pulse(self.handle, self.pin, 0, 0, 0, 0)
        self._lg.gpio_write(self.handle, self.pin, 0)

    def __repr__(self) -> str:
        return f"GPIO{self.pin} step pulses (lgpio tx_pulse)"
