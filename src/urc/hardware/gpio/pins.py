"""Pin parts over gpiozero's pin API (lgpio on a Pi, MockFactory when emulated).

Only gpiozero's pin layer is used (``factory.pin(n)``: function, pull, edges,
when_changed, frequency, state), so the same code runs on LGPIOFactory and on
MockFactory pins the simulator drives. gpiozero has no quadrature decoder with x4
counting and error detection (RotaryEncoder counts detents), hence :class:`PinQuadrature`.
"""

from __future__ import annotations

import threading
import time
from typing import Any

# x4 decoding: state = A<<1 | B; forward order 00 -> 01 -> 11 -> 10 -> 00.
#: (previous state << 2 | new state) -> count change; None = both channels changed (an
#: edge was missed: direction unknown, counted as an error, not guessed)
_FWD = {0b00: 0b01, 0b01: 0b11, 0b11: 0b10, 0b10: 0b00}
QUAD_TABLE: dict[int, int | None] = {}
for _p in range(4):
    for _n in range(4):
        QUAD_TABLE[_p << 2 | _n] = (0 if _p == _n else 1 if _FWD[_p] == _n
                                    else -1 if _FWD[_n] == _p else None)


def quad_decode(prev: int, new: int) -> int | None:
    return QUAD_TABLE[prev << 2 | new]


class PinOut:
    """Digital output (also the heartbeat: ``write(bool)``)."""

    def __init__(self, factory: Any, pin: int, *, initial: bool = False):
        self.pin = factory.pin(pin)
        self.pin.function = "output"
        self.pin.state = bool(initial)

    def write(self, value: bool) -> None:
        self.pin.state = bool(value)

    def read_back(self) -> bool:
        return bool(self.pin.state)


class PinPwm:
    """PWM output (lgpio software PWM on any pin; hardware PWM pins 12/13/18/19)."""

    def __init__(self, factory: Any, pin: int, *, frequency_hz: float = 1000.0):
        self.pin = factory.pin(pin)
        self.pin.function = "output"
        self.pin.frequency = frequency_hz
        self.pin.state = 0.0

    def write_duty(self, duty: float) -> None:
        self.pin.state = min(1.0, max(0.0, float(duty)))

    def read_back(self) -> float:
        return float(self.pin.state)


class PinIn:
    """Digital input with pull-up and edge timing (limit switch, power-fail line)."""

    def __init__(self, factory: Any, pin: int, *, pull: str = "up", on_edge: Any = None):
        self.pin = factory.pin(pin)
        self.pin.function = "input"
        self.pin.pull = pull
        self._edges = 0
        self._last_edge_s: float | None = None
        self._on_edge = on_edge
        self.pin.edges = "both"
        self.pin.when_changed = self._changed

    def _changed(self, ticks: Any = None, state: Any = None) -> None:
        self._edges += 1
        self._last_edge_s = time.monotonic()
        if self._on_edge is not None:
            self._on_edge(self.read())

    def read(self) -> bool:
        return bool(self.pin.state)

    def edges(self) -> int:
        return self._edges

    def last_edge_s(self) -> float | None:
        return self._last_edge_s


class PinQuadrature:
    """x4 quadrature counter on two pins (optional index Z latches the count)."""

    def __init__(self, factory: Any, a: int, b: int, z: int | None = None):
        self.a, self.b = factory.pin(a), factory.pin(b)
        for p in (self.a, self.b):
            p.function = "input"
            p.pull = "up"
        self._lock = threading.Lock()
        self._count = 0
        self._errors = 0
        self._index: int | None = None
        #: index (Z) pulses seen
        self.index_pulses = 0
        self._state = self._read_state()
        for p in (self.a, self.b):
            p.edges = "both"
            p.when_changed = self._edge
        self.z = None
        if z is not None:
            self.z = factory.pin(z)
            self.z.function = "input"
            self.z.pull = "up"
            self.z.edges = "rising"
            self.z.when_changed = self._index_edge

    def _read_state(self) -> int:
        return (1 if self.a.state else 0) << 1 | (1 if self.b.state else 0)

    def _edge(self, ticks: Any = None, state: Any = None) -> None:
        new = self._read_state()
        with self._lock:
            d = QUAD_TABLE[self._state << 2 | new]
            if d is None:
                self._errors += 1
            else:
                self._count += d
            self._state = new

    def _index_edge(self, ticks: Any = None, state: Any = None) -> None:
        with self._lock:
            self._index = self._count
            self.index_pulses += 1

    def count(self) -> int:
        return self._count

    def index_count(self) -> int | None:
        return self._index

    def errors(self) -> int:
        return self._errors


class PinPulseCounter:
    """SPID reed contact to ground: one count per falling edge (pin pulled up)."""

    def __init__(self, factory: Any, pin: int):
        self.pin = factory.pin(pin)
        self.pin.function = "input"
        self.pin.pull = "up"
        self._count = 0
        self.pin.edges = "falling"
        self.pin.when_changed = self._edge

    def _edge(self, ticks: Any = None, state: Any = None) -> None:
        self._count += 1

    def count(self) -> int:
        return self._count
