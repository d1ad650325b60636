"""What every transport adapter does with a session: feed, write replies, tick, log."""

from __future__ import annotations

import asyncio
import logging
from collections import deque
from typing import Any, Callable

from ..errors import UrcError
from ..ipc import bridge
from ..protocols.base import Session, internal_error

log = logging.getLogger("urc.servers")

#: how often sessions are asked for unsolicited output (G4JNT stream, monitor modes)
TICK_PERIOD_S = 0.1
READ_CHUNK = 4096

SessionFactory = Callable[[], Session]


def feed(session: Session, data: bytes, where: str) -> list[bytes]:
    """Give bytes to a session; a session bug costs this connection, never the server."""
    try:
        return session.receive(data)
    except Exception:  # sessions must not raise; if one does: logged, counted, input dropped
        internal_error(log, type(session).__name__, "%s: session failed on %r", where, data[:64])
        return []


def hang_up(session: Session, where: str) -> None:
    """The client went away: a session that keeps something under way for it (SARCNET
    calibration) gets ``disconnected()`` to end it cleanly."""
    gone = getattr(session, "disconnected", None)
    if gone is None:
        return
    try:
        gone()
    except Exception:
        internal_error(log, type(session).__name__, "%s: session failed on disconnect", where)


def needs_tick(session: Session) -> bool:
    return bool(getattr(session, "wants_tick", False))


class SessionRunner:
    """Feeds one session on the event loop without ever blocking the loop.

    Each input (bytes, a tick, the hang-up) runs in a bridged greenlet: a command that
    waits for the control process suspends this session only, while every other client
    is served; input arriving meanwhile queues behind it, so the session still sees its
    bytes in order and answers in order. ``write(reply)`` gets each reply whole;
    ``after()`` runs once the replies of an input are written (a serial port applies a
    requested line rate then)."""

    def __init__(self, session: Session, write: Callable[[bytes], None], where: str,
                 after: Callable[[], None] | None = None):
        self.session = session
        self.write = write
        self.where = where
        self.after = after
        self._queue: deque[tuple[str, Any, Callable[[bytes], None]]] = deque()
        self._busy = False
        self._draining = False

    @property
    def busy(self) -> bool:
        """A command of this session waits for the control process."""
        return self._busy

    def feed(self, data: bytes, write: Callable[[bytes], None] | None = None) -> None:
        self._enqueue("data", data, write or self.write)

    def tick(self, now_s: float) -> None:
        if not self._busy and not self._queue:  # (a stream skips a beat rather than queue up)
            self._enqueue("tick", now_s, self.write)

    def hang_up(self) -> None:
        self._enqueue("hangup", None, self.write)

    def _enqueue(self, kind: str, arg: Any, write: Callable[[bytes], None]) -> None:
        self._queue.append((kind, arg, write))
        if not self._draining:
            self._drain()

    def _drain(self) -> None:
        # (a loop, not recursion: inputs that finish at once are taken one after another)
        self._draining = True
        try:
            while self._queue and not self._busy:
                kind, arg, write = self._queue.popleft()
                self._busy = True
                bridge.start(self._work, (kind, arg), lambda replies, error, w=write: self._done(replies, error, w))
        finally:
            self._draining = False

    def _work(self, kind: str, arg: Any) -> list[bytes]:
        if kind == "data":
            return feed(self.session, arg, self.where)
        if kind == "tick":
            try:
                return self.session.tick(arg)
            except UrcError:  # (a stream with no fresh position to give: it skips a beat)
                return []
        hang_up(self.session, self.where)
        return []

    def _done(self, replies: list[bytes] | None, error: BaseException | None, write: Callable[[bytes], None]) -> None:
        self._busy = False
        if error is not None:  # (feed and hang_up catch everything: a tick that raised)
            internal_error(log, type(self.session).__name__, "%s: session tick failed: %r", self.where, error)
        for reply in replies or ():
            write(reply)
        if self.after is not None:
            self.after()
        if not self._draining:
            self._drain()


async def tick_loop(runner: SessionRunner, clock_now: Callable[[], float]) -> None:
    while not runner.session.closed:
        await asyncio.sleep(TICK_PERIOD_S)
        runner.tick(clock_now())
