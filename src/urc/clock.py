"""The one injected clock.

The control loop and the simulator only ever ask a :class:`Clock` for the time, so a
test can run a ten-minute scenario on a :class:`VirtualClock` in a fraction of a second
with exactly repeatable results, while ``urc run`` uses :class:`RealClock`.
"""

from __future__ import annotations

import time
from typing import Protocol


class Clock(Protocol):
    def now_s(self) -> float:
        """Monotonic seconds (arbitrary origin)."""

    async def sleep_until(self, t_s: float) -> None:
        """Return once ``now_s() >= t_s``."""


class RealClock:
    """Wall-clock monotonic time."""

    def now_s(self) -> float:
        return time.monotonic()

    async def sleep_until(self, t_s: float) -> None:
        import asyncio  # (lazy: the control process runs no event loop and never loads asyncio)

        delay_s = t_s - time.monotonic()
        await asyncio.sleep(delay_s if delay_s > 0 else 0)


class VirtualClock:
    """Time that only moves when told to; ``sleep_until`` jumps straight to the deadline."""

    def __init__(self, start_s: float = 0.0):
        self._t_s = float(start_s)

    def now_s(self) -> float:
        return self._t_s

    def advance(self, dt_s: float) -> None:
        if dt_s < 0:
            raise ValueError("virtual time cannot run backwards")
        self._t_s += dt_s

    def set(self, t_s: float) -> None:
        if t_s < self._t_s:
            raise ValueError("virtual time cannot run backwards")
        self._t_s = t_s

    async def sleep_until(self, t_s: float) -> None:
        if t_s > self._t_s:
            self._t_s = t_s
        import asyncio  # (lazy: as above)

        await asyncio.sleep(0)
