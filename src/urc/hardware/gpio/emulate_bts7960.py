"""An emulated IBT-2's current sense: both BTS7960 IS pins, tied and filtered as
docs/hardware.md wires them, following Infineon's BTS7960 data sheet Rev. 1.1, §4.4
current sense rows (the numbers are in :mod:`..drivers.bts7960_sense`):

* 4.4.6 k_ILIS = I_L / I_IS: 3 / 8.5 / 14 x 10^3 at 5 A, 5 / 8.5 / 12 at 15 A, 6 / 8.5 /
  11 at 30 A (min / typ / max); a chip sits at one column (``grade``), interpolated in
  I_L between the rows and held beyond them (the sheet gives nothing below 5 A);
* 4.4.7 I_IS(lim) 4 / 4.5 / 7 mA: the most IS gives, and what it gives in a fault;
* 4.4.8 I_ISL <= 1 uA with the half's IN low;
* 4.4.9 I_ISH <= 200 uA with the high side on at no load (``offset_a``).

Each half's IS gives its high side's forward current over k_ILIS (plus I_ISH) while
its IN is high (nothing of a reverse current: a generating motor's) and its leakage
while IN is low; the 10 ms RC filter passes the average over the PWM period, so the
ADC sees duty x on-time current plus (1 - duty) x leakage, summed over both halves,
into 500 Ohm, held below the input clamp. Given a clock, the
filter's lag is modelled too (first order, ``filter_tau_s``; the input taken as held
since the last read, which it is when the loop reads once per tick before it drives).
"""

from __future__ import annotations

import math
from typing import Any, Callable

from ..drivers.bts7960_sense import IS_LEAK_OFF_A, IS_LIM_A, IS_NODE_OHMS, IS_OFFSET_ON_A, K_ILIS

GRADES = {"min": 0, "typ": 1, "max": 2}
#: the documented filter: 10 kOhm x 1 uF
FILTER_TAU_S = 0.01
#: the BAT54S clamp at the ADC input: the 3.3 V rail plus a Schottky drop
CLAMP_V = 3.6


def k_ilis(load_a: float, grade: str = "typ") -> float:
    """4.4.6 at ``load_a`` for a chip of ``grade``: linear between the rows, held beyond."""
    col = GRADES[grade]
    rows = sorted(K_ILIS.items())
    i_l = abs(load_a)
    if i_l <= rows[0][0]:
        return rows[0][1][col]
    for (a0, k0), (a1, k1) in zip(rows, rows[1:]):
        if i_l <= a1:
            return k0[col] + (k1[col] - k0[col]) * (i_l - a0) / (a1 - a0)
    return rows[-1][1][col]


class EmulatedBts7960Is:
    """The IS node of one IBT-2 from its RPWM/LPWM levels and the simulated current
    through the driven high side (``current_a``: positive forward, negative while the
    motor generates and pushes it back, which IS does not sense). ``fault``:
    overtemperature or current limitation, IS at I_IS(lim) while its IN is high."""

    def __init__(self, rpwm: Any, lpwm: Any, current_a: Callable[[], float], *, grade: str = "typ",
                 lim_grade: str = "typ", offset_a: float = 0.0, leak_a: float = 0.0,
                 node_ohms: float = IS_NODE_OHMS, now_s: Callable[[], float] | None = None,
                 filter_tau_s: float = FILTER_TAU_S):
        if not 0.0 <= offset_a <= IS_OFFSET_ON_A or not 0.0 <= leak_a <= IS_LEAK_OFF_A:
            raise ValueError("I_ISH is 0..200 uA and I_ISL 0..1 uA (BTS7960 data sheet 4.4.8, 4.4.9)")
        self.rpwm, self.lpwm, self.current_a = rpwm, lpwm, current_a
        self.grade, self.lim_a = grade, IS_LIM_A[GRADES[lim_grade]]
        self.offset_a, self.leak_a, self.node_ohms = offset_a, leak_a, node_ohms
        self.now_s, self.filter_tau_s = now_s, filter_tau_s
        self.fault = False
        self._filtered: tuple[float, float] | None = None     # (at_s, volts)

    def on_time_a(self, load_a: float) -> float:
        """One half's IS while its high side conducts ``load_a`` forward."""
        if self.fault:
            return self.lim_a
        return min(max(load_a, 0.0) / k_ilis(load_a, self.grade) + self.offset_a, self.lim_a)

    def node_volts(self) -> float:
        """The PWM average at the tied IS pins (the filter settled)."""
        load_a = max(self.current_a(), 0.0)   # forward only: a reverse current reads no more than 0 A
        total_a = 0.0
        for duty in (self.rpwm.read_back(), self.lpwm.read_back()):
            total_a += duty * self.on_time_a(load_a if duty > 0.0 else 0.0) + (1.0 - duty) * self.leak_a
        return total_a * self.node_ohms

    def volts(self) -> float:
        """At the ADC input: through the RC filter, below the clamp."""
        v = self.node_volts()
        if self.now_s is not None:
            now = self.now_s()
            if self._filtered is not None and self.filter_tau_s > 0.0:
                at, held = self._filtered
                v = held + (v - held) * (1.0 - math.exp(-max(0.0, now - at) / self.filter_tau_s))
            self._filtered = (now, v)
        return min(v, CLAMP_V)
