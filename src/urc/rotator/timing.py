"""Control-loop timing: how late each tick wrote its outputs, stalls, and the watchdog.

A tick is judged by when its outputs were written relative to its deadline (start
lateness plus the tick's own run time), so a stall inside a tick (a slow disk, a held
lock) counts as much as a late start. One stall stops the motors at once and holds
them off until the loop has been on time again for ``recover_s``; only stalls that keep
happening (``latch_stalls`` within ``latch_window_s``) latch a watchdog fault that needs
an operator. An unattended station thus survives a busy host for a moment, but not a
host that cannot keep time.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class LoopHealth:
    """What status shows about the loop's timing."""
    late_p99_ms: float          # outputs written this long after the deadline (p99, recent ticks)
    tick_p99_ms: float          # the tick's own run time (p99, recent ticks)
    stalls: int                 # stalls since start
    recent_stalls: int          # stalls within the latch window
    held: bool                  # motors held off after a stall, resuming when on time
    last_stall_ms: float        # how late the last stall was (0 if none)

    def as_dict(self) -> dict:
        return {k: (round(v, 3) if isinstance(v, float) else v) for k, v in self.__dict__.items()}


def _p99(values: collections.deque[float]) -> float:
    if not values:
        return 0.0
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(0.99 * len(ordered)))]


class LoopTiming:
    def __init__(self, watchdog_s: float, latch_stalls: int = 3, latch_window_s: float = 600.0,
                 recover_s: float = 1.0, window_ticks: int = 500):
        self.watchdog_s = watchdog_s
        self.latch_stalls = latch_stalls
        self.latch_window_s = latch_window_s
        self.recover_s = recover_s
        self._late_ms: collections.deque[float] = collections.deque(maxlen=window_ticks)
        self._tick_ms: collections.deque[float] = collections.deque(maxlen=window_ticks)
        self._stall_t_s: collections.deque[float] = collections.deque()
        self._stalls = 0
        self._last_stall_ms = 0.0
        self._held_until_s = -float("inf")
        self._health: LoopHealth | None = None
        #: (the LoopHealth, its as_dict()): rounded once per LoopHealth, copied into every status
        self._health_dict: tuple[LoopHealth, dict[str, Any]] | None = None
        self._ticks = 0

    def record(self, late_s: float, tick_s: float) -> None:
        """Record one tick's lateness (outputs written this long after the deadline)
        and run time."""
        self._late_ms.append(late_s * 1000.0)
        self._tick_ms.append(tick_s * 1000.0)
        self._ticks += 1
        if self._ticks % 25 == 0:  # the p99s are re-sorted every 25 ticks, not every tick
            self._health = None

    def stall(self, now_s: float, late_s: float) -> str:
        """A stall of ``late_s`` seen at ``now_s``: ``"stall"`` to recover from, or
        ``"latch"`` when stalls keep happening."""
        self._stalls += 1
        self._last_stall_ms = late_s * 1000.0
        self._stall_t_s.append(now_s)
        while self._stall_t_s and now_s - self._stall_t_s[0] > self.latch_window_s:
            self._stall_t_s.popleft()
        self._held_until_s = now_s + self.recover_s
        self._health = None
        return "latch" if len(self._stall_t_s) >= self.latch_stalls else "stall"

    def acknowledge(self) -> None:
        """The operator cleared the faults: past stalls no longer count towards a latch."""
        self._stall_t_s.clear()
        self._health = None

    def held(self, now_s: float) -> bool:
        """Motors held off: a stall was seen less than ``recover_s`` ago."""
        return now_s < self._held_until_s

    def recent_stalls(self, now_s: float) -> int:
        return sum(1 for t in self._stall_t_s if now_s - t <= self.latch_window_s)

    def health(self, now_s: float) -> LoopHealth:
        held = self.held(now_s)
        if self._health is None or self._health.held != held:
            # (p99 over the window: sorted once per change, not per status read)
            self._health = LoopHealth(late_p99_ms=_p99(self._late_ms), tick_p99_ms=_p99(self._tick_ms),
                                      stalls=self._stalls, recent_stalls=self.recent_stalls(now_s),
                                      held=held, last_stall_ms=self._last_stall_ms)
        return self._health

    def health_dict(self, health: LoopHealth) -> dict[str, Any]:
        """``health.as_dict()`` for the LoopHealth :meth:`health` returned: a fresh copy
        (each status owns its own), rounded only when that LoopHealth is new."""
        if self._health_dict is None or self._health_dict[0] is not health:
            self._health_dict = (health, health.as_dict())
        return dict(self._health_dict[1])
