"""Parts: what a pin, counter or chip delivers, before anyone says what it means.

gpiozero separates pins from devices; urc separates *parts* (this module) from
*drivers* (:mod:`urc.hardware.drivers`), which turn parts into the ``Motor``,
``PositionSensor``, ``Brake`` and ``LimitSwitch`` of :mod:`urc.hardware.interfaces`.
Every backend provides parts: the physics simulator (:mod:`urc.hardware.sim.parts`),
Linux GPIO/I2C/SPI and the same on pins and buses emulated from the simulator
(:mod:`urc.hardware.gpio`). The drivers, and calibration, only see these protocols, so
they run the same code on the simulator and on iron.

A part that cannot deliver raises :class:`PartError` (a ``SensorError``: a sensor driver
passes it on and the rotator shows it as a fault, never acting on it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from ..errors import SensorError


class PartError(SensorError):
    """A part gave no usable value (I2C NACK or timeout, magnet missing, bad reference...)."""


# ------------------------------------------------------------------------ outputs
@runtime_checkable
class DigitalOut(Protocol):
    """A logic output (relay coil, DIR, BRAKE, INA/INB, the heartbeat)."""

    def write(self, value: bool) -> None: ...


@runtime_checkable
class PwmOut(Protocol):
    """A PWM output; duty in [0, 1]."""

    def write_duty(self, duty: float) -> None: ...


# ------------------------------------------------------------------------- inputs
@runtime_checkable
class DigitalIn(Protocol):
    """A logic input with edge timing (limit switch, power-fail line)."""

    def read(self) -> bool: ...

    def edges(self) -> int:
        """Edges seen since the part was made."""

    def last_edge_s(self) -> float | None:
        """Monotonic time of the last edge, None before the first."""


@runtime_checkable
class QuadratureCounter(Protocol):
    """x4 decoding of an A/B encoder: every edge of A and B counts, signed."""

    def count(self) -> int: ...

    def index_count(self) -> int | None:
        """The count latched at the last index (Z) pulse, None before one (or no Z)."""

    def errors(self) -> int:
        """Illegal transitions seen (both channels changed at once: an edge was missed)."""


@runtime_checkable
class PulseCounter(Protocol):
    """A single-channel pulse input (SPID reed contact): counts, no direction."""

    def count(self) -> int: ...


@runtime_checkable
class AdcChannel(Protocol):
    """One ADC input. ``full_scale_counts`` is the count the reference voltage gives."""

    full_scale_counts: int

    def read_counts(self) -> int: ...

    def read_reference_counts(self) -> int:
        """What the ADC reads on the reference (pot supply) now; for ratiometric work
        and to tell a broken reference wire. ``full_scale_counts`` when the reference is
        the ADC's own (MCP3008 with VREF = pot supply)."""


@dataclass(frozen=True)
class MagnetStatus:
    """AS5600 STATUS register: MD (detected), ML (too weak), MH (too strong)."""

    detected: bool
    too_weak: bool = False
    too_strong: bool = False

    @classmethod
    def from_register(cls, status: int) -> "MagnetStatus":
        # (read before every AS5600 angle: one frozen value per pattern of the three
        # bits, made once, not a new one through the frozen __init__ every tick)
        key = (cls, status & 0x38)
        found = _MAGNET_STATUS.get(key)
        if found is None:
            found = _MAGNET_STATUS[key] = cls(detected=bool(status & 0x20), too_weak=bool(status & 0x10),
                                             too_strong=bool(status & 0x08))
        return found

    def to_register(self) -> int:
        return (0x20 if self.detected else 0) | (0x10 if self.too_weak else 0) | \
            (0x08 if self.too_strong else 0)


#: MagnetStatus.from_register's values by (class, the register's MD ML MH bits)
_MAGNET_STATUS: dict[tuple[type, int], MagnetStatus] = {}


@runtime_checkable
class As5600Part(Protocol):
    """AS5600 magnetic angle sensor: 12-bit raw angle and magnet status."""

    def read_raw_angle(self) -> int: ...

    def magnet_status(self) -> MagnetStatus: ...


@runtime_checkable
class Vector3(Protocol):
    """A 3-axis sensor's raw vector in the body frame (magnetometer, accelerometer)."""

    def read_vector(self) -> tuple[float, float, float]: ...


@runtime_checkable
class VoltageIn(Protocol):
    """One ADC input read as volts (a current-sense output, a divided supply)."""

    def read_volts(self) -> float: ...


@runtime_checkable
class CurrentSense(Protocol):
    """Motor current (VNH5019 CS pin through an ADC, BTS7960 IS)."""

    def read_current_a(self) -> float: ...


__all__ = ["AdcChannel", "As5600Part", "CurrentSense", "DigitalIn", "DigitalOut",
           "MagnetStatus", "PartError", "PulseCounter", "PwmOut", "QuadratureCounter",
           "Vector3", "VoltageIn"]
