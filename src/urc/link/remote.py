"""The I/O process's side of the control process: a Rotator that lives in another process.

``urc run`` runs the control loop in a process of its own (:mod:`.control_process`):
within one interpreter the loop thread had to win Python's global lock from the
event-loop thread, and under a flood of requests on two cores the OS preempted that
thread while it held the lock, so ticks waited for a whole scheduler slice (10-19 ms
p99, bench/loop_bench.py, against 0.1-0.2 ms for a C thread in the same run). The
control process runs only the rotator, its hardware and the loop, at real-time
priority; everything that answers the network stays here.

This module is the I/O side of the wire between the two, over one Unix socket
(messages: :mod:`urc.model.messages`; codec: :mod:`urc.link.codec`):

* the control process publishes a :class:`Status` after every tick; :meth:`RemoteRotator.status`
  returns the newest, so reading status (every protocol's position query) costs no
  round trip; a status that stopped coming is a ``control`` fault, and the sessions'
  view refuses to give it out as a position;
* every command is one typed request, answered with its result or its exception (its
  own class, so each protocol still answers in its own error form). It never blocks the
  event loop: web routes and protocol sessions await :meth:`RemoteRotator.call`
  (:mod:`urc.model.effects`), which suspends the caller only; synchronous code that
  calls the port (the tracker, calibration procedures) runs on a thread of its own,
  where :meth:`RemoteRotator.request` blocks that thread only;
* in ``urc run`` the event loop itself reads the socket (``add_reader``): a reply settles
  its future where it is read, crossing no thread (a hand-off between two Python threads
  costs tens of microseconds of a set's round trip on a Pi-class machine;
  bench/rotctld_bench.py). Without an event loop (tests, tools) a reader thread does;
* the hardware stays over there: what a protocol or route needs of it (a sensor's count
  or constants, a calibration step) is one typed query (:class:`urc.model.messages.Query`,
  :meth:`RemoteRotator.ask`, answered by :mod:`.queries`), one round trip each; only data
  comes back (:func:`travels`).
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

from ..clock import RealClock
from ..control.faults import Fault
from ..errors import CommandRejected, UrcError
from . import codec
from ..model.messages import (AdoptSensorReading, Announce, CancelProgram, ClearFaults, EndSearch, Envelope, FlyProgram,
                            Goto, GotoAz, GotoEl,
                            GotoPose, HardwareInfo, HoldLocal, LocalControls, Move, OvershootQuery, Park,
                            PositionUncertain, PowerFail, Query, Reconfigure, Reply, Request, SaveNow,
                            SearchFrame, SetOvershoot, SetPosition, Stop, Track, TrackPose)
from .frames import FrameReader
from .status_record import StatusRecord, merge
from ..model.snapshot import Status

if TYPE_CHECKING:
    import asyncio

log = logging.getLogger(__name__)

#: how long a command waits for the control process's answer (its lock is held for a
#: tick at a time; a state save may wait for a slow SD card up to 5 s: longer means hung)
CALL_TIMEOUT_S = 6.0
#: how often an event loop with requests waiting looks for those past their bound (a
#: request is answered "no answer" up to this much after its timeout)
SWEEP_S = 0.1
#: how long a stop waits for its confirmation (it is applied however late it arrives,
#: so a longer wait would only keep its caller from telling the operator)
STOP_ACK_S = 1.0
#: a status older than this means the control process has stopped publishing (it
#: publishes every tick)
STATUS_STALE_S = 1.0
#: ... and sooner while the axes moved: a position that old may already be degrees off
#: (at 6 deg/s, 1 s was 3 deg given as current by rotctld's ``p``; issue 20)
MOVING_STATUS_STALE_S = 0.3


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


class _Pending:
    """One request awaiting its reply: a thread waits on ``done``, or the event loop
    holds ``future``, which :meth:`deliver` settles with the request's outcome (its value
    passed through ``finish``, or its exception) on that loop's thread."""

    __slots__ = ("rid", "request", "done", "reply", "future", "loop", "link", "finish", "timeout_s", "expires_s")

    def __init__(self, link: ControlLink, rid: int, request: Request, timeout_s: float,
                 loop: asyncio.AbstractEventLoop | None = None, finish: Callable[[Any], Any] | None = None):
        self.link = link
        self.rid = rid
        self.request = request
        self.timeout_s = timeout_s
        self.expires_s = time.monotonic() + timeout_s
        self.reply: Reply | None = None
        self.loop = loop
        self.finish = finish
        self.done = threading.Event() if loop is None else None
        self.future: asyncio.Future | None = None if loop is None else loop.create_future()

    def deliver(self, reply: Reply) -> None:
        if self.reply is not None:  # (answered already: a late reply after its expiry)
            return
        self.reply = reply
        if self.done is not None:
            self.done.set()
            return
        assert self.loop is not None
        if _running_loop() is self.loop:
            self._settle()
        else:
            try:
                self.loop.call_soon_threadsafe(self._settle)
            except RuntimeError:  # (its event loop is closed: nobody is waiting)
                pass

    def _settle(self) -> None:
        """On the loop's thread: the future gets the outcome."""
        fut = self.future
        assert fut is not None and self.reply is not None
        if fut.done():
            return
        try:
            value = self.link._outcome(self.request, self.reply)
            fut.set_result(value if self.finish is None else self.finish(value))
        except Exception as exc:
            fut.set_exception(exc)


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
            loop.add_reader(frames.fileno(), self._readable)
        else:
            loop.call_soon_threadsafe(loop.add_reader, frames.fileno(), self._readable)
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
        if not pending.done.wait(timeout_s):
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
                finish: Callable[[Any], Any] | None = None) -> _Pending:
        rid = next(self._ids)
        pending = self._pending[rid] = _Pending(self, rid, request, timeout_s, loop, finish)  # (before the check: a loss now fills it)
        deadline_s = None if isinstance(request, Stop) else pending.expires_s
        if self.lost:
            pending.deliver(_lost_reply(rid, self.lost))
        else:
            try:
                self.send(("request", Envelope(rid, deadline_s, request)))
            except (OSError, EOFError, ValueError) as exc:
                pending.deliver(_lost_reply(rid, str(exc)))
        if loop is not None and pending.reply is None and loop not in self._sweeps:
            self._sweeps[loop] = loop.call_later(SWEEP_S, self._sweep, loop)
        return pending

    def _sweep(self, loop: asyncio.AbstractEventLoop) -> None:
        """On ``loop``, every SWEEP_S while it has requests waiting: those past their
        bound are answered "no answer" (one timer for all of them: a timer each, armed and
        cancelled per request, was a heap push and pop per rotctld P)."""
        del self._sweeps[loop]
        now_s = time.monotonic()
        waiting = [p for p in self._pending.values() if p.loop is loop]
        for pending in waiting:
            if pending.expires_s <= now_s:
                self._expire(pending)
        if any(p.reply is None for p in waiting):
            self._sweeps[loop] = loop.call_later(SWEEP_S, self._sweep, loop)

    def _expire(self, pending: _Pending) -> None:
        if self._pending.pop(pending.rid, None) is None or pending.reply is not None:
            return
        text = f"the control process did not answer within {pending.timeout_s:g} s (hung?): "
        exc = (StopQueued(text + "the stop is sent and runs as soon as it resumes")
               if isinstance(pending.request, Stop) else ControlUnavailable(text + "nothing was done"))
        pending.deliver(Reply(pending.rid, "error", exception_to_wire(exc), None))

    def _outcome(self, request: Request, reply: Reply) -> Any:
        self._pending.pop(reply.rid, None)
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
            pending = self._pending.get(msg[1].rid)
            if pending is not None:
                pending.deliver(msg[1])
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
        for rid, pending in list(self._pending.items()):
            pending.deliver(_lost_reply(rid, reason))
        if self.on_lost is not None:
            try:
                self.on_lost(reason)
            except Exception:  # (an event loop already closed: nobody to tell)
                log.exception("telling that the control process is gone failed")


def _lost_reply(rid: int, reason: str) -> Reply:
    return Reply(rid, "lost", reason, None)


class _Shared:
    """What every view of one remote rotator shares: the link to the control process
    (replaced when it is started again) and what it said it runs with."""

    def __init__(self, link: ControlLink, info: dict[str, Any]):
        self.link = link
        self.settings = info["settings"]
        self.caps = info["caps"]
        self.geometry = info["geometry"]
        self.pid: int = info["pid"]
        self.priority: str = info.get("priority", "")
        #: what the hardware is (sent with "ready": asking costs no round trip)
        self.hardware = info["hardware"]
        #: the last bounded command accepted (a goto, a park: (method, arguments)) until
        #: another motion command: what a control process started again resumes
        self.bounded: tuple[str, tuple] | None = None


#: motion commands remembered while they are the last one (resumed after a restart) ...
_BOUNDED = (Goto, GotoAz, GotoEl, GotoPose, Park)
#: ... and those that end that (an open-ended motion or a re-reference)
_UNBOUNDED = (Track, TrackPose, Move, SetPosition)


class RemoteRotator:
    """Stands in for :class:`~urc.rotator.rotator.Rotator` in the I/O process: the same
    commands, each a typed request (urc.model.messages) run by the real one in the control
    process, and the same status, published by every tick (reading it costs nothing)."""

    def __init__(self, link: ControlLink, info: dict[str, Any], shared: _Shared | None = None,
                 fresh_status_only: bool = False):
        self._shared = shared or _Shared(link, info)
        self._fresh_status_only = fresh_status_only
        self.clock = RealClock()  # CLOCK_MONOTONIC: the same time base in both processes
        self._info = info
        link.offer_status(info["status"])

    def for_sessions(self) -> "RemoteRotator":
        """The view protocol sessions get: ``status()`` raises ControlUnavailable while the
        control process is gone or silent, so no protocol answers a stale position as if
        it were current (each answers in its own error form)."""
        return RemoteRotator(self._link, self._info, self._shared, fresh_status_only=True)

    def rebind(self, new: "RemoteRotator") -> None:
        """A new control process runs (started again after a takeover): every view of this
        rotator (the sessions' too) talks to it from now on."""
        shared, theirs = self._shared, new._shared
        shared.settings, shared.caps, shared.geometry = theirs.settings, theirs.caps, theirs.geometry
        shared.pid, shared.priority, shared.hardware = theirs.pid, theirs.priority, theirs.hardware
        shared.link = theirs.link

    _link = property(lambda self: self._shared.link)
    settings = property(lambda self: self._shared.settings)
    caps = property(lambda self: self._shared.caps)
    geometry = property(lambda self: self._shared.geometry)
    pid = property(lambda self: self._shared.pid)
    priority = property(lambda self: self._shared.priority)
    hardware = property(lambda self: self._shared.hardware)

    @property
    def lock(self) -> Any:
        raise TypeError("the rotator's lock is in the control process: steps that must not be split by "
                        "a tick run there whole (a query: urc.rotator.queries)")

    def status(self) -> Status:
        s = self._link.current()
        assert s is not None
        fault = self._link_fault(s)
        if fault is None:
            return s
        if self._fresh_status_only:
            raise ControlUnavailable(f"{fault.reason}: position unknown")
        return dataclasses.replace(s, faults=s.faults + (fault,))

    def _link_fault(self, s: Status) -> Fault | None:
        """A control process that is gone or silent is a fault every client sees (the
        position shown is its last word, not a live reading)."""
        if self._link.lost:
            return Fault("control", None, f"control process gone: {self._link.lost}", s.t_s)
        age_s = self.clock.now_s() - s.t_s
        if age_s > (MOVING_STATUS_STALE_S if s.moving else STATUS_STALE_S):
            return Fault("control", None, f"control process silent for {age_s:.1f} s", s.t_s)
        return None

    # ------------------------------------------------------------- requests
    def _timeout_s(self, request: Request) -> float:
        if isinstance(request, Stop):
            self._shared.bounded = None  # (before: a stop that is only queued cancels it too)
            return STOP_ACK_S
        if isinstance(request, SaveNow):
            return CALL_TIMEOUT_S + request.timeout_s
        return CALL_TIMEOUT_S

    def _accepted(self, request: Request, value: Any) -> Any:
        """What the I/O side keeps of an accepted request: the last bounded motion
        command (a goto, a park: resumed by a control process started again; any other
        motion command ends it), the settings a reconfigure handed over."""
        if isinstance(request, _BOUNDED):
            self._shared.bounded = (request.METHOD, tuple(request.arguments().values()))
        elif isinstance(request, _UNBOUNDED):
            self._shared.bounded = None
        elif isinstance(request, Reconfigure):
            # accepted: the control process applies them at its next tick, as these are
            settings = request.settings.completed()
            self._shared.settings, self._shared.caps = settings, settings.caps
            self._shared.geometry = settings.geometry()
        return value

    def request(self, request: Request) -> Any:
        """Run ``request`` in the control process, waiting for its answer: from a thread
        (the tracker's, a calibration procedure's); event-loop code awaits :meth:`call`
        instead. What the hardware is needs no round trip."""
        if isinstance(request, HardwareInfo):
            return self.hardware
        timeout_s = self._timeout_s(request)
        return self._accepted(request, self._link.call(request, timeout_s=timeout_s))

    def call(self, request: Request) -> asyncio.Future:
        """``await rotator.call(Goto(az, el))`` on the event loop: the round trip
        suspends its caller only (urc.model.effects). A future, not a coroutine: a
        protocol session's request needs no task of its own (urc.servers.common)."""
        if isinstance(request, HardwareInfo):
            import asyncio

            known = asyncio.get_running_loop().create_future()
            known.set_result(self.hardware)
            return known
        return self._link.submit(request, self._timeout_s(request), finish=lambda value: self._accepted(request, value))

    def ask(self, query: Query) -> Any:
        """A hardware query or calibration procedure, answered by the control process in
        one round trip (urc.rotator.queries); what the hardware is needs none."""
        return self.request(query)

    def reconfigure(self, settings: Any) -> None:
        self.request(Reconfigure(settings))

    def resume_bounded(self) -> str:
        """A control process started again: send the bounded command that was under way
        again if the position is known (an absolute sensor); what was resumed, or ""."""
        last = self._shared.bounded
        if last is None or not self.status().position_known:
            return ""
        getattr(self, last[0])(*last[1])
        return last[0]

    # ------------------------------------------------------------- the commands (RotatorPort)
    def goto(self, az_deg: float, el_deg: float) -> list:
        return self.request(Goto(az_deg, el_deg))

    def goto_az(self, az_deg: float) -> list:
        return self.request(GotoAz(az_deg))

    def goto_el(self, el_deg: float) -> list:
        return self.request(GotoEl(el_deg))

    def goto_pose(self, az_m_deg: float, el_m_deg: float, name: str = "goto_pose", local: bool = False) -> list:
        return self.request(GotoPose(az_m_deg, el_m_deg, name, local))

    def park(self, local: bool = False) -> list:
        return self.request(Park(local))

    def track(self, az_deg: float, el_deg: float, az_rate_deg_per_s: float = 0.0, el_rate_deg_per_s: float = 0.0,
              t_ref_s: float | None = None) -> None:
        self.request(Track(az_deg, el_deg, az_rate_deg_per_s, el_rate_deg_per_s, t_ref_s))

    def track_pose(self, az_m_deg: float, el_m_deg: float, az_rate_deg_per_s: float = 0.0,
                   el_rate_deg_per_s: float = 0.0, t_ref_s: float | None = None) -> None:
        self.request(TrackPose(az_m_deg, el_m_deg, az_rate_deg_per_s, el_rate_deg_per_s, t_ref_s))

    def move(self, axis: str, direction: int, speed_frac: float = 1.0, local: bool = False) -> None:
        self.request(Move(axis, direction, speed_frac, local))

    def stop(self, axis: str | None = None) -> None:
        self.request(Stop(axis))

    def fly_program(self, program: Any) -> None:
        self.request(FlyProgram(program))  # (a program is uploaded again by its tracker)

    def cancel_program(self, program_id: int | None = None) -> None:
        self.request(CancelProgram(program_id))

    def set_position(self, az_deg: float | None = None, el_deg: float | None = None, local: bool = False) -> None:
        self.request(SetPosition(az_deg, el_deg, local))

    def adopt_sensor_reading(self, axis: str, local: bool = False) -> float:
        return self.request(AdoptSensorReading(axis, local))

    def search_frame(self, axis: str, mech_deg: float) -> None:
        self.request(SearchFrame(axis, mech_deg))

    def end_search(self, axis: str, mech_deg: float | None = None) -> None:
        self.request(EndSearch(axis, mech_deg))

    def set_overshoot(self, axis: str, overshoot_deg: float) -> None:
        self.request(SetOvershoot(axis, overshoot_deg))

    def overshoot_deg(self, axis: str) -> float:
        return self.request(OvershootQuery(axis))

    def clear_faults(self) -> None:
        self.request(ClearFaults())

    def hold_local(self, control: str, held: bool) -> None:
        self.request(HoldLocal(control, held))

    def local_controls(self) -> tuple[str, ...]:
        return self.request(LocalControls())

    def announce(self, text: str) -> None:
        self.request(Announce(text))

    def power_fail(self, reason: str = "power-fail input: supply lost") -> None:
        self.request(PowerFail(reason))

    def save_now(self, timeout_s: float = 5.0) -> bool:
        return self.request(SaveNow(timeout_s))

    def position_uncertain(self) -> bool:
        return self.request(PositionUncertain())
