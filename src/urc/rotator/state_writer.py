"""Writing state records off the control tick, retrying failures.

The control tick hands the newest record to :meth:`StateWriter.submit` and carries on;
a slow fsync (an SD card can take most of a second) delays only the writer thread, never
a tick. Only the newest record matters, so a record still waiting is replaced, not
queued. A failed write is kept and retried every ``retry_s`` (or the newer record in its
place) until one succeeds. :meth:`report` says which record is known to be on disk:
the rotator lets an axis move only as far as that record promises (see
``Rotator._persist``), so a failing or slow disk can stop motion but never leave a
record on disk that a restart would wrongly trust.

``background=False`` writes in the caller's thread at once (virtual-clock tests and
benchmarks: exact and repeatable); retries are then paced by the caller's clock.

Each record handed over gets a number (:meth:`submit` returns it): :meth:`outcome` waits,
bounded, until that record or a newer one is on disk or an attempt at one has failed
(a motion command's reply waits so, off the tick: urc.link.control_process).
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable

from ..control.evolve import construct
from ..errors import StateFileError
from ..persistence import StateStore

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class WriterReport:
    #: the newest record known to be on disk (None: none written by this process yet)
    durable: dict[str, Any] | None
    #: a record is waiting to be written (or retried)
    pending: bool
    #: why the last attempt failed ("" after a success)
    error: str
    #: records written and failed attempts since start
    writes: int
    failures: int


class StateWriter:
    def __init__(self, store: StateStore, background: bool, now_s: Callable[[], float] = time.monotonic,
                 retry_s: float = 1.0):
        self.store = store
        self.background = background
        self._now_s = now_s
        self.retry_s = retry_s
        self._cv = threading.Condition()
        self._pending: dict[str, Any] | None = None
        self._durable: dict[str, Any] | None = None
        #: the number of the newest record handed over, of the pending one, of the newest
        #: on disk, and of the newest whose attempt failed (0: none)
        self._seq = self._pending_seq = self._durable_seq = self._failed_seq = 0
        self._error = ""
        self._writes = self._failures = 0
        self._busy = False
        self._closing = False
        self._next_try_s = -float("inf")
        self._thread: threading.Thread | None = None
        if background:
            self._thread = threading.Thread(target=self._run, name="urc-state-writer", daemon=True)
            self._thread.start()

    # ------------------------------------------------------------------ tick side
    def submit(self, payload: dict[str, Any]) -> int:
        """Write ``payload`` as soon as possible (it replaces one still waiting); returns
        its number (for :meth:`outcome`)."""
        with self._cv:
            seq = self._hand_over(payload)
            self._cv.notify_all()
        if not self.background:
            self._write_pending(force=True)
        return seq

    def _hand_over(self, payload: dict[str, Any]) -> int:
        """(Under ``_cv``.)"""
        self._seq += 1
        self._pending, self._pending_seq = payload, self._seq
        return self._seq

    @property
    def last_seq(self) -> int:
        """The number of the newest record handed over (0: none yet)."""
        return self._seq

    def outcome(self, seq: int, timeout_s: float) -> tuple[bool | None, str]:
        """Wait up to ``timeout_s`` for record ``seq``: (True, "") once it or a newer one
        is on disk; (False, why) once an attempt at it or a newer one failed (and none
        as new is on disk); (None, "") if neither happened in time (a slow disk). Never
        call it on the tick: it waits for the disk."""
        deadline_s = time.monotonic() + timeout_s
        with self._cv:
            while True:
                if self._durable_seq >= seq:
                    return True, ""
                if self._failed_seq >= seq:
                    return False, self._error
                left_s = deadline_s - time.monotonic()
                if left_s <= 0 or not self.background:  # (nothing else writes without a thread)
                    return None, ""
                self._cv.wait(left_s)

    def report(self) -> WriterReport:
        if not self.background and self._pending is not None:
            self._write_pending(force=False)
        with self._cv:  # (construct: asked every tick, see urc.control.evolve)
            return construct(WriterReport, durable=self._durable, pending=self._pending is not None or self._busy,
                             error=self._error, writes=self._writes, failures=self._failures)

    def write_now(self, payload: dict[str, Any]) -> bool:
        """Write in the caller's thread and wait (start-up, before anything can move)."""
        with self._cv:
            while self._busy:
                self._cv.wait()
            self._hand_over(payload)
            self._busy = True
        return self._attempt()

    def flush(self, timeout_s: float = 5.0) -> bool:
        """Wait until nothing is pending; True if the newest record is on disk."""
        if not self.background:
            if self._pending is not None:
                self._write_pending(force=True)
            return self._pending is None
        deadline = time.monotonic() + timeout_s
        with self._cv:
            self._next_try_s = -float("inf")  # retry a failed write now
            self._cv.notify_all()
            while (self._pending is not None or self._busy) and time.monotonic() < deadline:
                self._cv.wait(timeout=max(0.0, min(0.05, deadline - time.monotonic())))
            return self._pending is None and not self._busy

    def close(self, timeout_s: float = 5.0) -> bool:
        ok = self.flush(timeout_s)
        with self._cv:
            self._closing = True
            self._cv.notify_all()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
        return ok

    # ------------------------------------------------------------------ writing
    def _write_pending(self, force: bool) -> None:
        with self._cv:
            if self._pending is None or self._busy or (not force and self._now_s() < self._next_try_s):
                return
            self._busy = True
        self._attempt()

    def _attempt(self) -> bool:
        """Write the pending record (``_busy`` is set by the caller)."""
        with self._cv:
            payload, seq = self._pending, self._pending_seq
        try:
            assert payload is not None
            self.store.save(payload)
        except (OSError, StateFileError) as exc:
            with self._cv:
                self._failures += 1
                self._failed_seq = max(self._failed_seq, seq)
                if self._error != str(exc):
                    log.error("state not saved: %s", exc)
                self._error = str(exc)
                self._next_try_s = self._now_s() + self.retry_s
                self._busy = False
                self._cv.notify_all()
            return False
        with self._cv:
            self._writes += 1
            if self._error:
                log.warning("state saved again after: %s", self._error)
            self._error = ""
            self._durable, self._durable_seq = payload, seq
            if self._pending is payload:
                self._pending = None
            self._busy = False
            self._cv.notify_all()
        return True

    def _run(self) -> None:
        while True:
            with self._cv:
                while not self._closing:
                    if self._pending is None or self._busy:
                        self._cv.wait()
                        continue
                    delay_s = self._next_try_s - self._now_s()
                    if delay_s <= 0:
                        break
                    self._cv.wait(timeout=delay_s)
                if self._closing:
                    return
                self._busy = True
            self._attempt()
