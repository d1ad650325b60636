"""Received-power sources: one small interface for what a station already has.

A source's ``read()`` returns a :class:`Sample` (when it was taken, the value and its
unit) or raises :class:`SignalRefused` with a reason a person can act on:

* ``missing``: nothing came (no answer, connection refused, no line yet),
* ``bad``: something came that is not a power (junk, an error reply, NaN),
* ``stale``: the newest sample is older than the source's ``max_age_s``,
* ``saturated``: the receiver or ADC is at its ceiling: the true power is unknown.

A refused sample is never fitted. Sources never retry on their own: a scan decides
whether to wait or give up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Literal, Protocol, runtime_checkable

from ..errors import UrcError

Reason = Literal["bad", "missing", "stale", "saturated"]
#: dB of some reference (rigctld STRENGTH: dB over S9; rtl_power: dBFS-like), dBm, volts
#: (an AGC or detector voltage), or a linear power in arbitrary units
Unit = Literal["dB", "dBm", "V", "linear"]
UNITS: tuple[str, ...] = ("dB", "dBm", "V", "linear")


class SignalRefused(UrcError):
    """A power sample that must not be used, and why."""

    def __init__(self, reason: Reason, message: str):
        self.reason = reason
        super().__init__(f"{reason}: {message}")


@dataclass(frozen=True)
class Sample:
    """One power reading: ``t_s`` on the clock the source was given (POSIX seconds
    unless it was given another), ``value`` in ``unit``."""

    t_s: float
    value: float
    unit: Unit

    @property
    def is_log(self) -> bool:
        return self.unit in ("dB", "dBm")


@runtime_checkable
class PowerSource(Protocol):
    name: str

    def read(self) -> Sample:
        """The newest sample, or :class:`SignalRefused`."""


def judge(t_s: float, value: float, unit: Unit, *, now_s: float, max_age_s: float | None,
          ceiling: float | None = None, floor: float | None = None, what: str = "") -> Sample:
    """A :class:`Sample` if ``value`` is a usable power at ``t_s``; else SignalRefused.

    ``ceiling``: the reading at which the receiver or ADC saturates (a value at or above
    it is refused); ``floor``: likewise at the bottom (an ADC at 0 V: detector unplugged
    or its output clipped). ``max_age_s`` None: any age (a replayed file)."""
    label = f"{what}: " if what else ""
    if not (isinstance(value, (int, float)) and math.isfinite(value)):
        raise SignalRefused("bad", f"{label}not a finite number: {value!r}")
    if not math.isfinite(t_s):
        raise SignalRefused("bad", f"{label}sample time not finite: {t_s!r}")
    if max_age_s is not None:
        age_s = now_s - t_s
        if age_s > max_age_s:
            raise SignalRefused("stale", f"{label}newest sample is {age_s:.1f} s old "
                                f"(more than {max_age_s:g} s)")
    if ceiling is not None and value >= ceiling:
        raise SignalRefused("saturated", f"{label}{value:g} {unit} is at the ceiling {ceiling:g} {unit}")
    if floor is not None and value <= floor:
        raise SignalRefused("saturated", f"{label}{value:g} {unit} is at the floor {floor:g} {unit}")
    return Sample(float(t_s), float(value), unit)


def to_linear(value: float, unit: str) -> float:
    """A power on a linear scale (for fitting a beam): dB and dBm as ratios; volts and
    linear units as they are (a detector's voltage is taken as proportional to power:
    a log detector such as the AD8307 reads dB and should be given as dB by its
    callable)."""
    if unit in ("dB", "dBm"):
        return 10.0 ** (value / 10.0)
    return float(value)


Clock = Callable[[], float]
