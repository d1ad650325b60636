"""The I/O process's end of the link to the control process: requests out, replies and
statuses in (:class:`ControlLink`), and what a reply carries back (a value that is only
data, an exception as its class and attributes).

Every command is one typed request (:mod:`urc.model.messages`, encoded by
:mod:`.codec`), answered with its result or its exception. It never blocks the event
loop: a request from the loop is a future (:meth:`ControlLink.submit`) or a callback
(:meth:`ControlLink.submit_then`, a protocol session's next step); from another thread
(the tracker, a calibration procedure) :meth:`ControlLink.call` blocks that thread only.
In ``urc run`` the event loop itself reads the socket (``add_reader``, :mod:`.frames`): a
reply settles its request where it is read, crossing no thread (a hand-off between two
Python threads cost tens of microseconds of a set's round trip; bench/rotctld_bench.py).
Without an event loop (tests, tools) a reader thread does. Only data comes back
(:func:`travels`): objects with behaviour stay in the control process.
"""

from __future__ import annotations

import dataclasses
import datetime
import enum
import itertools
import logging
import os
import pickle
import threading
import time
from multiprocessing.connection import Connection
from pathlib import PurePath
from typing import TYPE_CHECKING, Any, Callable

from ..errors import CommandRejected, UrcError
from ..model.messages import Envelope, Reply, Request, Stop
from ..model.snapshot import Status
from . import codec
from .frames import FrameReader
from .status_record import StatusRecord, merge

if TYPE_CHECKING:
    import asyncio

log = logging.getLogger(__name__)

#: how long a command waits for the control process's answer (its lock is held for a
#: tick at a time; a state save may wait for a slow SD card up to 5 s: longer means hung)
CALL_TIMEOUT_S = 6.0
#: how often an event loop with requests waiting looks for those past their bound (a
#: request is answered "no answer" up to this much after its timeout)
SWEEP_S = 0.1

class ControlUnavailable(CommandRejected):
    """The control process does not answer (hung, dead or stopping)."""

    def __init__(self, message: str, reason: str = "fault"):
        super().__init__(message, reason)


class StopQueued(ControlUnavailable):
    """A stop the control process has not confirmed in STOP_ACK_S: it is on its way and
    runs as soon as that process reads it (a stop has no deadline)."""


# ------------------------------------------------------------------ the wire format
_PLAIN_TYPES = (type(None), bool, int, float, complex, str, bytes, enum.Enum, datetime.date, datetime.time,
                datetime.timedelta, PurePath)
#: the plain types a command's value mostly is (one set lookup before the isinstance tests)
_EXACT_PLAIN = frozenset({type(None), bool, int, float, str})


def travels(value: Any, depth: int = 0) -> bool:
    """Only data travels, as a copy; objects with behaviour (a sensor, the hardware) stay
    in the control process, so calling a method on what came back can never act on a
    copy. Data: numbers, text, enums, times, paths, containers and dataclasses of those,
    numpy arrays."""
    if type(value) in _EXACT_PLAIN:
        return True
    if depth > 8:
        return False
    if isinstance(value, _PLAIN_TYPES) or type(value).__module__ == "numpy":
        return True
    if isinstance(value, (list, tuple, set, frozenset)):
        return all(travels(v, depth + 1) for v in value)
    if isinstance(value, dict):
        return all(travels(k, depth + 1) and travels(v, depth + 1) for k, v in value.items())
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return all(travels(getattr(value, f.name), depth + 1) for f in dataclasses.fields(value))
    return False


def _picklable(value: Any) -> bool:
    try:
        pickle.dumps(value)
        return True
    except Exception:
        return False


def exception_to_wire(exc: BaseException) -> tuple:
    """An exception as (module, class name, args, attributes, text). Pickle would rebuild
    it as ``cls(*args)`` only, which loses what an ``__init__`` with other parameters
    keeps in attributes (CommandRejected's reason, ConfigError's key)."""
    cls = type(exc)
    args = exc.args if _picklable(exc.args) else (str(exc),)
    if isinstance(exc, OSError) and exc.filename is not None and len(args) == 2:
        args = (*args, exc.filename)  # (not in args: the device or file that failed)
    attrs = {k: v for k, v in vars(exc).items() if _picklable(v)}
    return cls.__module__, cls.__qualname__, args, attrs, str(exc)


def exception_from_wire(wire: tuple) -> BaseException:
    """The exception exception_to_wire described, if its class is one the link's codec
    admits (urc's own, or a built-in); otherwise a UrcError with its text."""
    module, qualname, args, attrs, text = wire
    cls = codec.allowed_class(module, qualname)
    if isinstance(cls, type) and issubclass(cls, BaseException):
        try:
            exc = cls(*args)  # (OSError keeps errno and text only through __init__)
        except Exception:
            exc = cls.__new__(cls)
            exc.args = tuple(args)
        vars(exc).update(attrs)
        return exc
    return UrcError(f"{qualname}: {text}")


# ------------------------------------------------------------------ the I/O side
def on_event_loop() -> bool:
    """Is the caller on a thread running an event loop?"""
    return _running_loop() is not None


#: tests set this: a round trip that would block the event loop raises instead of being logged
STRICT_ENV = "URC_STRICT_EVENT_LOOP"


#: what a request made with ``then`` is answered with: ``then(value, None)`` or ``then(None, exception)``
Then = Callable[[Any, BaseException | None], None]


class _Pending:
    """One request awaiting its reply: a thread waits on ``done``; or, on the event loop,
    :meth:`deliver` settles it with the request's outcome (its value passed through
    ``finish``, or its exception) on that loop's thread: its ``future``, or its ``then``
    callback (a protocol session's next step: no future, no loop round in between)."""

    __slots__ = ("rid", "request", "done", "reply", "future", "then", "loop", "link", "finish", "timeout_s",
                 "expires_s")

    def __init__(self, link: ControlLink, rid: int, request: Request, timeout_s: float,
                 loop: asyncio.AbstractEventLoop | None = None, finish: Callable[[Any], Any] | None = None,
                 then: Then | None = None):
        self.link = link
        self.rid = rid
        self.request = request
        self.timeout_s = timeout_s
        self.expires_s = time.monotonic() + timeout_s
        self.reply: Reply | None = None
        self.loop = loop
        self.finish = finish
        self.then = then
        self.done = threading.Event() if loop is None else None
        self.future: asyncio.Future | None = None if loop is None or then is not None else loop.create_future()

    def deliver(self, reply: Reply, read_here: bool = False) -> None:
        """``read_here``: the reply was read by the loop's own reader, so the outcome is
        given now; else (a loss, an expiry, another thread) in a round of the loop of its
        own, so that a ``then`` never runs inside the call that made the request. (Called
        once: by whoever took the request from the table, ControlLink._answer.)"""
        self.reply = reply
        if self.done is not None:
            self.done.set()
            return
        assert self.loop is not None
        if _running_loop() is self.loop and (read_here or self.then is None):
            self._settle()
        else:
            try:
                self.loop.call_soon_threadsafe(self._settle)
            except RuntimeError:  # (its event loop is closed: nobody is waiting)
                pass

    def _settle(self) -> None:
        """On the loop's thread: the outcome to the future or to ``then``."""
        assert self.reply is not None
        fut = self.future
        if fut is not None and fut.done():
            return
        value: Any = None
        error: BaseException | None = None
        try:
            value = self.link._outcome(self.request, self.reply)
            if self.finish is not None:
                value = self.finish(value)
        except Exception as exc:
            error = exc
        if fut is not None:
            if error is None:
                fut.set_result(value)
            else:
                fut.set_exception(error)
            return
        assert self.then is not None
        try:
            self.then(value, error)
        except Exception:  # (the link reads on: a caller's bug is its own)
            log.exception("handling the answer to %s failed", type(self.request).__name__)


def _running_loop() -> asyncio.AbstractEventLoop | None:
    import asyncio  # (lazy: the control process never loads asyncio)

    return asyncio._get_running_loop()  # (None off a loop's thread: the cheap form of get_running_loop)


class ControlLink:
    """The I/O process's end of the socket: statuses and replies are read by the event loop
    (:meth:`start` with a loop) or by a reader thread. A request waits for its reply
    without blocking anyone: awaited (:meth:`submit`) it suspends its caller only; from
    another thread it waits on an event. Either way bounded by ``timeout_s``."""

    def __init__(self, conn: Connection, on_lost: Callable[[str], None] | None = None,
                 record: StatusRecord | None = None):
        self.conn = conn
        self.on_lost = on_lost
        #: the shared-memory record the control process writes every tick (its hot
        #: fields, read without this link's thread); None: every status comes by socket
        self.record = record
        #: the newest full Status (by socket), and the record's cold generation it is of
        self.status: Status | None = None
        self.status_gen: int | None = None
        self._merged: tuple[int, int, Status] | None = None
        #: why the control process is gone ("" while it runs)
        self.lost = ""
        #: the control process's last word: how it stopped ({"saved": ..., ...})
        self.final: dict[str, Any] | None = None
        self.finished = threading.Event()
        self._ids = itertools.count(1)
        self._pending: dict[int, _Pending] = {}
        #: each event loop's timer that answers its requests past their bound (_sweep)
        self._sweeps: dict[asyncio.AbstractEventLoop, asyncio.TimerHandle] = {}
        self._send_lock = threading.Lock()
        self._reader: threading.Thread | None = None
        #: the event loop that reads the socket (None: the reader thread does)
        self._loop: asyncio.AbstractEventLoop | None = None
        self._frames: FrameReader | None = None
        self._complained: set[str] = set()

    def start(self, loop: asyncio.AbstractEventLoop | None = None) -> "ControlLink":
        """Read the socket from ``loop`` (from any thread: it starts reading on its own
        thread), or from a reader thread of this link's."""
        if loop is None:
            self._reader = threading.Thread(target=self._read, name="urc-control-link", daemon=True)
            self._reader.start()
            return self
        self._loop = loop
        frames = self._frames = FrameReader(self.conn)
        if _running_loop() is loop:
            self._start_reading(frames)
        else:
            loop.call_soon_threadsafe(self._start_reading, frames)
        return self

    def send(self, msg: tuple) -> None:
        data = codec.dumps(msg)
        with self._send_lock:
            self.conn.send_bytes(data)

    def call(self, request: Request, timeout_s: float = CALL_TIMEOUT_S) -> Any:
        """Run ``request`` in the control process; its value, or the exception raised there. A stop is always
        applied, however late it arrives; anything else that is not answered within
        ``timeout_s`` is refused over there too (it carries that deadline)."""
        on_loop = _running_loop()
        if on_loop is not None:
            self._complain(request)
        pending = self._submit(request, timeout_s, None)
        assert pending.done is not None
        if on_loop is not None and on_loop is self._loop:  # (the reader is this very thread)
            self._pump(pending, timeout_s)
            answered = pending.done.is_set()
        else:
            answered = pending.done.wait(timeout_s)
        if not answered:
            self._expire(pending)
        assert pending.reply is not None
        return self._outcome(request, pending.reply)

    def submit(self, request: Request, timeout_s: float = CALL_TIMEOUT_S,
               finish: Callable[[Any], Any] | None = None) -> asyncio.Future:
        """:meth:`call` from the event loop: a future of the request's value (passed
        through ``finish``) or its exception, bounded by ``timeout_s`` as there; awaiting
        it suspends only the caller. No task: the reply settles the future where it is read."""
        import asyncio

        pending = self._submit(request, timeout_s, asyncio.get_running_loop(), finish)
        assert pending.future is not None
        return pending.future

    def submit_then(self, request: Request, then: Then, timeout_s: float = CALL_TIMEOUT_S,
                    finish: Callable[[Any], Any] | None = None) -> None:
        """:meth:`submit` with a callback instead of a future: ``then(value, None)`` or
        ``then(None, exception)`` on the event loop, from the very round that reads the
        reply (a protocol session's next step: a set's round trip saves a loop round)."""
        import asyncio

        self._submit(request, timeout_s, asyncio.get_running_loop(), finish, then)

    def _complain(self, request: Request) -> None:
        """A round trip from the event loop thread, not awaited, blocks
        every client: a bug in urc (await RemoteRotator.call), loud in tests."""
        name = type(request).__name__
        if os.environ.get(STRICT_ENV):
            raise RuntimeError(f"{name} would block the event loop: await it (urc.model.effects.call)")
        if name not in self._complained:
            self._complained.add(name)
            log.error("%s blocks the event loop while it waits for the control process (a bug)", name,
                      stack_info=True)

    def _submit(self, request: Request, timeout_s: float, loop: asyncio.AbstractEventLoop | None,
                finish: Callable[[Any], Any] | None = None, then: Then | None = None) -> _Pending:
        rid = next(self._ids)
        # (in the table before the check: a loss now fills it)
        pending = self._pending[rid] = _Pending(self, rid, request, timeout_s, loop, finish, then)
        deadline_s = None if isinstance(request, Stop) else pending.expires_s
        if self.lost:
            self._answer(rid, _lost_reply(rid, self.lost))
        else:
            try:
                self.send(("request", Envelope(rid, deadline_s, request)))
            except (OSError, EOFError, ValueError) as exc:
                self._answer(rid, _lost_reply(rid, str(exc)))
        if loop is not None and pending.reply is None and loop not in self._sweeps:
            self._sweeps[loop] = loop.call_later(SWEEP_S, self._sweep, loop)
        return pending

    def _sweep(self, loop: asyncio.AbstractEventLoop) -> None:
        """On ``loop``, every SWEEP_S while it has requests waiting: those past their
        bound are answered "no answer" (one timer for all of them: a timer each, armed and
        cancelled per request, was a heap push and pop per rotctld P)."""
        del self._sweeps[loop]
        now_s = time.monotonic()
        # (a copy first, made in one C call: a thread's call may add to the table meanwhile)
        waiting = [p for p in tuple(self._pending.values()) if p.loop is loop]
        for pending in waiting:
            if pending.expires_s <= now_s:
                self._expire(pending)
        if any(p.reply is None for p in waiting):
            self._sweeps[loop] = loop.call_later(SWEEP_S, self._sweep, loop)

    def _answer(self, rid: int, reply: Reply, read_here: bool = False) -> None:
        """Deliver ``reply`` to request ``rid`` if it still waits. Whoever takes it from the
        table delivers it (dict.pop is one step under the GIL): a reply read at the very
        moment its bound expires on another thread goes to the caller once, not twice."""
        pending = self._pending.pop(rid, None)
        if pending is not None:
            pending.deliver(reply, read_here)

    def _expire(self, pending: _Pending) -> None:
        text = f"the control process did not answer within {pending.timeout_s:g} s (hung?): "
        exc = (StopQueued(text + "the stop is sent and runs as soon as it resumes")
               if isinstance(pending.request, Stop) else ControlUnavailable(text + "nothing was done"))
        self._answer(pending.rid, Reply(pending.rid, "error", exception_to_wire(exc), None))

    def _outcome(self, request: Request, reply: Reply) -> Any:
        if reply.outcome == "lost":
            raise ControlUnavailable(f"the control process is gone ({reply.value}): nothing was done")
        self.offer_status(reply.status)
        if reply.outcome == "error":
            raise exception_from_wire(reply.value)
        return reply.value

    def offer_status(self, status: Status | None, gen: int | None = None) -> None:
        # a reply carries the status a command left (read-your-writes); ticks publish too
        if status is not None and (self.status is None or status.t_s >= self.status.t_s):
            self.status = status
            if gen is not None:
                self.status_gen = gen

    def current(self) -> Status | None:
        """The newest status: the last full one with the record's hot fields of the
        latest tick merged in (position, speeds, modes, its time), so the position is as
        fresh as the control loop whatever this process's threads managed to read. The
        cold fields (faults, events, ...) are those of the last full status read."""
        s = self.status
        if s is None or self.record is None:
            return s
        hot = self.record.read()
        if hot is None or hot.t_s <= s.t_s:
            return s
        cached = self._merged
        if cached is not None and cached[0] == hot.tick and cached[1] == id(s):
            return cached[2]
        merged = merge(s, hot)
        self._merged = (hot.tick, id(s), merged)
        return merged

    # ------------------------------------------------------------- reading
    def _take(self, data: bytes) -> None:
        """One message from the control process."""
        try:
            msg = codec.loads(data)
        except BaseException:  # (whatever the decoder raised: that message dropped, and on)
            log.exception("control link: an unreadable message from the control process, dropped")
            return
        kind = msg[0]
        if kind == "status":
            self.offer_status(msg[1], msg[2] if len(msg) > 2 else None)
        elif kind == "reply":
            self._answer(msg[1].rid, msg[1], read_here=self._loop is not None)
        elif kind == "died":
            self._lose(f"control loop died: {msg[1]}")
        elif kind == "stopped":
            self.final = msg[1]

    def _read(self) -> None:
        """The reader thread (no event loop reads the socket)."""
        reason = "its socket closed"
        try:
            while True:
                self._take(self.conn.recv_bytes())
        except (EOFError, OSError) as exc:
            if not isinstance(exc, EOFError):
                reason = f"its socket failed: {exc}"
        except Exception as exc:  # (a bug in handling a message: the link is unusable)
            log.exception("control link broken")
            reason = f"link failed: {exc!r}"
        self._end(reason)

    def _start_reading(self, frames: FrameReader) -> None:
        """(On the loop.) Unless the link was lost meanwhile (its descriptor closed, and
        its number perhaps another socket's by now)."""
        if not frames.closed:
            assert self._loop is not None
            self._loop.add_reader(frames.fileno(), self._readable)

    def _readable(self) -> None:
        """The event loop's reader: everything the socket holds now, message by message."""
        assert self._frames is not None
        reason = ""
        try:
            messages = self._frames.read()
            if messages is None:
                reason = "its socket closed"
            else:
                for data in messages:
                    self._take(data)
        except OSError as exc:
            reason = f"its socket failed: {exc}"
        except Exception as exc:  # (a bug in handling a message, bytes that are no frame)
            log.exception("control link broken")
            reason = f"link failed: {exc!r}"
        if reason:
            self._stop_reading()
            self._end(reason)

    def _pump(self, pending: _Pending, timeout_s: float) -> None:
        """Read the socket on this thread until ``pending`` is answered or ``timeout_s`` has
        passed: a blocking call on the very loop that reads the socket (a bug, logged by
        :meth:`_complain`) must not wait for itself."""
        frames = self._frames
        assert frames is not None
        deadline_s = time.monotonic() + timeout_s
        while pending.reply is None and not frames.closed:
            if not frames.wait(deadline_s - time.monotonic()):
                return
            self._readable()

    def _stop_reading(self) -> None:
        frames, loop = self._frames, self._loop
        if frames is not None and loop is not None and not frames.closed:
            try:
                loop.remove_reader(frames.fileno())
            except RuntimeError:  # (its loop is closed)
                pass
            frames.close()

    def _end(self, reason: str) -> None:
        self._lose(reason if self.final is None else "it stopped")
        self.finished.set()

    def _lose(self, reason: str) -> None:
        if self.lost:
            return
        self.lost = reason
        for rid in list(self._pending):
            self._answer(rid, _lost_reply(rid, reason))
        if self.on_lost is not None:
            try:
                self.on_lost(reason)
            except Exception:  # (an event loop already closed: nobody to tell)
                log.exception("telling that the control process is gone failed")


def _lost_reply(rid: int, reason: str) -> Reply:
    return Reply(rid, "lost", reason, None)
