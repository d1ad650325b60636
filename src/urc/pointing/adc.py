"""An AGC or detector voltage on an ADC input as a power source (the RC2000C way).

Any :class:`urc.hardware.parts.VoltageIn` (``read_volts()``) or a plain callable
returning volts. urc's own ADC parts give one through
:class:`urc.hardware.gpio.i2c.AdcInput`: ``ads1115_power`` and ``mcp3008_power`` in
urc.hardware.gpio.adc_power build it (hardware sits above pointing) and set the
saturation from the chip's full scale (the code a clipped input reads). The value is
volts (unit ``V``): whether volts go up or down with power, and on what law, is the receiver's (a log detector's volts are dB; an AGC line often falls as the
signal rises); a ``to_power`` callable turns volts into the unit it returns.
"""

from __future__ import annotations

import time
from typing import Any, Callable

from ..errors import HardwareError
from .sources import Clock, Sample, SignalRefused, Unit, judge


class AdcPower:
    """``read()``: one conversion now. ``ceiling_v`` / ``floor_v``: readings at or beyond
    them are refused as saturated (the ADC's full scale; 0 V on an input that should
    never be at ground). ``to_power``: volts to (value, unit), e.g. a log detector's
    slope and intercept; None: volts, unit ``V``."""

    def __init__(self, input_: Any, *, ceiling_v: float | None = None, floor_v: float | None = None,
                 to_power: Callable[[float], tuple[float, Unit]] | None = None,
                 clock: Clock = time.time, name: str = "ADC"):
        self._read: Callable[[], float] = input_.read_volts if hasattr(input_, "read_volts") else input_
        self.ceiling_v, self.floor_v, self.to_power = ceiling_v, floor_v, to_power
        self.clock, self.name = clock, name

    def read(self) -> Sample:
        try:
            volts = self._read()
        except (HardwareError, OSError) as exc:
            raise SignalRefused("missing", f"{self.name}: no conversion ({exc})") from None
        t_s = self.clock()
        # saturation is judged on the volts, where the ADC clips
        sample = judge(t_s, volts, "V", now_s=t_s, max_age_s=None, ceiling=self.ceiling_v,
                       floor=self.floor_v, what=self.name)
        if self.to_power is None:
            return sample
        value, unit = self.to_power(sample.value)
        return judge(t_s, value, unit, now_s=t_s, max_age_s=None, what=self.name)
