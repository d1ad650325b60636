"""Brake relay and limit-switch drivers on digital parts."""

from __future__ import annotations

import threading
from typing import Any

from ..parts import DigitalIn, DigitalOut
from .motors import forcing


class RelayBrake:
    """A brake that needs voltage to release (Tartu, BIG-RAS): a relay feeds its coil.

    Built engaged (coil off). Without a feedback contact, ``is_released`` says the brake
    is released only ``release_s`` after the coil was energised (the time the armature
    needs); it is engaged again at once when the coil is switched off, which is the
    safe way to err.

    The tick releases and engages it while ``Hardware.drive_safe`` engages it from other
    threads: ``_lock`` is held over check + write + state, and :meth:`force_safe`
    (``drive_safe``'s) writes the coil off whatever is remembered, leaving the coil's
    level unknown so that the next call writes it (as the motor drivers do).
    """

    def __init__(self, name: str, coil: DigitalOut, clock: Any, *, release_s: float = 0.0):
        self.name = name
        self.coil = coil
        self.clock = clock
        self.release_s = float(release_s)
        self._on_since: float | None = None
        #: the level the coil was last written; None = not known (force_safe)
        self._coil: bool | None = False
        self._lock = threading.Lock()
        coil.write(False)

    def set_released(self, released: bool) -> None:
        released = bool(released)
        with self._lock:
            if released != self._coil:
                self.coil.write(released)
                self._coil = released
                self._on_since = self.clock.now_s() if released else None

    def force_safe(self) -> None:
        """Engaged (coil off) from any thread, whatever is remembered and whether or not
        the lock came (:func:`.motors.forcing`)."""
        with forcing(self._lock, f"{self.name} brake on"):
            self._on_since = None        # engaged at once: the safe way to err
            self.coil.write(False)
            self._coil = None

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
