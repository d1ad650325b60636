"""What every transport adapter does with a session: feed, write replies, tick, log."""

from __future__ import annotations

import asyncio
import logging
import time
from collections import deque
from types import GeneratorType
from typing import Any, Callable

from ..errors import UrcError
from ..protocols.base import Session, internal_error
from ..model.effects import Effects, perform

log = logging.getLogger("urc.servers")

#: how often sessions are asked for unsolicited output (G4JNT stream, monitor modes)
TICK_PERIOD_S = 0.1
READ_CHUNK = 4096
#: a stream's bytes go to its session this many at a time, and one session gets the event
#: loop for at most DRAIN_BUDGET_S before everyone else is served again: a client flooding
#: 60 kB of junk (30,000 error replies, ~1-3 s of work) stalled every other client's ``p``
#: for as long (issue 21). Sessions parse streams, so any split of the bytes is a valid one.
SLICE_BYTES = 512
DRAIN_BUDGET_S = 0.002
#: beyond this many unprocessed bytes the transport stops reading (TCP's flow control then
#: holds the flooding client back, not urc's memory); it reads again below the low mark
PAUSE_ABOVE_BYTES = 64 * 1024
RESUME_BELOW_BYTES = 16 * 1024

SessionFactory = Callable[[], Session]


def needs_tick(session: Session) -> bool:
    return bool(getattr(session, "wants_tick", False))


class SessionRunner:
    """Feeds one session on the event loop without ever blocking the loop.

    Each input (bytes, a tick, the hang-up) is a generator of port requests
    (urc.model.effects) stepped here: an input that needs none (every position query)
    is answered at once; a request to the control process is awaited in a task, which
    suspends this session only, while every other client is served; input arriving
    meanwhile queues behind it, so the session still sees its bytes in order and
    answers in order. ``write(reply)`` gets each reply whole;
    ``after()`` runs once the replies of an input are written (a serial port applies a
    requested line rate then).

    A stream (``stream=True``) is fed in slices, and no session holds the loop longer
    than DRAIN_BUDGET_S at a time; ``pause(True)`` / ``pause(False)`` is asked of the
    transport when unprocessed input passes PAUSE_ABOVE_BYTES / falls below
    RESUME_BELOW_BYTES. (Datagrams are messages: each stays whole.)"""

    def __init__(self, session: Session, write: Callable[[bytes], None], where: str,
                 after: Callable[[], None] | None = None, stream: bool = True,
                 pause: Callable[[bool], None] | None = None):
        self.session = session
        self.write = write
        self.where = where
        self.after = after
        self.stream = stream
        self.pause = pause
        self._queue: deque[tuple[str, Any, Callable[[bytes], None]]] = deque()
        self._input: tuple[str, Any] = ("", None)  # (the one being run: what its failure is logged as)
        self._busy = False
        self._draining = False
        self._resume_scheduled = False
        self._queued_bytes = 0
        self._paused = False

    @property
    def busy(self) -> bool:
        """A command of this session waits for the control process."""
        return self._busy

    def feed(self, data: bytes, write: Callable[[bytes], None] | None = None) -> None:
        write = write or self.write
        if len(data) <= SLICE_BYTES and not (self._queue or self._busy or self._draining or self._resume_scheduled):
            # (the common case, a poll's few bytes to an idle session: run now, as _drain
            # would at once, without the queue's round; a rotctld p is a few microseconds)
            self._draining = True
            try:
                self._run(("data", data), write)
            finally:
                self._draining = False
            if self._queue:  # (input that arrived meanwhile: a session's own hang-up)
                self._kick()
            return
        step = SLICE_BYTES if self.stream else max(len(data), 1)
        for i in range(0, max(len(data), 1), step):
            self._queue.append(("data", data[i:i + step], write))
        if self.stream:
            self._account(len(data))
        self._kick()

    def _account(self, delta_bytes: int) -> None:
        self._queued_bytes += delta_bytes
        if self.pause is None:
            return
        if not self._paused and self._queued_bytes > PAUSE_ABOVE_BYTES:
            self._paused = True
            self.pause(True)
        elif self._paused and self._queued_bytes < RESUME_BELOW_BYTES:
            self._paused = False
            self.pause(False)

    def tick(self, now_s: float) -> None:
        if not self._busy and not self._queue:  # (a stream skips a beat rather than queue up)
            self._enqueue("tick", now_s, self.write)

    def hang_up(self) -> None:
        self._enqueue("hangup", None, self.write)

    def _enqueue(self, kind: str, arg: Any, write: Callable[[bytes], None]) -> None:
        self._queue.append((kind, arg, write))
        self._kick()

    def _kick(self) -> None:
        if not self._draining and not self._resume_scheduled:
            self._drain()

    def _drain(self) -> None:
        # (a loop, not recursion: inputs that finish at once are taken one after another,
        # until this session's share of the loop is used; then everyone else's turn)
        self._draining = True
        self._resume_scheduled = False
        give_back_s = time.perf_counter() + DRAIN_BUDGET_S
        try:
            while self._queue and not self._busy:
                if time.perf_counter() > give_back_s and self._resume_later():
                    return
                kind, arg, write = self._queue.popleft()
                if kind == "data" and self.stream:
                    self._account(-len(arg))
                self._run((kind, arg), write)
        finally:
            self._draining = False

    def _run(self, item: tuple[str, Any], write: Callable[[bytes], None]) -> None:
        """One input: its replies written, or its first request to the control process
        under way (this session busy until the answer)."""
        self._busy = True
        self._input = item
        try:
            steps = self._work(*item)
        except BaseException as exc:
            self._done(None, exc, write)
            return
        if isinstance(steps, GeneratorType):
            self._step(steps, None, None, write)
        else:  # (a session step that only answers: its replies, no generator to step)
            self._done(steps, None, write)  # type: ignore[arg-type]

    def _resume_later(self) -> bool:
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # (fed from a test without an event loop: nobody to share with)
            return False
        self._resume_scheduled = True
        loop.call_soon(self._drain)
        return True

    def _work(self, kind: str, arg: Any) -> Effects[list[bytes] | None] | list[bytes] | None:
        """The input given to the session: its steps (a generator of port requests,
        stepped by :meth:`_step`) or, from a step that only answers, its replies. A client
        that went away: a session that keeps something under way for it (SARCNET
        calibration) gets ``disconnected()`` to end it cleanly."""
        if kind == "data":
            return self.session.receive(arg)
        if kind == "tick":
            return self.session.tick(arg)
        gone = getattr(self.session, "disconnected", None)
        return None if gone is None else gone()

    def _step(self, steps: Effects[list[bytes] | None], value: Any, error: BaseException | None,
              write: Callable[[bytes], None]) -> None:
        """Run ``steps`` on until it ends (its replies written) or yields a request the
        control process must answer (awaited in a task; stepped on from its outcome)."""
        try:
            while True:
                request = steps.send(value) if error is None else steps.throw(error)
                port = getattr(self.session, "rotator", None)
                remote = getattr(port, "call", None)
                if remote is None:  # (an in-process rotator: answered at once)
                    try:
                        value, error = perform(port, request), None
                    except Exception as exc:
                        value, error = None, exc
                    continue
                then = getattr(port, "call_then", None)
                if then is not None:  # (the control process's: stepped on where its reply is read)
                    then(request, lambda value, error: self._step(steps, value, error, write))
                else:
                    task = asyncio.ensure_future(remote(request))
                    task.add_done_callback(lambda t: self._resumed(steps, t, write))
                return
        except StopIteration as end:
            self._done(end.value, None, write)
        except BaseException as exc:
            self._done(None, exc, write)

    def _resumed(self, steps: Effects[list[bytes] | None], task: asyncio.Future,
                 write: Callable[[bytes], None]) -> None:
        if task.cancelled():  # (the loop is closing: the session ends with it)
            steps.close()
            return
        error = task.exception()
        self._step(steps, None if error is not None else task.result(), error, write)

    def _done(self, replies: list[bytes] | None, error: BaseException | None, write: Callable[[bytes], None]) -> None:
        self._busy = False
        kind, arg = self._input
        if error is not None:
            replies = None
            self._failed(kind, arg, error)
        elif kind == "hangup":  # (nobody is left to read a reply)
            replies = None
        for reply in replies or ():
            write(reply)
        if self.after is not None:
            self.after()
        self._kick()

    def _failed(self, kind: str, arg: Any, error: BaseException) -> None:
        """Sessions must not raise; if one does, it is logged and counted and that input
        dropped: a session bug costs this connection, never the server."""
        name = type(self.session).__name__
        if kind == "data":
            internal_error(log, name, "%s: session failed on %r", self.where, arg[:64])
        elif kind == "hangup":
            internal_error(log, name, "%s: session failed on disconnect", self.where)
        elif not isinstance(error, UrcError):  # (a stream with no fresh position to give: it skips a beat)
            internal_error(log, name, "%s: session tick failed: %r", self.where, error)


async def tick_loop(runner: SessionRunner, clock_now: Callable[[], float]) -> None:
    while not runner.session.closed:
        await asyncio.sleep(TICK_PERIOD_S)
        runner.tick(clock_now())
