"""The BTS7960's current sense (IS pin) as Infineon's datasheet gives it, and how urc
reads it on an IBT-2 board.

Infineon BTS7960 data sheet Rev. 1.1 (2004-12-07), §4.4 "Electrical Characteristics -
Control and Diagnostics", current sense, R_IS = 1 kOhm:

* 4.4.6 k_ILIS = I_L / I_IS in static on-condition (x 10^3, min / typ / max):
  I_L = 30 A: 6 / 8.5 / 11; I_L = 15 A: 5 / 8.5 / 12; I_L = 5 A: 3 / 8.5 / 14.
* 4.4.7 I_IS(lim), the largest analog sense current and the sense current in a fault
  (overtemperature, current limitation): 4 / 4.5 / 7 mA.
* 4.4.8 I_ISL, with IN or INH low: at most 1 uA.
* 4.4.9 I_ISH, with the high side on at I_L = 0 A: at most 200 uA (an offset: up to
  200e-6 x 8500 = 1.7 A of phantom current at the typical ratio).

IS senses the forward current of its half-bridge's high side only, and only while that
high side conducts: during the PWM on-time of the side being driven (RPWM's half going
forward, LPWM's going back); the other half's IS gives its leakage.

Wiring urc expects (docs/hardware.md, bigras): the IBT-2's R_IS and L_IS pins tied
together (each has its 1 kOhm to ground on the board, so the node is 500 Ohm: whichever
side drives, its IS current flows through both), then 10 kOhm in series and 1 uF to
ground at the ADC input (an RC filter of 10 ms, so the ADC reads the PWM average; it
also limits the current into the ADC's input clamp), and a BAT54S from the ADC input to
3.3 V and ground. The node reads at most 7 mA x 500 Ohm = 3.5 V (a fault at the
datasheet's maximum; 2.25 V typical), within the ADS1115's VDD + 0.3 V.
"""

from __future__ import annotations

import math
from typing import Callable

from ..parts import VoltageIn

#: 4.4.6: I_L (A) -> k_ILIS (min, typ, max)
K_ILIS = {5.0: (3000.0, 8500.0, 14000.0), 15.0: (5000.0, 8500.0, 12000.0), 30.0: (6000.0, 8500.0, 11000.0)}
K_ILIS_TYP = 8500.0
#: 4.4.7: I_IS(lim) (min, typ, max), amperes
IS_LIM_A = (4.0e-3, 4.5e-3, 7.0e-3)
#: 4.4.8: IS with its IN (or INH) low, at most
IS_LEAK_OFF_A = 1.0e-6
#: 4.4.9: IS with the high side on and no load current, at most
IS_OFFSET_ON_A = 200.0e-6

#: the IBT-2's resistor from each IS pin to ground, and the two in parallel (tied pins)
IBT2_IS_OHMS = 1000.0
IS_NODE_OHMS = IBT2_IS_OHMS / 2.0
#: the default volts per motor ampere (typical k_ILIS into the tied pins' 500 Ohm)
V_PER_A = IS_NODE_OHMS / K_ILIS_TYP
#: the RC filter's time constant: 10 kOhm in series from the tied pins' 500 Ohm (10.5 kOhm)
#: into 1 uF. The sense models the filtered duty at the ends of a +-25 % bracket (1 uF
#: ceramic over temperature and bias, 1 % resistors) and divides by the larger: the filter
#: it models is then never ahead of the real one, so a reading never comes out high
FILTER_TAU_S = 10.5e-3
FILTER_TAU_BRACKET = (0.75, 1.25)
#: 10 time constants (the slow end of the bracket): a duty held at 0 this long has left
#: under 0.01 % of any earlier reading, so what the input reads then is its own offset
FILTER_SETTLE_S = 10 * FILTER_TAU_S * FILTER_TAU_BRACKET[1]
#: below this (modelled, filtered) duty the on-time current is not computed: an offset
#: the zero did not catch (a few mV) times 1/duty would read as amperes, at 1 % duty a
#: 16 mV offset as 1.6 V: a false fault and 27 A. The current is then unknown (NaN) and
#: the fault counter neither counts nor drains
DUTY_FLOOR = 0.10
#: under this the bridge drives nothing: the current is 0 (and a reading at fault level
#: is the wiring)
DUTY_OFF = 1e-3
#: the largest reading taken as the input's offset with nothing driven: 2 x I_ISL (4.4.8)
#: into 500 Ohm is 1 mV, the ADS1115's offset a few LSB, the BAT54S's leakage through
#: 10 kOhm some 10 mV; more than this is not an offset (wiring, or a fault)
ZERO_MAX_V = 0.1
#: the longest time one reading stands for in the fault counter (5 filter time
#: constants: the reading says nothing of what came before that)
READING_SPAN_MAX_S = 5 * FILTER_TAU_S
#: an on-time IS current at or above this is the fault signal: 0.8 x I_IS(lim) min. The
#: largest normal one at a rotator's currents (5 A at k_ILIS min, plus I_ISH) is
#: 5/3000 + 0.2 mA = 1.9 mA; reaching 3.2 mA without a fault takes (3.2 - 0.2) mA x 3000
#: = 9 A even on the least favourable chip (25 A typical): a stop either way
FAULT_IS_A = 0.8 * IS_LIM_A[0]
#: how long, net of the readings below it, the on-time IS current must read at the fault
#: level before urc calls it: a fault holds IS at I_IS(lim) while it lasts (in every
#: on-time, however short or jittery the drive), while a motor's starting current
#: (up to 10 A on a BIG-RAS: 3.5 mA on the least favourable chip) passes. The bridge has
#: cut the motor itself by then (current limitation, thermal shutdown); this only stops
#: urc driving it. As long as the overcurrent rule's hold (control.faults)
FAULT_HOLD_S = 0.25


class FilteredDuty:
    """A first-order model of the duty behind the RC filter (the filter sees the PWM's
    average: duty x on-time value), advanced exactly between duty changes."""

    def __init__(self, tau_s: float):
        self.tau_s, self.value, self.duty, self.at_s = float(tau_s), 0.0, 0.0, -math.inf

    def advance(self, now_s: float) -> float:
        if now_s > self.at_s:
            # duty read once: note_duty may change it from another thread (drive_safe's)
            duty = self.duty
            self.value = duty + (self.value - duty) * math.exp(-(now_s - self.at_s) / self.tau_s)
            self.at_s = now_s
        return self.value

    def set(self, now_s: float, duty: float) -> None:
        self.advance(now_s)
        self.duty = duty


class Bts7960Sense:
    """The tied IS pins on one filtered ADC input (see the module's wiring).

    The filter gives the duty-weighted average of the on-time IS current, so the
    reading (less the input's offset, learnt while nothing is driven) is divided by the
    filtered duty, modelled (:class:`FilteredDuty`) at both ends of the time constant's
    tolerance and the larger taken: the current and the fault signal come out the same
    at any duty, in bursts or a jittering duty too, never high after a duty change.
    Below :data:`DUTY_FLOOR` the current is unknown: :meth:`read_current_a` gives NaN
    (a number would be an offset times 1/duty, or a low value taken as safe).

    The fault signal is counted, not timed as an unbroken run (one low reading, a burst's
    gap, must not restart it): each reading at the fault level adds the time since the
    last reading, each one below takes it off, one below the duty floor (or a low one
    with nothing driven) does neither; a count of ``hold_s`` is a fault. With no high
    side on the current is 0 and a reading at fault level means the wiring is wrong.
    """

    def __init__(self, volts: VoltageIn, v_per_a: float, now_s: Callable[[], float], *,
                 node_ohms: float = IS_NODE_OHMS, settle_s: float = FILTER_SETTLE_S,
                 hold_s: float = FAULT_HOLD_S, tau_s: float = FILTER_TAU_S,
                 duty_floor: float = DUTY_FLOOR):
        self.volts, self.v_per_a, self.now_s = volts, float(v_per_a), now_s
        self.settle_s, self.node_ohms, self.hold_s = float(settle_s), float(node_ohms), float(hold_s)
        self.duty_floor = float(duty_floor)
        self._models = [FilteredDuty(tau_s * k) for k in FILTER_TAU_BRACKET]
        #: the on-time reading (volts at the node while a high side conducts) at which
        #: the fault signal is called
        self.fault_v = FAULT_IS_A * node_ohms
        self.fault: str | None = None
        #: seconds of fault-level readings, less those below (0 .. hold_s)
        self.fault_count_s = 0.0
        self._last_read_s: float | None = None
        #: the input's reading with nothing driven (ADC offset, I_ISL, clamp leakage)
        self.zero_v = 0.0
        self._off_since_s: float | None = -math.inf    # None while a side is driven

    def note_duty(self, duty: float) -> None:
        """The bridge's drive was just set to ``duty`` (the motor driver tells)."""
        d, now = abs(float(duty)), self.now_s()
        for m in self._models:
            m.set(now, d)
        if d > 0.0:
            self._off_since_s = None
        elif self._off_since_s is None:
            self._off_since_s = now

    def divisor_duty(self) -> float:
        """The filtered duty the reading is divided by (never below the real one)."""
        now = self.now_s()
        return max(m.advance(now) for m in self._models)

    def read_current_a(self) -> float:
        """The motor current in amperes; NaN while the duty is below the floor (unknown)."""
        raw_v = self.volts.read_volts()
        now = self.now_s()
        duty = self.divisor_duty()
        if self._off_since_s is not None and now - self._off_since_s >= self.settle_s \
                and abs(raw_v) <= ZERO_MAX_V:
            self.zero_v += 0.2 * (raw_v - self.zero_v)     # averages the ADC's noise
        v = raw_v - self.zero_v
        span_s = 0.0 if self._last_read_s is None else min(max(now - self._last_read_s, 0.0), READING_SPAN_MAX_S)
        self._last_read_s = now
        if duty < DUTY_OFF:
            on_v, amps = v, 0.0
        elif duty >= self.duty_floor:
            on_v = v / duty
            amps = on_v / self.v_per_a
        else:                                              # unknown: no count, no verdict
            self.fault = None
            return math.nan
        if on_v >= self.fault_v:
            step = span_s
        else:   # nothing driven says nothing of the on-time: a burst's gap must not drain it
            step = -span_s if duty >= DUTY_OFF else 0.0
        self.fault_count_s = min(max(self.fault_count_s + step, 0.0), self.hold_s)
        if self.fault_count_s < self.hold_s or on_v < self.fault_v:
            self.fault = None          # (a count kept through a stop is called on the next reading)
        elif duty >= DUTY_OFF:
            self.fault = (f"BTS7960 IS at {on_v / self.node_ohms * 1e3:.1f} mA of on-time current "
                          f"({raw_v:.2f} V at {duty:.0%} filtered duty): the bridge signals a fault "
                          "(overtemperature or current limitation), or the motor has drawn 9 A or "
                          f"more for {self.hold_s:g} s")
        else:
            self.fault = (f"current-sense input at {raw_v:.2f} V with neither BTS7960 high side on: "
                          "check the IS wiring (docs/hardware.md)")
        return amps
