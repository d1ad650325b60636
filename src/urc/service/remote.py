"""The I/O process's side of the control process: a Rotator that lives in another process.

``urc run`` runs the control loop in a process of its own (:mod:`.control_process`):
within one interpreter the loop thread had to win Python's global lock from the
event-loop thread, and under a flood of requests on two cores the OS preempted that
thread while it held the lock, so ticks waited for a whole scheduler slice (10-19 ms
p99, bench/loop_bench.py, against 0.1-0.2 ms for a C thread in the same run). The
control process runs only the rotator, its hardware and the loop, at real-time
priority; everything that answers the network stays here.

This module is the wire between the two, over one Unix socket
(``multiprocessing.connection``, pickled messages):

* the control process publishes a :class:`Status` after every tick; :meth:`RemoteRotator.status`
  returns the newest, so reading status (every protocol's position query) costs no
  round trip;
* every command is a call by name on the real Rotator, answered with its result or
  its exception (its own class, so each protocol still answers in its own error form);
* data comes back as a copy (:func:`travels`); objects with behaviour (the hardware, a
  sensor) stay where they are and come back as :class:`RemoteRef` paths that the
  control process resolves again on use, e.g. ``rotator.hw.axis("az").sensor.calibration()``.
  Only public names resolve.
"""

from __future__ import annotations

import dataclasses
import datetime
import enum
import functools
import importlib
import itertools
import logging
import pickle
import threading
from multiprocessing.connection import Connection
from pathlib import PurePath
from typing import Any, Callable

from ..clock import RealClock
from ..control.faults import Fault
from ..errors import CommandRejected, UrcError
from .snapshot import Status

log = logging.getLogger(__name__)

#: how long a command waits for the control process's answer (its lock is held for a
#: tick at a time; a state save may wait for a slow SD card up to 5 s: longer means hung)
CALL_TIMEOUT_S = 6.0
#: a status older than this means the control process has stopped publishing
STATUS_STALE_S = 1.0

#: a path step that calls what the previous steps named: ("()", args, kwargs)
CALL = "()"
#: dunder methods a RemoteRef forwards (every other private name is refused)
FORWARDED_DUNDERS = ("__contains__",)


class ControlUnavailable(CommandRejected):
    """The control process does not answer (hung, dead or stopping)."""

    def __init__(self, message: str, reason: str = "fault"):
        super().__init__(message, reason)


# ------------------------------------------------------------------ the wire format
def resolve(root: Any, path: tuple) -> Any:
    """Follow ``path`` (attribute names and call steps) from ``root``; public names only."""
    obj = root
    for step in path:
        if isinstance(step, str):
            if step.startswith("_") and step not in FORWARDED_DUNDERS:
                raise AttributeError(f"{step!r} is not reachable from the I/O process")
            obj = getattr(obj, step)
        else:
            _, args, kwargs = step
            obj = obj(*args, **kwargs)
    return obj


_PLAIN_TYPES = (type(None), bool, int, float, complex, str, bytes, enum.Enum, datetime.date, datetime.time,
                datetime.timedelta, PurePath)


def travels(value: Any, depth: int = 0) -> bool:
    """Data travels as a copy; objects with behaviour (a sensor, the hardware) stay in the
    control process and are reached through a RemoteRef, so calling a method on what
    came back can never act on a copy. Data: numbers, text, enums, times, paths,
    containers and dataclasses of those, numpy arrays."""
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


def _named(module: str, qualname: str) -> Any:
    """What ``module.qualname`` names (a class or function, by the name it travelled as)."""
    obj: Any = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


def exception_from_wire(wire: tuple) -> BaseException:
    module, qualname, args, attrs, text = wire
    try:
        cls = _named(module, qualname)
        if isinstance(cls, type) and issubclass(cls, BaseException):
            try:
                exc = cls(*args)  # (OSError keeps errno and text only through __init__)
            except Exception:
                exc = cls.__new__(cls)
                exc.args = tuple(args)
            vars(exc).update(attrs)
            return exc
    except Exception:
        pass
    return UrcError(f"{qualname}: {text}")


# ------------------------------------------------------------------ the I/O side
class _Slot:
    __slots__ = ("done", "reply")

    def __init__(self) -> None:
        self.done = threading.Event()
        self.reply: tuple | None = None


class ControlLink:
    """The I/O process's end of the socket: a reader thread takes statuses and replies,
    callers on any thread send requests and wait (bounded) for their answer."""

    def __init__(self, conn: Connection, on_lost: Callable[[str], None] | None = None):
        self.conn = conn
        self.on_lost = on_lost
        self.status: Status | None = None
        #: why the control process is gone ("" while it runs)
        self.lost = ""
        #: the control process's last word: how it stopped ({"saved": ..., ...})
        self.final: dict[str, Any] | None = None
        self.finished = threading.Event()
        self._ids = itertools.count(1)
        self._pending: dict[int, _Slot] = {}
        self._send_lock = threading.Lock()
        self._reader: threading.Thread | None = None

    def start(self) -> "ControlLink":
        self._reader = threading.Thread(target=self._read, name="urc-control-link", daemon=True)
        self._reader.start()
        return self

    def send(self, msg: tuple) -> None:
        with self._send_lock:
            self.conn.send(msg)

    def request(self, kind: str, path: tuple, args: tuple = (), kwargs: dict | None = None,
                timeout_s: float = CALL_TIMEOUT_S) -> Any:
        """Send one request and wait for its answer: the value, a RemoteRef for what
        cannot travel, or the exception raised over there."""
        rid = next(self._ids)
        slot = self._pending[rid] = _Slot()  # (before the check: a loss now fills it)
        try:
            if self.lost:
                raise ControlUnavailable(f"the control process is gone ({self.lost}): nothing was done")
            try:
                self.send((kind, rid, path, args, kwargs or {}))
            except (OSError, EOFError) as exc:
                raise ControlUnavailable(f"the control process is gone ({exc}): nothing was done") from None
            if not slot.done.wait(timeout_s):
                raise ControlUnavailable(f"the control process did not answer within {timeout_s:g} s "
                                         "(hung?): the command may still take effect")
        finally:
            self._pending.pop(rid, None)
        assert slot.reply is not None
        outcome, payload, status = slot.reply
        if outcome == "lost":
            raise ControlUnavailable(f"the control process is gone ({payload}): nothing was done")
        self.offer_status(status)
        if outcome == "error":
            raise exception_from_wire(payload)
        if outcome == "ref":
            if kind == "run":
                raise UrcError(f"{'.'.join(path)} returned something that cannot leave the control process")
            return RemoteRef(self, path if kind == "get" else path + ((CALL, args, kwargs or {}),))
        return payload

    def offer_status(self, status: Status | None) -> None:
        # a reply carries the status a command left (read-your-writes); ticks publish too
        if status is not None and (self.status is None or status.t_s >= self.status.t_s):
            self.status = status

    def _read(self) -> None:
        reason = "its socket closed"
        try:
            while True:
                msg = self.conn.recv()
                kind = msg[0]
                if kind == "status":
                    self.offer_status(msg[1])
                elif kind == "reply":
                    slot = self._pending.get(msg[1])
                    if slot is not None:
                        slot.reply = msg[2:]
                        slot.done.set()
                elif kind == "died":
                    reason = f"control loop died: {msg[1]}"
                    self._lose(reason)
                elif kind == "stopped":
                    self.final = msg[1]
        except (EOFError, OSError) as exc:
            if not isinstance(exc, EOFError):
                reason = f"its socket failed: {exc}"
        except Exception as exc:  # a message that cannot be read: the link is unusable
            log.exception("control link broken")
            reason = f"unreadable message: {exc!r}"
        self._lose(reason if self.final is None else "it stopped")
        self.finished.set()

    def _lose(self, reason: str) -> None:
        if self.lost:
            return
        self.lost = reason
        for slot in list(self._pending.values()):
            slot.reply = ("lost", reason, None)
            slot.done.set()
        if self.on_lost is not None:
            try:
                self.on_lost(reason)
            except Exception:  # (an event loop already closed: nobody to tell)
                log.exception("telling that the control process is gone failed")


class RemoteRef:
    """Something that stays in the control process (the hardware, a sensor), named by
    the path that reaches it from the rotator. Attributes come back as values when they
    can travel and are not callable; calls run over there."""

    __slots__ = ("_link", "_path")

    def __init__(self, link: ControlLink, path: tuple):
        self._link = link
        self._path = path

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        return self._link.request("get", self._path + (name,))

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self._link.request("call", self._path, args, kwargs)

    def __contains__(self, item: Any) -> bool:
        return bool(self._link.request("call", self._path + ("__contains__",), (item,)))

    def __repr__(self) -> str:
        return f"<RemoteRef {'.'.join(s if isinstance(s, str) else '()' for s in self._path)}>"


class RemoteRotator:
    """Stands in for :class:`~urc.service.rotator.Rotator` in the I/O process: the same
    commands (run by the real one, in the control process) and the same status."""

    #: Rotator methods the I/O process must not call: the control process owns the tick
    #: and its own shutdown
    LOCAL_ONLY = frozenset({"tick", "shutdown", "note_lateness"})

    def __init__(self, link: ControlLink, info: dict[str, Any]):
        self._link = link
        self.pid: int = info["pid"]
        self.priority: str = info.get("priority", "")
        self.clock = RealClock()  # CLOCK_MONOTONIC: the same time base in both processes
        self.hw = RemoteRef(link, ("hw",))
        self.store = RemoteRef(link, ("store",))
        self._take_settings(info)
        link.offer_status(info["status"])

    def _take_settings(self, info: dict[str, Any]) -> None:
        self.settings = info["settings"]
        self.caps = info["caps"]
        self.geometry = info["geometry"]

    @property
    def lock(self) -> Any:
        raise TypeError("the rotator's lock is in the control process: steps that must not be split by "
                        "a tick run there (urc.service.remote.in_control_process)")

    def status(self) -> Status:
        s = self._link.status
        assert s is not None
        fault = self._link_fault(s)
        return s if fault is None else dataclasses.replace(s, faults=s.faults + (fault,))

    def _link_fault(self, s: Status) -> Fault | None:
        """A control process that is gone or silent is a fault every client sees (the
        position shown is its last word, not a live reading)."""
        if self._link.lost:
            return Fault("control", None, f"control process gone: {self._link.lost}", s.t_s)
        age_s = self.clock.now_s() - s.t_s
        if age_s > STATUS_STALE_S:
            return Fault("control", None, f"control process silent for {age_s:.1f} s", s.t_s)
        return None

    def run(self, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """``fn(rotator, *args, **kwargs)`` in the control process (see in_control_process)."""
        return self._link.request("run", (fn.__module__, fn.__qualname__), args, kwargs)

    def reconfigure(self, settings: Any) -> None:
        self._link.request("call", ("reconfigure",), (settings,))
        # accepted: the control process applies them at its next tick, as these are
        settings = settings.completed()
        self._take_settings({"settings": settings, "caps": settings.caps, "geometry": settings.geometry()})

    def __getattr__(self, name: str) -> Any:
        from .rotator import Rotator

        if name.startswith("_") or name in self.LOCAL_ONLY or not callable(getattr(Rotator, name, None)):
            raise AttributeError(name)

        def remote_call(*args: Any, **kwargs: Any) -> Any:
            return self._link.request("call", (name,), args, kwargs)
        remote_call.__name__ = name
        return remote_call



def in_control_process(fn: Callable[..., Any]) -> Callable[..., Any]:
    """For ``fn(rotator, ...)``: given a RemoteRotator, the whole call runs in the control
    process on the real rotator (by name: the function must be importable there), so
    steps that hold the rotator's lock stay together, no tick in between, and its
    sensor reads cost no round trips. Arguments and result must be data."""
    @functools.wraps(fn)
    def where_the_rotator_is(rotator: Any, *args: Any, **kwargs: Any) -> Any:
        if isinstance(rotator, RemoteRotator):
            return rotator.run(fn, *args, **kwargs)
        return fn(rotator, *args, **kwargs)
    where_the_rotator_is.in_control_process = True  # type: ignore[attr-defined]
    return where_the_rotator_is


def control_side_function(module: str, qualname: str) -> Callable[..., Any]:
    """The function an ``in_control_process`` call names (nothing else may be run)."""
    fn = _named(module, qualname)
    if not getattr(fn, "in_control_process", False):
        raise AttributeError(f"{module}.{qualname} is not meant to run in the control process")
    return fn
