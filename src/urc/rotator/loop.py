"""Running the rotator's tick: in real time (its own thread) or on a virtual clock (tests, bench).

The real-time loop runs on a thread of its own with absolute deadlines. In ``urc run``
that thread lives in the control process (:mod:`.control_process`), apart from the
process that serves the network: Python's lock is shared by the threads of one process,
and a busy event-loop thread preempted by the OS while holding it delayed ticks by
10-19 ms (bench/loop_bench.py). The few threads beside the loop there run short
Python code; ``sys.setswitchinterval`` is shortened so that they give the loop its turn
within ``SWITCH_INTERVAL_S``. A late loop never runs catch-up ticks: it
resumes on the next deadline. Every exit path of the thread leaves the outputs safe.
"""

from __future__ import annotations

import logging
import math
import os
import sys
import threading
import time
from typing import TYPE_CHECKING, Callable

from ..clock import Clock, VirtualClock
from .rotator import Rotator
from ..model.snapshot import AxisStatus, Status

if TYPE_CHECKING:
    import asyncio

log = logging.getLogger(__name__)

#: how long another thread may run Python code before the loop thread gets the GIL
#: back (CPython's default is 5 ms: a whole tick's budget at 200 Hz)
SWITCH_INTERVAL_S = 0.0005
#: real-time priority (SCHED_FIFO, Linux) asked for the loop thread: low among real-time
#: tasks, above every normal one, so a busy host does not delay its wake-ups
RT_PRIORITY = 10
#: how long an orderly stop waits for the axes to come to rest before saving anyway
#: (saved as moving then: the restart widens its bound)
STANDSTILL_TIMEOUT_S = 8.0


def next_deadline_s(deadline_s: float, period_s: float, now_s: float) -> float:
    """The first deadline after ``deadline_s`` that is still ahead of ``now_s``: a late
    loop skips the periods it missed instead of running them as a burst."""
    nxt = deadline_s + period_s
    if nxt <= now_s:
        nxt += math.floor((now_s - nxt) / period_s + 1.0) * period_s
    return nxt


class WatchdogPing:
    """systemd's service watchdog (``WatchdogSec`` in the unit, sd_notify ``WATCHDOG=1``):
    pinged from the control loop only while its ticks are on time, so a hung or stalled
    loop gets the service killed and restarted (the heartbeat output cuts the motors)."""

    def __init__(self, notify: Callable[[str], None] | None = None, interval_s: float | None = None,
                 alive: Callable[[], bool] = lambda: True):
        if notify is None:
            notify = sd_notifier()
        self.notify = notify
        #: what else must be well for a ping (the control process: its I/O process talks)
        self.alive = alive
        usec = os.environ.get("WATCHDOG_USEC")
        self.interval_s = interval_s if interval_s is not None else \
            (int(usec) / 1e6 / 4 if usec and usec.isdigit() and int(usec) > 0 else 1.0)
        self._last_s = -math.inf

    def tick(self, on_time: bool) -> None:
        now = time.monotonic()
        if on_time and now - self._last_s >= self.interval_s and self.alive():
            self._last_s = now
            self.notify("WATCHDOG=1")


def sd_notifier() -> Callable[[str], None]:
    """sd_notify through $NOTIFY_SOCKET (a no-op when not started by systemd)."""
    if not os.environ.get("NOTIFY_SOCKET"):
        return lambda _state: None
    import sdnotify

    return sdnotify.SystemdNotifier().notify


class ControlThread:
    """The control loop on its own thread: ``tick`` at every absolute deadline until
    :meth:`stop`. ``on_tick(status)`` runs on the loop thread after each tick (keep it
    short: the systemd ping); anything slow belongs on the event loop."""

    def __init__(self, rotator: Rotator, clock: Clock, on_tick: Callable[[Status], None] | None = None,
                 watchdog: WatchdogPing | None = None, on_exit: Callable[[BaseException | None], None] | None = None):
        self.rot = rotator
        self.clock = clock
        self.on_tick = on_tick
        self.watchdog = watchdog
        self.on_exit = on_exit
        self.error: BaseException | None = None
        self.priority = ""
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="urc-control", daemon=True)

    def start(self) -> "ControlThread":
        if sys.getswitchinterval() > SWITCH_INTERVAL_S:
            sys.setswitchinterval(SWITCH_INTERVAL_S)
        self._thread.start()
        return self

    def stop(self, timeout_s: float = 5.0) -> None:
        self._stop.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout_s)

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def _raise_priority(self) -> str:
        """Ask for real-time scheduling for this thread, else a better nice value (needs
        root or CAP_SYS_NICE: the systemd unit runs as root); returns what was granted."""
        tid = threading.get_native_id()
        try:
            os.sched_setscheduler(tid, os.SCHED_FIFO, os.sched_param(RT_PRIORITY))
            return f"real-time (SCHED_FIFO {RT_PRIORITY})"
        except (AttributeError, OSError):
            pass
        try:
            os.setpriority(os.PRIO_PROCESS, tid, -10)
            return "nice -10"
        except (AttributeError, OSError):
            return "normal"

    def _run(self) -> None:
        self.priority = self._raise_priority()
        log.info("control loop thread: %s priority", self.priority)
        rot, clock = self.rot, self.clock
        period_s = 1.0 / rot.caps.loop_hz
        deadline_s = clock.now_s()
        try:
            while not self._stop.is_set():
                wait_s = deadline_s - clock.now_s()
                if wait_s > 0 and self._stop.wait(wait_s):
                    break
                status = rot.tick(deadline_s)
                if self.watchdog is not None:
                    self.watchdog.tick(not status.loop.get("held") and not any(
                        f.kind == "watchdog" for f in status.faults))
                if self.on_tick is not None:
                    self.on_tick(status)
                deadline_s = next_deadline_s(deadline_s, period_s, clock.now_s())
        except BaseException as exc:
            self.error = exc
            log.critical("control loop died: %r", exc, exc_info=True)
        finally:
            if self.error is not None:
                # motors off and brakes on at once, whatever state the rotator is in
                rot.hw.drive_safe()
            if self.on_exit is not None:
                self.on_exit(self.error)


def settle(rotator: Rotator, timeout_s: float = STANDSTILL_TIMEOUT_S, poll_s: float = 0.02) -> bool:
    """Stop both axes and wait (bounded) until they stand still, while the loop keeps
    ticking on its own thread. True if they were seen to come to rest; False if not in
    ``timeout_s``, or as soon as the only axes not at rest have dead sensors: their
    standstill can never be seen (their fault has cut their outputs already), so they are
    saved as moving (a bridged controller answering garbage held every stop for the
    whole timeout)."""
    try:
        rotator.stop()
    except Exception:  # the stop command itself may be refused (uncertain position...)
        log.exception("stop before shutdown failed")
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        time.sleep(poll_s)
        s = rotator.status()
        if s.moving:  # (an axis whose sensor is dead never counts as moving)
            continue
        unseen = [name for name in s.axes if not _at_rest(getattr(s, name))]
        if not unseen:
            return True
        if all(_sensor_dead(s, name) for name in unseen):
            log.warning("stop: %s not seen to come to rest (position sensor unreadable)", " and ".join(unseen))
            return False
    return False


def _at_rest(axis: AxisStatus) -> bool:
    return axis.mode in ("idle", "holding")


def _sensor_dead(s: Status, axis: str) -> bool:
    """As the rotator judges it (Core.sensor_dead): unreadable now, and latched as such."""
    return not getattr(s, axis).sensor_ok and any(f.kind == "sensor_dead" and f.axis == axis for f in s.faults)


async def run_realtime(rotator: Rotator, clock: Clock, stop: asyncio.Event,
                       on_tick: Callable[[float], None] | None = None) -> None:
    """Run the control thread until ``stop`` is set (for embedding in an event loop).
    ``on_tick(now_s)`` runs on the event loop after ticks (the tracker feeding setpoints),
    coalesced: a slow one delays the next call, never a tick."""
    import asyncio  # (lazy: the control process runs no event loop and never loads asyncio)

    loop = asyncio.get_running_loop()
    pending = threading.Event()

    def call_tracker() -> None:
        pending.clear()
        try:
            on_tick(rotator.status().t_s)
        except Exception:
            log.exception("after-tick step failed")

    def after_tick(_status: Status) -> None:
        if on_tick is not None and not pending.is_set():
            pending.set()
            loop.call_soon_threadsafe(call_tracker)
    control = ControlThread(rotator, clock, after_tick, on_exit=lambda _e: loop.call_soon_threadsafe(stop.set))
    control.start()
    try:
        await stop.wait()
    finally:
        control.stop()
    if control.error is not None:
        raise control.error


def run_virtual(rotator: Rotator, clock: VirtualClock, duration_s: float,
                on_tick: Callable[[Status], None] | None = None,
                until: Callable[[Status], bool] | None = None) -> Status:
    """Advance virtual time by ``duration_s`` in control periods, ticking each time.

    Stops early when ``until(status)`` is true. Returns the last status.
    """
    period_s = 1.0 / rotator.caps.loop_hz
    status = rotator.status()
    for _ in range(max(1, round(duration_s / period_s))):
        clock.advance(period_s)
        status = rotator.tick()
        if on_tick is not None:
            on_tick(status)
        if until is not None and until(status):
            break
    return status
