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
#: how long the RC filter (10 kOhm x 1 uF = 10 ms) remembers a duty: 10 time constants,
#: after which a 100:1 duty drop leaves under 0.5 % of the reading (5 left 6 % after 10:1)
FILTER_SETTLE_S = 0.1
#: an on-time IS current at or above this is the fault signal: 0.8 x I_IS(lim) min. The
#: largest normal one at a rotator's currents (5 A at k_ILIS min, plus I_ISH) is
#: 5/3000 + 0.2 mA = 1.9 mA; reaching 3.2 mA without a fault takes (3.2 - 0.2) mA x 3000
#: = 9 A even on the least favourable chip (25 A typical): a stop either way
FAULT_IS_A = 0.8 * IS_LIM_A[0]
#: how long the on-time IS current must stay at the fault level before urc calls it: a
#: fault holds IS at I_IS(lim) for as long as it lasts, while a motor's starting current
#: (up to 10 A on a BIG-RAS: 3.5 mA on the least favourable chip) passes. The bridge has
#: cut the motor itself by then (current limitation, thermal shutdown); this only stops
#: urc driving it. As long as the overcurrent rule's hold (control.faults)
FAULT_HOLD_S = 0.25


class Bts7960Sense:
    """The tied IS pins on one filtered ADC input (see the module's wiring).

    The filter gives the duty-weighted average of the on-time IS current, so the
    reading is divided by the duty: the current and the fault signal come out the same
    at any duty (a fixed threshold on the average missed a fault below 67 % duty). The
    filter still holds a higher duty's reading for :data:`FILTER_SETTLE_S` after the
    duty falls, so the largest duty of that window is the divisor: the reading may come
    out low for that long after the duty rises, never high after it falls (no fault or
    overcurrent called on the filter's memory). With no high side on for the whole
    window the current is 0 and any reading at fault level means the wiring is wrong.
    A reading at the fault level is called a fault once it has lasted ``hold_s``.
    """

    def __init__(self, volts: VoltageIn, v_per_a: float, now_s: Callable[[], float], *,
                 node_ohms: float = IS_NODE_OHMS, settle_s: float = FILTER_SETTLE_S,
                 hold_s: float = FAULT_HOLD_S):
        self.volts, self.v_per_a, self.now_s = volts, float(v_per_a), now_s
        self.settle_s, self.node_ohms, self.hold_s = float(settle_s), float(node_ohms), float(hold_s)
        self._above_since_s: float | None = None
        #: the on-time reading (volts at the node while a high side conducts) at which
        #: the fault signal is called
        self.fault_v = FAULT_IS_A * node_ohms
        self.fault: str | None = None
        self._duties: list[tuple[float, float]] = [(-math.inf, 0.0)]   # (since_s, |duty|)

    def note_duty(self, duty: float) -> None:
        """The bridge's drive was just set to ``duty`` (the motor driver tells)."""
        d = abs(float(duty))
        if d != self._duties[-1][1]:
            self._duties.append((self.now_s(), d))

    def divisor_duty(self) -> float:
        """The largest duty the filtered reading can still hold."""
        start = self.now_s() - self.settle_s
        while len(self._duties) > 1 and self._duties[1][0] <= start:
            self._duties.pop(0)
        return max(d for _, d in self._duties)

    def read_current_a(self) -> float:
        v = self.volts.read_volts()
        duty = self.divisor_duty()
        on_v = v / duty if duty > 0.0 else v
        now = self.now_s()
        if on_v < self.fault_v:
            self._above_since_s = None
        elif self._above_since_s is None:
            self._above_since_s = now
        if self._above_since_s is None or now - self._above_since_s < self.hold_s:
            self.fault = None
        elif duty > 0.0:
            self.fault = (f"BTS7960 IS at {on_v / self.node_ohms * 1e3:.1f} mA of on-time current "
                          f"({v:.2f} V at {duty:.0%} duty): the bridge signals a fault (overtemperature or "
                          "current limitation), or the motor has drawn 9 A or more for "
                          f"{self.hold_s:g} s")
        else:
            self.fault = (f"current-sense input at {v:.2f} V with neither BTS7960 high side on: "
                          "check the IS wiring (docs/hardware.md)")
        return on_v / self.v_per_a if duty > 0.0 else 0.0
