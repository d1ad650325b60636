"""``urc run``'s control process: the rotator, its hardware and the control loop, nothing else.

(Over 600 lines on purpose: both ends of the one process boundary, the child's serving
and watching and the parent's starting, watching and starting again, read together.)

The I/O process (web, protocol servers, tracker, front panel) starts it with
:class:`ControlProcess` and talks to it through :mod:`.remote`. Why a process of its own
is in that module's docstring; what this one guarantees:

* Every thread here runs at real-time priority when the host allows it (the loop thread
  above the rest), and none of them does heavy work, so a thread that holds Python's
  lock here is never one that the OS has preempted for a busy web server.
* It never waits for the I/O process: statuses go out on a thread of their own, latest
  first, and a slow reader only makes that thread skip statuses.
* The instance locks are shared with the I/O process (inherited descriptors): they stay
  held until both processes are gone, so a new ``urc run`` cannot open the hardware
  while this one still brings the axes to rest.
* Every end stops the axes, waits for standstill (bounded), leaves the outputs safe and
  saves the state: asked to stop, the I/O process gone (its socket closed, even after a
  ``kill -9``), SIGTERM/SIGINT/SIGABRT here, or the loop dying. An I/O process gone with
  a bounded motion in flight is the exception: that motion flies on, and the next
  ``urc run`` takes this process over (urc.link.adoption). An I/O process that goes
  silent (hung, stopped, starved) for ``IO_SILENT_S`` stops only open-ended motion (a
  jog, an update-fed track), said in status' ``last_stop``; a bounded one (a goto, a
  park, a pass program) flies on to its end, since its end was checked when it was
  accepted and the guard holds the limits and zones every tick.
* A tick that hangs (a driver blocked on a bus) holds the rotator's lock: a watch thread
  makes the outputs safe without it, and the main thread, which only keeps watch, still
  ends the process in order on a signal.
* One thread reads the I/O process's messages and runs each command as it reads it: a
  command crosses no thread here (a hand-off between two Python threads costs tens of
  microseconds of a set's round trip, bench/rotctld_bench.py), and commands run in the
  order they were sent. Behind a command that runs long (a save on a slow card, a query
  stuck on a bus) the main thread reads on: the I/O process's writes never block on a
  full socket, its pings still count, and a stop it asks for begins at once.
"""

from __future__ import annotations

import collections
import ctypes
import logging
import os
import select
import signal
import socket
import subprocess
import sys
import threading
import time
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any, Callable

from ..clock import RealClock
from . import codec
from ..model.messages import COMMANDS, Envelope, HardwareInfo, Query, Reconfigure, Reply, Request
from .frames import FrameReader
from .status_record import ColdGeneration, StatusRecord
from . import adoption
from .instance import mark_adoptable, mark_stopping, skip_exit_collection
from ..rotator.loop import ControlThread, WatchdogPing, settle
from ..rotator.queries import handle as handle_query
from .client import (CALL_TIMEOUT_S, ControlLink, ControlUnavailable, exception_from_wire, exception_to_wire,
                     travels)
from .remote import RemoteRotator

log = logging.getLogger(__name__)

#: builds the control process's rotator and its configured settings, from the
#: configuration and the state directory (urc.control_entry.build)
Build = Callable[[Any, Path], tuple[Any, Any]]

#: real-time priority (SCHED_FIFO) of this process's threads; the loop thread raises
#: itself to loop.RT_PRIORITY, above them
PROCESS_RT_PRIORITY = 5
#: how often the I/O process says it is alive (from its event loop: a loop that can no
#: longer serve a STOP is as good as hung)
PING_S = 0.2
#: the I/O process silent this long (hung, stopped, its event loop blocked): open-ended
#: motion (a jog) stops, since no client could stop it any more (issue 20: motors off
#: within 1.5 s); bounded motion flies on (issue 33)
IO_SILENT_S = 1.0
#: how often the main thread looks for a hung tick at least (a hung tick's motors are
#: cut within [faults] watchdog_s plus this; state records reach save_interval_s / 2 of
#: travel, plus the coast, ahead of a moving axis)
WATCH_S = 0.05
#: how long the watch waits for a killed control process to go before it claims the
#: outputs anyway (one stuck in the kernel ignores SIGKILL, and its lines stay held)
KILL_WAIT_S = 2.0
#: after a takeover the control process is started again after this back-off, doubled
#: for each restart within RESTART_WINDOW_S; RESTARTS_MAX of them there: outputs held safe
RESTART_BACKOFF_S = 1.0
RESTART_WINDOW_S = 60.0
RESTARTS_MAX = 3
#: how long building the hardware may take (imports, a bridge's first contact)
START_TIMEOUT_S = 60.0
#: a command running longer than this: the main thread reads the I/O process's messages
#: on behind it (ControlServer._drain_behind), so that the socket never fills
DRAIN_BEHIND_S = 0.5
#: how long a moving command's reply waits for the first state record of its motion
#: (ControlServer._await_first_record): an SD card's write takes up to ~1 s; one slower
#: than this answers ok (the command stands) rather than hold up the client
FIRST_RECORD_WAIT_S = 2.0
#: how long the I/O process waits for an orderly stop: standstill (loop.STANDSTILL_TIMEOUT_S,
#: 8 s), the loop thread's end (5 s), the state save on a slow card (5 s), and more
STOP_TIMEOUT_S = 30.0


# ======================================================================== the child
#: why a control process may end with exit code 0 (the service was asked to stop)
ORDERLY = ("asked to stop", "SIGTERM received", "SIGINT received")
#: why _serve ended when the I/O process died (its socket closed, or PR_SET_PDEATHSIG)
IO_GONE = "the I/O process is gone"


class ControlServer:
    """The control process's main thread only keeps watch (signals, the I/O process gone,
    the loop dead); one thread reads the I/O process's messages and runs each command as it
    reads it, in order (a slow one, a state save on a slow SD card, blinds none of that
    watch); another watches for a hung tick."""

    def __init__(self, conn: Connection, cfg: Any, state_dir: Path, lock_fds: list[int],
                 record: StatusRecord | None = None, build: Build | None = None):
        self.conn = conn
        #: builds the rotator and its configured settings (urc.control_entry.build: the
        #: composition root's, handed in so that the link imports no assembly)
        self.build = build
        #: the shared-memory status record: each tick's count and time, the evidence that
        #: this loop runs which the I/O process reads without a thread (urc.link.status_record)
        self.record = record
        self._ticks = 0
        #: counts the changes of the Status's cold fields: only those go out on the
        #: socket once a record is shared (the hot ones are in the record every tick)
        self._cold = ColdGeneration()
        self._latest_gen = 0
        self.cfg = cfg
        self.state_dir = state_dir
        self.lock_fds = lock_fds
        self._send_lock = threading.Lock()
        self._latest = None
        self._fresh = threading.Event()
        #: the status the I/O process has been sent last, and its cold generation (set under
        #: the send lock)
        self._sent: Any = None
        self._sent_gen: int | None = None
        #: the status whose hot fields the record holds, and its cold generation
        self._recorded: tuple[Any, int] = (None, -1)
        self._closing = False
        self._signal = ""
        #: PR_SET_PDEATHSIG said the I/O process died (its socket's close may come later)
        self._io_gone = False
        #: the I/O process's last message (None: not heard since "ready", as it starts)
        self._heard_s: float | None = None
        #: when the command under way began (None: none is)
        self._command_since_s: float | None = None
        #: held while a command runs: the orderly stop waits for the one under way
        self._running = threading.Lock()
        #: the current connection's reader (its frames) and the messages read, not yet
        #: handled: the reading thread takes them in order; while a command runs long, the
        #: main thread reads on into it (_drain_behind), so the socket never fills
        self._reader: FrameReader | None = None
        self._reader_lock = threading.Lock()
        self._backlog: collections.deque[tuple] = collections.deque()
        #: why the reading thread of the current connection ended ("": it reads)
        self._read_end = ""
        #: when the last tick ended (the loop thread's own clock reading)
        self._ticked_s = time.monotonic()
        #: set when the orderly stop begins: commands still unread are refused
        self._stopping = False
        #: the tick watch acts (until the loop is stopped on purpose, at the very end)
        self._watching = True
        self.rot: Any = None
        self.control: ControlThread | None = None
        #: the settings the configuration gave this rotator (at start, or the last
        #: Reconfigure): a urc run taking it over compares its own with these
        self._config_settings: Any = None

    def send(self, msg: tuple, conn: Connection | None = None) -> None:
        """``msg`` to the I/O process; with ``conn``, only if that is still the one (a
        reply for an I/O process taken over since is dropped: its request ids are not the
        new one's)."""
        data = codec.dumps(msg)
        with self._send_lock:
            if conn is None or conn is self.conn:
                self.conn.send_bytes(data)

    def _send_status(self, status: Any, gen: int | None = None) -> None:
        data = codec.dumps(("status", status, gen))
        with self._send_lock:
            self.conn.send_bytes(data)
            self._sent, self._sent_gen = status, gen

    def _send_reply(self, rid: int, outcome: str, value: Any, status: Any, conn: Connection | None = None) -> None:
        """With the status the command left (a cleared fault shows at once), unless the
        I/O process has been sent that one already: most commands leave the last
        tick's. (A Status is ~1.4 kB of pickle, ~40 us to dump and ~50 us to load: a
        third of a set's round trip.) ``_sent`` is set only once its bytes are on the
        socket, so a status found there is ahead of this reply. With the shared record, a
        tick's status goes on the socket only when its cold fields changed: the I/O
        process has it too when the record holds its hot fields and the socket its cold
        generation (else every reply carried a Status, ~0.3 ms of a set's CPU)."""
        recorded, gen = self._recorded
        known = status is self._sent or (status is recorded and gen == self._sent_gen)
        self.send(("reply", Reply(rid, outcome, value, None if known else status)), conn)

    def _io_alive(self) -> bool:
        return self._heard_s is None or time.monotonic() - self._heard_s < IO_SILENT_S

    # ------------------------------------------------------------- lifetime
    def run(self) -> int:
        assert self.build is not None
        # (SIGABRT: what systemd's watchdog sends by default)
        for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGABRT, signal.SIGUSR1):
            signal.signal(sig, self._on_signal)
        try:
            self.rot, self._config_settings = self.build(self.cfg, self.state_dir)
            # what the calibration queries need (numpy): imported now, not while ticking
            import urc.procedures.calibration  # noqa: F401
        except BaseException as exc:
            log.debug("control process could not start", exc_info=True)
            self.send(("failed", exception_to_wire(exc)))
            return 1
        check_safety_chain(self.rot)
        # systemd's watchdog is fed while the loop is on time and the I/O process talks:
        # a hung web server and protocol ports are a hung service to restart too
        self.control = ControlThread(self.rot, RealClock(), on_tick=self._publish,
                                     watchdog=WatchdogPing(alive=self._io_alive))
        self.control.start()
        try:
            while not self.control.priority:  # (set first thing on the loop thread)
                time.sleep(0.001)
            self.send(("ready", self._ready()))
            # (statuses only after "ready": the first message the I/O process reads is that)
            threading.Thread(target=self._publish_loop, name="urc-status-out", daemon=True).start()
            self._ticked_s = time.monotonic()  # (building the rotator took its time)
            threading.Thread(target=self._watch_ticks, name="urc-tick-watch", daemon=True).start()
            reason = self._serve()
            while reason == IO_GONE and self.record is not None and self.rot.bounded_in_flight():
                reason = self._orphaned()
        except (EOFError, OSError):
            reason = IO_GONE
        except BaseException as exc:  # a bug here must still end in the orderly stop
            log.exception("control process failed")
            reason = f"control process failed: {exc!r}"
        result = self._shutdown(reason)
        self._closing = True
        self._last_word(("stopped", result))
        return 0 if reason in ORDERLY and result["saved"] and not result["error"] else 1

    def _ready(self) -> dict[str, Any]:
        """What the I/O process needs of this rotator (its "ready", and a take-over's)."""
        rot = self.rot
        assert self.control is not None
        return {"pid": os.getpid(), "priority": self.control.priority, "settings": rot.settings,
                "caps": rot.caps, "geometry": rot.geometry, "status": rot.status(),
                "hardware": handle_query(rot, HardwareInfo()), "config_settings": self._config_settings}

    def _on_signal(self, signum: int, _frame: Any) -> None:
        if signum == signal.SIGUSR1:  # (PR_SET_PDEATHSIG: the I/O process died)
            self._io_gone = True
        else:
            self._signal = signal.Signals(signum).name

    def _orphaned(self) -> str:
        """The I/O process died with a bounded motion in flight: fly it on by this
        process's clock, and hand this process over to the next ``urc run`` of this state
        directory (urc.link.adoption); serve that one until it ends too. Once the
        motion has ended and nobody came for ORPHAN_GRACE_S, end (why: IO_GONE)."""
        assert self.control is not None
        assert self.record is not None
        what = self.rot.bounded_in_flight()
        self.rot.stop_open_ended(IO_GONE)
        self.rot.announce(f"{IO_GONE}: the {what} flies on; a new urc run takes this control process over")
        for fd in self.lock_fds:  # (a new urc run asks this process before it waits for the lock)
            mark_adoptable(fd)
        listener = adoption.Listener(self.state_dir)
        settled_s: float | None = None
        try:
            while True:
                if self._signal:
                    return f"{self._signal} received"
                if not self.control.alive:
                    return f"control loop died: {self.control.error!r}"
                conn = listener.accept(4 * WATCH_S)
                if conn is not None:
                    try:
                        outcome, who = adoption.hand_over(conn, adoption.hardware_digest(self.cfg), self._ready(),
                                                          [self.record.fd, *self.lock_fds])
                    except (EOFError, OSError, ValueError) as exc:
                        outcome, who = "failed", f"the hand-over failed: {exc}"
                    if outcome == "taken":
                        with self._send_lock:
                            self.conn = conn
                            self._sent = self._sent_gen = None  # (the new one has heard nothing)
                        self._heard_s, self._io_gone, self._latest_gen = None, False, -1
                        self.rot.announce(f"taken over by {who}: the {what} went on meanwhile")
                        return self._serve()
                    conn.close()
                    log.warning("a take-over was refused: %s", who)
                    if outcome == "other hardware":
                        return f"{IO_GONE}; {who}"
                now_s = time.monotonic()
                if self.rot.bounded_in_flight():
                    settled_s = None
                elif settled_s is None:
                    settled_s = now_s
                elif now_s - settled_s > adoption.ORPHAN_GRACE_S:
                    return IO_GONE
        finally:
            listener.close()

    def _serve(self) -> str:
        """Read the current connection's messages and run its commands (a thread of its
        own: :meth:`_read_and_run`), and watch for signals, the I/O process gone and a dead
        loop until something ends it (a hung tick has its own watch thread); returns why."""
        assert self.control is not None
        self._start_reading()
        while True:
            if self._signal:
                return f"{self._signal} received"
            if self._io_gone:
                return IO_GONE
            if self._read_end:
                return self._read_end
            if not self.control.alive:
                error = repr(self.control.error)
                self._last_word(("died", error))
                return f"control loop died: {error}"
            self._drain_behind()
            time.sleep(WATCH_S)

    def _start_reading(self) -> threading.Thread:
        """The reading thread of the current connection, started."""
        self._read_end = ""
        with self._reader_lock:
            self._reader, self._backlog = FrameReader(self.conn), collections.deque()
        thread = threading.Thread(target=self._read_and_run, args=(self.conn, self._reader, self._backlog),
                                  name="urc-commands", daemon=True)
        thread.start()
        return thread

    def _read_and_run(self, conn: Connection, reader: FrameReader, backlog: collections.deque[tuple]) -> None:
        """Read ``conn`` and run each command as it comes, until the I/O process is gone or
        asks this process to stop (:attr:`_read_end` says which), or another connection
        took its place (a take-over). A silence of IO_SILENT_S with no command under way
        stops open-ended motion, once. A failure here ends the process in order (said as
        such): a process that no longer reads its commands must not run on."""
        silenced = False
        try:
            while conn is self.conn:
                if not backlog:
                    if not reader.wait(WATCH_S):
                        silent_s = time.monotonic() - self._heard_s if self._heard_s is not None else 0.0
                        if silent_s > IO_SILENT_S and not silenced:
                            silenced = True
                            self._stop_for_silence(silent_s)
                        continue
                    with self._reader_lock:
                        arrived = self._arrived(reader)
                    if arrived is None:
                        self._end_reading(conn, IO_GONE)
                        return
                    backlog.extend(arrived)
                    continue
                silenced = False
                msg = backlog.popleft()
                if msg[0] == "stop":
                    self._end_reading(conn, "asked to stop")
                    return
                if msg[0] == "request":
                    self._run_command(msg[1], conn)
        except BaseException as exc:  # (a bug here: this process must not go deaf and run on)
            log.exception("control process: reading the I/O process's messages failed")
            self._end_reading(conn, f"reading the I/O process's messages failed: {exc!r}")
        finally:
            with self._reader_lock:
                reader.close()

    def _arrived(self, reader: FrameReader) -> list[tuple] | None:
        """(Under the reader's lock.) The messages that have arrived, decoded (what is no
        message dropped); [] if none; None once the I/O process is gone."""
        try:
            frames = reader.read() if not reader.closed else None
        except (OSError, ValueError) as exc:  # (a socket failed, bytes that are no frame)
            log.error("control process: the link to the I/O process failed: %s", exc)
            frames = None
        if frames is None:
            return None
        if frames:
            self._heard_s = time.monotonic()
        return [msg for msg in map(self._decoded, frames) if msg is not None]

    def _drain_behind(self) -> None:
        """(The main thread, every WATCH_S.) While a command has run longer than
        DRAIN_BEHIND_S, read on into the backlog: the I/O process's pings and requests
        would otherwise fill the socket, and its next write would block its event loop;
        its pings say it is alive (systemd's watchdog); a stop it asks for begins at once
        (the orderly stop then waits for the command under way, CALL_TIMEOUT_S at most)."""
        since_s = self._command_since_s
        if since_s is None or time.monotonic() - since_s < DRAIN_BEHIND_S:
            return
        if not self._reader_lock.acquire(blocking=False):
            return
        try:
            reader = self._reader
            if reader is None or reader.closed or not reader.wait(0.0):
                return
            for msg in self._arrived(reader) or ():  # (the I/O process gone: the reading thread finds it so too)
                if msg[0] == "stop":
                    self._read_end = "asked to stop"
                elif msg[0] == "request":
                    self._backlog.append(msg)
        finally:
            self._reader_lock.release()

    @staticmethod
    def _decoded(data: bytes) -> tuple | None:
        """A message from the I/O process, or None (logged) for one the codec refuses or
        that is no message of ours: dropped, and on."""
        try:
            msg = codec.loads(data)
        except BaseException:  # (whatever the decoder raised)
            log.exception("control process: unreadable message from the I/O process, ignored")
            return None
        if not (isinstance(msg, tuple) and msg and isinstance(msg[0], str)):
            log.error("control process: %r is no message, ignored", type(msg).__name__)
            return None
        if msg[0] == "request" and not (len(msg) == 2 and isinstance(msg[1], Envelope)):
            log.error("control process: a request without its envelope, ignored")
            return None
        return msg

    def _end_reading(self, conn: Connection, why: str) -> None:
        if conn is self.conn:  # (a connection taken over since is not ended by its old one)
            self._read_end = why

    def _run_command(self, env: Envelope, conn: Connection) -> None:
        with self._running:
            self._command_since_s = time.monotonic()
            try:
                if self._stopping:
                    self._reply_error(env.rid, ControlUnavailable("the control process is stopping: nothing was done"),
                                      conn)
                else:
                    self._answer(env, conn)
            except OSError:  # (the I/O process is gone: its reply with it; a new one may come)
                pass
            except Exception as exc:  # (this thread must outlive any one command)
                log.exception("command %r failed", env)
                try:
                    self._reply_error(env.rid, exc, conn)
                except OSError:
                    pass
            finally:
                self._command_since_s = None

    def _watch_ticks(self) -> None:
        """A tick that hangs (in a driver, on a bus) holds the rotator's lock and the loop:
        from here, for the whole life of the process (an orderly stop included), the
        outputs go safe without either once no tick has ended for watchdog_s."""
        hung = False
        while True:
            time.sleep(WATCH_S)
            late_s = time.monotonic() - self._ticked_s
            if late_s <= self.rot.settings.watchdog_s:
                hung = False
            elif not hung and self._watching:
                hung = True
                try:
                    self.rot.hw.drive_safe()
                    log.critical("control loop: no tick for %.1f s (a hung tick): outputs made safe", late_s)
                except Exception:  # (each write is tried; this thread must go on watching)
                    log.exception("making the outputs safe after a hung tick failed")

    def _reply_error(self, rid: int, exc: BaseException, conn: Connection | None = None) -> None:
        self.send(("reply", Reply(rid, "error", exception_to_wire(exc), None)), conn)

    def _stop_for_silence(self, silent_s: float) -> None:
        """Only what a live client must end stops (a jog, an update-fed track); a goto,
        a park or a pass program flies on to its end (issue 33: a paused I/O process
        left accepted gotos half-way, silently idle)."""
        try:
            self.rot.stop_open_ended(f"the I/O process (web, protocols, tracker) was silent for {silent_s:.1f} s")
        except Exception:
            log.exception("stop after the I/O process went silent failed")

    def _answer(self, env: Envelope, conn: Connection | None = None) -> None:
        if env.deadline_s is not None and time.monotonic() > env.deadline_s:
            # its caller was told "no answer, nothing done" already: keep that true
            self._reply_error(env.rid, ControlUnavailable(
                f"{type(env.request).__name__} arrived after its deadline (this process was held up): "
                "nothing was done"), conn)
            return
        try:
            try:
                value = self._run(env.request)
            finally:  # (a moving command whose reply waits for its first state record)
                ticket = self.rot.motion_ticket()
            if not travels(value):  # (behaviour stays here: a handler's bug, said as such)
                raise TypeError(f"{type(env.request).__name__} returned {type(value).__name__}, "
                                "which cannot leave the control process")
            outcome = "value"
            if isinstance(env.request, Reconfigure):
                self._config_settings = env.request.settings
            if ticket is not None:
                self.rot.confirm_motion_record(ticket, FIRST_RECORD_WAIT_S)
        except Exception as exc:
            outcome, value = "error", exception_to_wire(exc)
        self._send_reply(env.rid, outcome, value, self.rot.status(), conn)

    def _run(self, request: Request) -> Any:
        """Each request type runs what COMMANDS names for it, each query its handler
        (urc.rotator.queries.HANDLERS); nothing else can run."""
        if isinstance(request, Query):
            return handle_query(self.rot, request)
        method = COMMANDS.get(type(request))
        if method is None:
            raise TypeError(f"{type(request).__name__} is not a request the control process runs")
        return getattr(self.rot, method)(**request.arguments())

    def _last_word(self, msg: tuple, timeout_s: float = 2.0) -> None:
        """Tell the I/O process, unless it cannot hear (hung with its socket full): this
        process must end all the same."""
        if not self._send_lock.acquire(timeout=timeout_s):
            return
        try:
            if select.select([], [self.conn.fileno()], [], timeout_s)[1]:
                self.conn.send_bytes(codec.dumps(msg))
        except (OSError, ValueError):
            pass
        finally:
            self._send_lock.release()

    def _shutdown(self, reason: str) -> dict[str, Any]:
        """Axes to rest, outputs safe, state saved: every way this process ends."""
        assert self.control is not None
        log.info("control process stopping: %s", reason)
        if reason.startswith(IO_GONE):
            for fd in self.lock_fds:  # a new urc waits for this one instead of failing
                mark_stopping(fd)
        self._stopping = True  # (commands still unread are refused, none runs after this)
        if self._running.acquire(timeout=CALL_TIMEOUT_S):  # (the one under way ends first)
            self._running.release()
        # a hung tick holds the lock that the stop command needs (the watch thread has made
        # the outputs safe): no waiting for it
        settled = False
        if self.control.alive and self.rot.lock.acquire(timeout=2 * self.rot.settings.watchdog_s):
            self.rot.lock.release()
            settled = settle(self.rot)
        self._watching = False
        self.control.stop()
        result: dict[str, Any] = {"reason": reason, "settled": settled, "hung": False,
                                  "error": None if self.control.error is None else repr(self.control.error)}
        if self.control.alive:
            # a tick hangs (in the hardware) and holds the rotator: outputs safe without it
            self.rot.hw.drive_safe()
            result.update(saved=False, hung=True)
        else:
            result["saved"] = self.rot.shutdown(save=True)
        try:
            self.rot.hw.close()
        except Exception:  # (the outputs are safe and the state saved already)
            log.exception("closing the hardware failed")
        return result

    # ------------------------------------------------------------- statuses
    def _publish(self, status: Any) -> None:
        """On the loop thread after each tick: hand over, never wait."""
        self._ticked_s = time.monotonic()
        if self.record is not None:
            self._ticks += 1
            gen = self._cold.update(status)
            try:
                self.record.write(status, self._ticks, gen)
            except ValueError:  # (a mode the record has no code for: a bug, said once)
                log.exception("the status record cannot hold this status: every status on the socket")
                self.record = None
            else:
                self._recorded = (status, gen)
                if gen == self._latest_gen:
                    return  # (nothing the record lacks: no pickle, no socket)
                self._latest_gen = gen
        self._latest = status
        self._fresh.set()

    def _publish_loop(self) -> None:
        while not self._closing:
            if not self._fresh.wait(0.5):
                continue
            self._fresh.clear()
            try:
                self._send_status(self._latest, self._latest_gen if self.record is not None else None)
            except OSError:  # (the I/O process is gone; a new one may take this process over)
                self._fresh.set()
                time.sleep(4 * WATCH_S)
            except Exception:  # (a status that cannot be sent: the next one may; replies rely on these)
                log.exception("publishing a status failed")


def check_safety_chain(rot: Any) -> None:
    """Before the first tick (the heartbeat still, the motors off): does the external
    safety chain cut when the heartbeat stops? Only where its output is read back
    (``motor_enable_sense_pin``); a chain that does not cut latches a fault, so nothing
    drives until a person has mended it (issue 35)."""
    hw = rot.hw
    if getattr(hw, "motor_enable_timeout_s", None) is None or getattr(hw, "enable_sense", None) is None:
        return
    from ..hardware.safety_test import self_test

    for _attempt in (1, 2):  # (once more before a fault: a stall of this process in the test)
        try:
            result = self_test(hw, hw.motor_enable_timeout_s, clock=RealClock())
        except Exception as exc:  # (a read-back that cannot be read: no proof that it cuts)
            log.exception("the safety chain's self-test failed to run")
            rot.safety_chain_failed(f"safety chain self-test could not run: {exc}")
            return
        log.info("%s", result.line())
        if result.ok is not False:
            return
    rot.safety_chain_failed(result.line())


def _die_with_parent() -> None:
    """SIGUSR1 if the I/O process dies, even when it is killed before its socket's close
    is seen (Linux prctl PR_SET_PDEATHSIG): said as the I/O process gone (an orderly stop,
    or a bounded motion flown on to be taken over; SIGTERM would be a stop only)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGUSR1)
    except (OSError, AttributeError):
        pass


def _realtime() -> str:
    """SCHED_FIFO for this thread, inherited by every thread it starts (needs root or
    CAP_SYS_NICE, which the systemd unit has)."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(PROCESS_RT_PRIORITY))
        return f"SCHED_FIFO {PROCESS_RT_PRIORITY}"
    except (AttributeError, OSError):
        return "normal"


def main(argv: list[str], build: Build) -> int:
    conn = Connection(int(argv[0]))
    _die_with_parent()
    if os.getppid() != int(argv[1]):  # the I/O process died before the line above
        return 1
    kind, cfg, state_dir, lock_fds, log_level = codec.loads(conn.recv_bytes())
    logging.basicConfig(level=log_level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    log.debug("control process: %s priority for its threads", _realtime())
    record = StatusRecord.attach(int(argv[2])) if len(argv) > 2 else None
    try:
        return ControlServer(conn, cfg, Path(state_dir), lock_fds, record, build).run()
    finally:
        skip_exit_collection()


# ======================================================================== the parent
class ControlProcess:
    """The I/O process's handle on the control process: start it, use its rotator, stop it."""

    def __init__(self, cfg: Any, state_dir: Path, lock_fds: list[int],
                 on_lost: Callable[[str], None] | None = None, loop: Any = None):
        self.cfg = cfg
        #: the event loop that reads the link (``urc run``'s); None: a reader thread does
        self.loop = loop
        self.state_dir = state_dir
        self.lock_fds = lock_fds
        self.on_lost = on_lost
        self.proc: subprocess.Popen | None = None
        self.link: ControlLink | None = None
        self._conn: Connection | None = None
        #: set when the orderly stop begins (a silent process is then not a frozen one)
        self.stopping = threading.Event()
        #: why the I/O process took the outputs over ("" if it did not, or the control
        #: process it started again runs)
        self.taken_over = ""
        self._watcher: threading.Thread | None = None
        self._restarts: list[float] = []
        #: the rotator handed out (a restart gives it the new process's link)
        self.rotator: RemoteRotator | None = None
        #: the outputs this process holds safe after a takeover (None: it holds none)
        self.held: Any = None
        #: the status record the control process writes every tick (urc.link.status_record)
        self.record: StatusRecord | None = None
        #: a taken-over process's "ready" (urc.link.adoption), until wait_ready reads it
        self._adopted_ready: dict[str, Any] | None = None

    def start(self, timeout_s: float = START_TIMEOUT_S) -> RemoteRotator:
        """Spawn it and wait until its rotator is built (its start-up errors are raised
        here, as building the rotator in this process raised them)."""
        self.spawn()
        return self.wait_ready(timeout_s)

    def spawn(self) -> None:
        """Start the process and hand it its configuration; it imports and builds the
        rotator while the caller goes on (``urc run`` imports its web stack meanwhile:
        on two cores the two starts overlap)."""
        ours, theirs = socket.socketpair()
        # a fresh record per process (its ticks count from 0); the last one stays with the
        # lost link that still reads it (its last word), and goes with it
        self.record = StatusRecord.create()
        try:
            # a fresh interpreter, not a fork: this process may already run threads
            self.proc = subprocess.Popen([sys.executable, "-m", "urc.control_entry", str(theirs.fileno()),
                                          str(os.getpid()), str(self.record.fd)],
                                         pass_fds=(theirs.fileno(), self.record.fd, *self.lock_fds),
                                         start_new_session=True)
        finally:
            theirs.close()
        self._conn = Connection(ours.detach())
        self._conn.send_bytes(codec.dumps(("init", self.cfg, str(self.state_dir), self.lock_fds,
                                           logging.getLogger().getEffectiveLevel())))

    def adopt(self, adopted: adoption.Adopted) -> None:
        """Take over a control process whose I/O process died mid-flight (instead of
        :meth:`spawn`; :meth:`wait_ready` then returns its rotator at once)."""
        self.proc = _Foreign(adopted.pid)  # type: ignore[assignment]
        self.record = StatusRecord.attach(adopted.record_fd)
        self._conn = adopted.conn
        self._adopted_ready = adopted.ready

    def wait_ready(self, timeout_s: float = START_TIMEOUT_S) -> RemoteRotator:
        """Wait for the spawned process's rotator (its start-up errors are raised here);
        a process that failed or did not answer in time is gone when this raises."""
        conn, proc = self._conn, self.proc
        assert conn is not None and proc is not None, "spawn() first"
        if self._adopted_ready is not None:
            payload, self._adopted_ready = self._adopted_ready, None
            return self._link_up(conn, payload)
        try:
            if not conn.poll(timeout_s):
                raise ControlUnavailable(f"the control process did not start within {timeout_s:g} s")
            kind, payload = codec.loads(conn.recv_bytes())
        except (EOFError, OSError):
            code = proc.wait(5)
            raise ControlUnavailable(f"the control process exited while starting (exit code {code})") from None
        except BaseException:
            self.abandon()
            raise
        if kind == "failed":
            proc.wait(5)
            conn.close()
            raise exception_from_wire(payload)
        return self._link_up(conn, payload)

    def _link_up(self, conn: Connection, payload: dict[str, Any]) -> RemoteRotator:
        self.link = ControlLink(conn, self.on_lost, self.record).start(self.loop)
        remote = RemoteRotator(self.link, payload)
        if self.rotator is None:
            self.rotator = remote
        return remote

    def abandon(self) -> None:
        """A spawned process that will not be used (its starter failed first): killed."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        if self._conn is not None:
            self._conn.close()

    def ping(self) -> None:
        assert self.link is not None
        if not self.link.lost:
            try:
                self.link.send(("ping",))
            except OSError:
                pass

    def watch(self, takeover_s: float, hold_outputs: Callable[[], Any],
              on_event: Callable[[str], None] = lambda text: None) -> None:
        """Supervise the control process from a thread of its own (the event loop may be
        what is stuck). Once it is gone, or frozen for ``takeover_s`` by evidence a starved
        I/O process cannot fake (:meth:`progress`), kill it so its outputs are free, hold
        them safe from here (``hold_outputs()``: an object with ``close``), and start it
        again with back-off; after RESTARTS_MAX restarts within RESTART_WINDOW_S the
        outputs stay held safe until ``urc run`` ends. Clients keep their connections
        meanwhile (their protocol's error: the rotator's link is down). Layer 2 of the
        safety chain, and what keeps a station on the air after it (issue 33)."""
        if takeover_s <= 0:
            return

        def run() -> None:
            while True:
                why = self._watch_once(takeover_s)
                if not why:
                    return  # an orderly stop
                self.taken_over = why
                held = None
                try:
                    held = self.held = hold_outputs()
                    failed = getattr(held, "failed", [])
                    on_event(f"{why}: killed it; " + ("every output driven safe by the I/O process" if not failed
                             else "NOT made safe: " + "; ".join(f"{what} ({err})" for what, err in failed)))
                except Exception as exc:
                    log.exception("taking the outputs over failed")
                    on_event(f"{why}: killed it; taking the outputs over failed: {exc}")
                if not self._restart(held, on_event):
                    return

        self._watcher = threading.Thread(target=run, name="urc-control-watch", daemon=True)
        self._watcher.start()

    def progress(self) -> tuple[Any, str]:
        """Evidence that the control process runs which no thread of this process has to
        have read in time (a starved one is no evidence): its tick counter in the shared
        status record, else (no record yet: it starts) its CPU time in ns from the kernel
        (/proc/PID/schedstat: a ticking loop burns some every tick, a stopped or
        deadlocked one none); and the kernel's state of it (T: stopped)."""
        assert self.proc is not None
        pid = self.proc.pid
        try:
            with open(f"/proc/{pid}/stat", "rb") as f:
                state = f.read().rsplit(b")", 1)[1].split()[0].decode()
        except (OSError, IndexError):
            return None, "?"  # (gone: the link says so)
        live = self.record.liveness() if self.record is not None else None
        if live is not None and live[0] > 0:
            return ("tick", live[0]), state
        try:
            with open(f"/proc/{pid}/schedstat", "rb") as f:
                return ("cpu", int(f.read().split()[0])), state
        except (OSError, IndexError, ValueError):
            return None, state

    def _watch_once(self, takeover_s: float) -> str:
        """Watch until the control process is lost or frozen (why), or an orderly stop ("")."""
        assert self.link is not None and self.proc is not None
        link = self.link
        awake_since_s = last_s = progress_s = time.monotonic()
        last_cpu, _ = self.progress()
        while True:
            stopping = self.stopping.wait(WATCH_S)
            now_s = time.monotonic()
            if now_s - last_s > WATCH_S + 0.25:  # this process was held up itself (SIGSTOP,
                awake_since_s = now_s            # swapped out): judge only what it saw
            last_s = now_s
            exited = self.proc.poll() is not None  # (the link's reader, the event loop, may be what is stuck)
            if link.lost or exited:
                try:  # (a loop that died still stops in order, saves and says so)
                    self.proc.wait(5.0)
                except subprocess.TimeoutExpired:
                    pass
                if stopping or self.stopping.is_set():
                    return ""
                why = link.lost or f"exit code {self.proc.returncode}"
                return f"the control process ended ({why})" if link.final is not None else \
                    f"the control process died ({why})"
            if stopping:
                return ""  # (an orderly stop: silence now is that stop)
            cpu, state = self.progress()
            if cpu != last_cpu and state not in ("T", "t"):
                last_cpu, progress_s = cpu, now_s
            live = link.record.liveness() if link.record is not None else None
            status = link.status
            t_s = live[1] if live is not None and live[0] > 0 else (status.t_s if status is not None else now_s)
            age_s = now_s - t_s
            # frozen: no status AND no tick (no CPU time) for takeover_s, all of it seen awake
            still_s = min(age_s, now_s - progress_s, now_s - awake_since_s)
            if still_s > takeover_s:
                return f"the control process froze (no tick for {still_s:.1f} s, process state {state})"

    def _restart(self, held: Any, on_event: Callable[[str], None]) -> bool:
        """Kill what is left, wait the back-off with the outputs held safe, then start a
        new control process and hand it the rotator's link. False: given up (too many
        restarts, or an orderly stop began)."""
        assert self.proc is not None
        self.proc.kill()  # (a stopped process dies too: its lines are free after this)
        try:  # (one stuck in the kernel, D state, ignores SIGKILL: take what is free)
            self.proc.wait(KILL_WAIT_S)
        except subprocess.TimeoutExpired:
            log.error("the control process did not die within %.0f s of SIGKILL (stuck in the kernel?)",
                      KILL_WAIT_S)
        while True:
            now_s = time.monotonic()
            self._restarts = [t for t in self._restarts if now_s - t < RESTART_WINDOW_S]
            if len(self._restarts) >= RESTARTS_MAX:
                on_event(f"the control process failed {len(self._restarts) + 1} times within "
                         f"{RESTART_WINDOW_S:g} s: outputs held safe until urc run ends (restart it)")
                return False
            backoff_s = RESTART_BACKOFF_S * 2 ** len(self._restarts)
            if self.stopping.wait(backoff_s):
                return False
            self._restarts.append(time.monotonic())
            if held is not None:
                self.release_outputs()
                held = None
            try:
                self.spawn()
                remote = self.wait_ready()
            except Exception as exc:
                log.error("restarting the control process failed: %s", exc)
                on_event(f"restarting the control process failed: {exc}")
                continue
            if self.rotator is not None:
                self.rotator.rebind(remote)
            text = (f"control process started again (process {self.proc.pid}) after: {self.taken_over}; position "
                    + ("known" if remote.status().position_known else "uncertain: re-reference"))
            try:  # (an absolute sensor: the goto or park under way goes on)
                resumed = self.rotator.resume_bounded() if self.rotator is not None else ""
            except Exception as exc:
                resumed = ""
                log.warning("resuming the command under way failed: %s", exc)
            if resumed:
                text += f"; the {resumed} under way resumed"
            on_event(text)
            try:  # (in its status' events too, for every client)
                remote.announce(text)
            except Exception:
                log.exception("announcing the restart failed")
            self.taken_over = ""
            return True

    def release_outputs(self) -> None:
        """Let go of the outputs held safe since a takeover (the end of ``urc run``, or a
        new control process about to claim them)."""
        held, self.held = self.held, None
        if held is not None:
            try:
                held.close()
            except Exception:
                log.exception("letting go of the held outputs failed")

    def stop(self, timeout_s: float = STOP_TIMEOUT_S) -> dict[str, Any]:
        """Ask for an orderly stop and wait for it; returns how it ended."""
        assert self.proc is not None and self.link is not None
        self.stopping.set()
        if self._watcher is not None:  # (it decides whether a dead process is taken over)
            self._watcher.join(10.0)
        if self.taken_over:
            return {"reason": self.taken_over, "settled": False, "hung": False, "saved": False,
                    "error": self.taken_over, "exit_code": self.proc.wait()}
        try:
            self.link.send(("stop",))  # (also after a broken link: the socket may still carry it)
        except OSError:
            pass
        give_up_s = time.monotonic() + timeout_s
        self.link.finished.wait(timeout_s)
        try:
            code = self.proc.wait(max(5.0, give_up_s - time.monotonic()))
        except subprocess.TimeoutExpired:
            self.proc.terminate()  # its orderly stop once more, on SIGTERM
            try:
                code = self.proc.wait(10.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()  # (its own exit paths failed: the heartbeat stops with it)
                code = self.proc.wait()
        final = self.link.final or {"saved": False, "settled": False, "hung": False, "reason": self.link.lost,
                                     "error": f"the control process ended without a word ({self.link.lost})"}
        return {**final, "exit_code": code}


class _Foreign:
    """A control process taken over from a dead I/O process (urc.link.adoption): not
    this process's child, so it is watched through a pidfd (Linux 5.3) rather than
    waited for; what the watch and the stop use of subprocess.Popen."""

    returncode: int | None = None

    def __init__(self, pid: int):
        self.pid = pid
        self._fd = os.pidfd_open(pid)

    def poll(self) -> int | None:
        if self.returncode is None and select.select([self._fd], [], [], 0)[0]:
            self.returncode = 0  # (its exit code went to its real parent)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        if self.returncode is None and not select.select([self._fd], [], [], timeout)[0]:
            raise subprocess.TimeoutExpired(f"process {self.pid}", timeout or 0.0)
        self.returncode = 0
        return 0

    def _signal(self, sig: int) -> None:
        if self.poll() is None:
            signal.pidfd_send_signal(self._fd, sig)

    def kill(self) -> None:
        self._signal(signal.SIGKILL)

    def terminate(self) -> None:
        self._signal(signal.SIGTERM)
