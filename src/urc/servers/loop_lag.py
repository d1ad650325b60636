"""How late the I/O process's event loop runs a timer: the operator's (and the bench's)
measure of "the event loop never blocks" (issue 33).

A task sleeps PERIOD_S again and again and records how much later than asked it woke:
a loop held by a blocking call (a catalog read, a pass plan, an import) wakes it late by
that much. The control process stops open-ended motion after 1 s of silence from this
loop, so a lag near that is a stop. ``/api/status`` shows the recent lags under
``loop_lag`` while the probe runs; with ``URC_LOOP_LAG_LOG=PATH`` every sample is also
appended to PATH (``UNIX_S LAG_MS`` a line), for bench/loop_lag.py.

Started once on the running loop by ``start()`` (urc run's composition root, app.py).
"""

from __future__ import annotations

import asyncio
import os
import time
from collections import deque
from typing import IO, Any

#: how often the probe's timer is due
PERIOD_S = 0.1
#: samples kept for the status: the last five minutes
WINDOW = 3000
#: environment variable naming a file every sample is appended to
LOG_ENV = "URC_LOOP_LAG_LOG"


class LoopLagProbe:
    def __init__(self, period_s: float = PERIOD_S, window: int = WINDOW, log_path: str | None = None):
        self.period_s = period_s
        self.lags_s: deque[float] = deque(maxlen=window)
        self.samples = 0
        self.max_s = 0.0  # since the start
        self.log_path = log_path
        self.task: asyncio.Task | None = None

    def record(self, lag_s: float) -> None:
        self.lags_s.append(lag_s)
        self.samples += 1
        self.max_s = max(self.max_s, lag_s)

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        log: IO[str] | None = open(self.log_path, "a", buffering=1) if self.log_path else None
        try:
            while True:
                due_s = loop.time() + self.period_s
                await asyncio.sleep(self.period_s)
                lag_s = max(0.0, loop.time() - due_s)
                self.record(lag_s)
                if log is not None:
                    log.write(f"{time.time():.3f} {lag_s * 1000.0:.3f}\n")
        finally:
            if log is not None:
                log.close()

    def summary(self) -> dict[str, Any]:
        """Lateness of the timer over the window (ms) and the worst since the start."""
        lags = sorted(self.lags_s)

        def ms(q: float) -> float | None:
            return round(lags[min(len(lags) - 1, int(round(q * (len(lags) - 1))))] * 1000.0, 2) if lags else None
        return {"p50_ms": ms(0.5), "p99_ms": ms(0.99), "max_ms": ms(1.0),
                "max_since_start_ms": round(self.max_s * 1000.0, 2), "samples": self.samples,
                "window_s": round(len(lags) * self.period_s, 1), "period_s": self.period_s}


_probe: LoopLagProbe | None = None


def start(period_s: float = PERIOD_S) -> LoopLagProbe:
    """Start the probe on the running event loop (a second call returns the running one)."""
    global _probe
    if _probe is None or _probe.task is None or _probe.task.done():
        _probe = LoopLagProbe(period_s, log_path=os.environ.get(LOG_ENV) or None)
        _probe.task = asyncio.get_running_loop().create_task(_probe.run(), name="loop-lag")
    return _probe


def summary() -> dict[str, Any] | None:
    """The running probe's summary, or None when no probe runs in this process."""
    return None if _probe is None or _probe.task is None or _probe.task.done() else _probe.summary()


__all__ = ["LOG_ENV", "PERIOD_S", "LoopLagProbe", "start", "summary"]
