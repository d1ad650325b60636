"""Pass searches for the web page, bounded: an open (unauthenticated) endpoint must not
be able to take the station down by asking for many of them.

* one search runs at a time, in a worker thread (never on the event loop or the
  control loop's thread);
* the same question asked again is answered from a small cache, or joins the search
  already running for it (every open dashboard asks the same one);
* at most ``MAX_WAITING`` different questions wait for their turn; more are refused at
  once with 503, and a caller waits at most ``TIMEOUT_S`` (503, the search goes on and
  fills the cache);
* parameters are rounded (whole hours, whole degrees), so a scan of many slightly
  different values hits the cache instead of starting a search each.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections import OrderedDict
from typing import Any, Callable

from fastapi import HTTPException

#: the longest look-ahead a page may ask for (hours)
MAX_HOURS = 72.0
#: a pass list is reused this long (seconds) before the search runs again
CACHE_S = 30.0
#: different answers kept (each is a list of a few hundred passes at most)
CACHE_ENTRIES = 4
#: different questions allowed to wait for the running search
MAX_WAITING = 2
#: a caller gives up (503) after this long; the search itself goes on
TIMEOUT_S = 60.0
#: a 503 tells a well-behaved client when to come back
RETRY = {"Retry-After": str(int(CACHE_S))}


class PassSearch:
    def __init__(self, search: Callable[[float, float], Any], *, timeout_s: float = TIMEOUT_S,
                 max_waiting: int = MAX_WAITING, cache_s: float = CACHE_S):
        self.search = search
        self.timeout_s = timeout_s
        self.max_waiting = max_waiting
        self.cache_s = cache_s
        self._cache: OrderedDict[tuple[float, float], tuple[float, Any]] = OrderedDict()
        self._pending: dict[tuple[float, float], asyncio.Future] = {}
        self._one_at_a_time = asyncio.Semaphore(1)
        self.searches = 0  # how many ran (for tests and the log)

    @staticmethod
    def key(hours: float, min_el_deg: float) -> tuple[float, float]:
        return float(min(math.ceil(hours), MAX_HOURS)), float(round(min_el_deg))

    async def get(self, hours: float, min_el_deg: float) -> Any:
        key = self.key(hours, min_el_deg)
        hit = self._cache.get(key)
        if hit is not None and time.monotonic() - hit[0] < self.cache_s:
            return hit[1]
        fut = self._pending.get(key)
        if fut is None:
            if len(self._pending) > self.max_waiting:
                raise HTTPException(503, "pass search busy: try again in a minute", headers=RETRY)
            fut = asyncio.get_running_loop().create_task(self._run(key))
            self._pending[key] = fut
        try:
            # shield: a caller that gives up (timeout, closed page) leaves the search to finish
            return await asyncio.wait_for(asyncio.shield(fut), self.timeout_s)
        except asyncio.TimeoutError:
            raise HTTPException(503, f"pass search took longer than {self.timeout_s:g} s: "
                                     "try again later (the result is being computed)", headers=RETRY) from None

    async def _run(self, key: tuple[float, float]) -> Any:
        try:
            async with self._one_at_a_time:
                self.searches += 1
                result = await asyncio.to_thread(self.search, *key)
            self._cache[key] = (time.monotonic(), result)
            self._cache.move_to_end(key)
            while len(self._cache) > CACHE_ENTRIES:
                self._cache.popitem(last=False)
            return result
        finally:
            self._pending.pop(key, None)


__all__ = ["MAX_HOURS", "PassSearch"]
