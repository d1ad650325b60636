"""Brake relay and limit-switch drivers on digital parts."""

from __future__ import annotations

from typing import Any

from ..parts import DigitalIn, DigitalOut


class RelayBrake:
    """A brake that needs voltage to release (Tartu, BIG-RAS): a relay feeds its coil.

    Built engaged (coil off). Without a feedback contact, ``is_released`` says the brake
    is released only ``release_s`` after the coil was energised (the time the armature
    needs); it is engaged again at once when the coil is switched off, which is the
    safe way to err.
    """

    def __init__(self, name: str, coil: DigitalOut, clock: Any, *, release_s: float = 0.0):
        self.name = name
        self.coil = coil
        self.clock = clock
        self.release_s = float(release_s)
        self._on_since: float | None = None
        coil.write(False)

    def set_released(self, released: bool) -> None:
        if released and self._on_since is None:
            self.coil.write(True)
            self._on_since = self.clock.now_s()
        elif not released and self._on_since is not None:
            self.coil.write(False)
            self._on_since = None

    def is_released(self) -> bool:
        return self._on_since is not None and self.clock.now_s() - self._on_since >= self.release_s - 1e-9


class LimitSwitchInput:
    """A limit switch on a digital input (pin pulled up).

    ``active_low=True``: a normally-open contact closing to ground when hit. A broken
    wire then reads inactive, so prefer normally-closed switches with
    ``active_low=False``: the pin goes high (active) when the switch *or the wire* opens.
    """

    def __init__(self, name: str, pin: DigitalIn, *, active_low: bool = True):
        self.name = name
        self.pin = pin
        self.active_low = active_low

    def is_active(self) -> bool:
        return self.pin.read() != self.active_low
