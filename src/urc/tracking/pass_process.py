"""Pass searches in a separate process, so they never hold the control loop's interpreter.

A search over a whole catalog is seconds of numpy and sgp4 work, much of it in C code
that keeps Python's global lock: in the ``urc run`` process, one search delayed control
ticks by ~150 ms (bench/loop_bench.py). A worker process has its own interpreter and lock.

The worker is started once, on first use, with the ``spawn`` method (forking a process
that runs threads can copy a held lock into the child), and is reused. sgp4's ``Satrec``
cannot be pickled, so element sets travel as their catalog records (the text they were
read from) and are parsed again in the worker; a whole catalog sends the records it holds,
never building its sets in this process.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import threading
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Iterable

from .elements import Catalog, ElementSet
from .passes import Pass, find_passes
from .station import Station

_pool: ProcessPoolExecutor | None = None
_pool_lock = threading.Lock()


def _portable(es: ElementSet) -> bytes:
    """What a worker needs to rebuild ``es``: its record (name, source, original text)."""
    if es.tle is None and es.omm is None:
        raise ValueError(f"{es.label}: no TLE or OMM text to send to the pass-search process")
    return json.dumps(es.to_record()).encode("utf-8")


def _rebuild(record: bytes) -> ElementSet:
    # (checked when it was read: a set read without its checksum is sent as it is)
    rec = json.loads(record)
    return ElementSet.from_record(rec, str(rec.get("source", "")), checksum=False)


def _search(items: list[bytes], station: Station, start_unix_s: float,
            duration_s: float, min_el_deg: float) -> list[Pass]:
    return find_passes([_rebuild(i) for i in items], station, start_unix_s,
                       duration_s=duration_s, min_el_deg=min_el_deg)


def _lowest_priority() -> None:
    """In the worker: run only when nothing else wants the CPU. On two cores a search at
    normal priority takes CPU time from the controller's event-loop thread, and while
    that thread waits for a core holding Python's global lock, the control thread waits
    for the lock (a priority inversion of tens of ms)."""
    try:
        os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
    except (AttributeError, OSError):
        os.nice(19)


def _executor() -> ProcessPoolExecutor:
    global _pool
    with _pool_lock:
        if _pool is None:
            _pool = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn"),
                                        initializer=_lowest_priority)
        return _pool


def find_passes_isolated(sats: Iterable[ElementSet] | Catalog, station: Station, start_unix_s: float, *,
                         duration_s: float, min_el_deg: float) -> list[Pass]:
    """:func:`~urc.tracking.passes.find_passes` run in the worker process (blocking: call
    it from a worker thread) for some sets or a whole catalog. A worker that died is
    replaced once."""
    items = sats.records() if isinstance(sats, Catalog) else [_portable(es) for es in sats]
    def search() -> list[Pass]:
        return _executor().submit(_search, items, station, start_unix_s, duration_s, min_el_deg).result()

    try:
        return search()
    except BrokenProcessPool:
        shutdown()  # the worker died (killed, out of memory): start a new one, once
        return search()


def shutdown() -> None:
    """Stop the worker (at exit; a broken one before it is replaced)."""
    global _pool
    with _pool_lock:
        pool, _pool = _pool, None
    if pool is not None:
        pool.shutdown(wait=False, cancel_futures=True)


__all__ = ["find_passes_isolated", "shutdown"]
