"""Running the rotator's tick: in real time (asyncio) or on a virtual clock (tests, bench)."""

from __future__ import annotations

import asyncio
from typing import Callable

from ..clock import Clock, VirtualClock
from .rotator import Rotator
from .snapshot import Status

#: after a stall longer than this many periods, resynchronise instead of catching up.
RESYNC_PERIODS = 5


async def run_realtime(rotator: Rotator, clock: Clock, stop: asyncio.Event,
                       on_tick: Callable[[float], None] | None = None) -> None:
    """Tick at the profile's loop rate until ``stop`` is set; report lateness.
    ``on_tick(now_s)`` runs after each tick (the tracker feeding setpoints)."""
    period_s = 1.0 / rotator.caps.loop_hz
    next_s = clock.now_s()
    while not stop.is_set():
        await clock.sleep_until(next_s)
        late_s = clock.now_s() - next_s
        rotator.note_lateness(late_s)
        status = rotator.tick()
        if on_tick is not None:
            on_tick(status.t_s)
        next_s += period_s
        if clock.now_s() - next_s > RESYNC_PERIODS * period_s:
            next_s = clock.now_s()


def run_virtual(rotator: Rotator, clock: VirtualClock, duration_s: float,
                on_tick: Callable[[Status], None] | None = None,
                until: Callable[[Status], bool] | None = None) -> Status:
    """Advance virtual time by ``duration_s`` in control periods, ticking each time.

    Stops early when ``until(status)`` is true. Returns the last status.
    """
    period_s = 1.0 / rotator.caps.loop_hz
    status = rotator.status()
    for _ in range(max(1, round(duration_s / period_s))):
        clock.advance(period_s)
        status = rotator.tick()
        if on_tick is not None:
            on_tick(status)
        if until is not None and until(status):
            break
    return status
