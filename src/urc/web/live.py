"""The live feed: one sampler task turns rotator snapshots into WebSocket frames.

Each frame is built and serialised once and handed to every open dashboard (latest
wins: a slow client skips frames instead of queueing them). A frame carries what changes
every tick; the parts that change seldom (the pass plan and ground track, the event log)
are sent as their own messages, to each dashboard only when they changed (``PARTS``),
before the first frame that needs them (while tracking, 18 KiB frames became 1.4 KiB:
``bench/web_bench.py --tracking-only``). The same task records the chart history, runs
a calibration procedure's steps and expires jog leases, so a dashboard that vanishes
mid-jog (closed tab, lost network) stops the antenna.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
import time
from dataclasses import dataclass
from typing import Any

from starlette.websockets import WebSocket, WebSocketDisconnect, WebSocketState

from ..errors import CommandRejected
from ..model.messages import Move, Stop
from ..model.effects import call
from ..tracking.cycle import cycle_state, tracking_now
from .history import History, pointing_error_deg

log = logging.getLogger(__name__)

#: frames per second sent to dashboards (the page asks for >= 5)
FRAME_HZ = 10.0
#: a jog stops unless the page renews it within this time (press-and-hold dead man)
JOG_LEASE_S = 0.6
#: the tracker's status (ground track, plan) is recomputed at most this often
TRACKING_REFRESH_S = 1.0
#: seldom-changing parts sent apart from the frames: message type -> (section, keys)
#: (the plan changes with the pass; the ground track every 10 s as its window moves)
PARTS = {"plan": ("tracking", ("plan",)), "ground": ("tracking", ("ground_track",)),
         "events": (None, ("events",))}


@dataclass
class JogLease:
    direction: int
    speed: float
    expires_s: float


class Hub:
    def __init__(self, rotator: Any, tracker: Any = None, frame_hz: float = FRAME_HZ):
        self.rotator = rotator
        self.tracker = tracker
        self.period_s = 1.0 / frame_hz
        self.history = History()
        self.procedure: Any = None
        self.jogs: dict[str, JogLease] = {}
        self.seq = 0
        self.frame_text = ""
        #: message type -> (revision, value, serialised message); see PARTS
        self.parts: dict[str, tuple[int, Any, str]] = {}
        self.info_rev = 0
        self._settings_seen: Any = None
        self.clients = 0
        self._waiters: set[asyncio.Future] = set()
        self._task: asyncio.Task | None = None
        self._proc_task: asyncio.Task | None = None
        #: held while a procedure's step runs on a thread: one step at a time
        self._proc_lock = asyncio.Lock()
        self._tracking: dict | None = None
        self._tracking_t = -math.inf
        self._tracking_busy = False

    # ------------------------------------------------------------------ snapshots
    def _tracker_status(self) -> dict | None:
        status = getattr(self.tracker, "status", None)
        if status is None:
            return None
        try:
            return status()
        except Exception:  # a tracker bug must not take the dashboard down
            log.exception("tracker status failed")
            return None

    def refresh_tracking_now(self) -> None:
        self._tracking = self._tracker_status()
        self._tracking_t = time.monotonic()

    async def refresh_tracking(self) -> None:
        """After a tracking command: the page should see the new target at once (computed
        in a worker thread, like the periodic refresh)."""
        self._tracking = await asyncio.to_thread(self._tracker_status)
        self._tracking_t = time.monotonic()

    def tracking(self) -> dict | None:
        """The tracker's status, refreshed when TRACKING_REFRESH_S old. Computing it costs
        tens of ms (ground track, pass plan; a first one imports skyfield, seconds), so
        never on the event loop: a stale one is refreshed in a worker thread, started
        here, and the last one is returned meanwhile (``fresh_tracking`` waits for it).
        The setpoint itself reaches the page every frame through the rotator's target."""
        if self.tracker is None:
            return None
        if time.monotonic() - self._tracking_t > TRACKING_REFRESH_S:
            self._start_refresh()
        return self._tracking

    def _start_refresh(self) -> None:
        if self._tracking_busy:
            return
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # (no event loop on this thread: it may compute it itself)
            self.refresh_tracking_now()
            return
        self._tracking_busy = True
        loop.create_task(self._refresh_tracking())

    async def fresh_tracking(self) -> None:
        """Bring the tracker's status up to date if it is stale (in a worker thread)."""
        if self.tracker is not None and time.monotonic() - self._tracking_t > TRACKING_REFRESH_S:
            await self.refresh_tracking()

    async def _refresh_tracking(self) -> None:
        try:
            self._tracking = await asyncio.to_thread(self._tracker_status)
        finally:
            self._tracking_t = time.monotonic()
            self._tracking_busy = False

    def status_dict(self) -> dict[str, Any]:
        d = self.rotator.status().as_dict()
        d.setdefault("tracking", tracking_now(self.tracking(), time.time()))
        d["cycle"] = cycle_state(d, pointing_error_deg(d))
        return d

    def build_frame(self) -> str:
        status = self.status_dict()
        now = time.time()
        error = pointing_error_deg(status)
        self.history.add(now, status, error)
        self.seq += 1
        revs = self._split_parts(status)
        revs["info"] = self._info_rev()
        return json.dumps({"type": "status", "seq": self.seq, "t_wall_s": now, "status": status,
                           "error_deg": error, "procedure": self.procedure_dict(),
                           "jogs": sorted(self.jogs), "revs": revs}, separators=(",", ":"))

    def _info_rev(self) -> int:
        """Counts changes of the rotator's settings (limits, keep-out zones...: what
        /api/info describes): the page re-reads /api/info when this number moves."""
        settings = getattr(self.rotator, "settings", None)
        if settings is not self._settings_seen:
            self._settings_seen = settings
            self.info_rev += 1
        return self.info_rev

    def _split_parts(self, status: dict) -> dict[str, int]:
        """Move the seldom-changing parts out of ``status`` into ``self.parts`` (a new
        revision when one changed); the frame keeps only their revision numbers."""
        revs = {}
        for kind, (section, keys) in PARTS.items():
            holder = status.get(section) if section else status
            value = None
            if isinstance(holder, dict):
                if section:  # the tracker's own dict is shared with /api/status: copy it
                    holder = status[section] = dict(holder)
                value = {k: holder.pop(k) for k in keys if k in holder}
            rev, old, text = self.parts.get(kind, (0, None, ""))
            if value != old or not text:
                rev += 1
                text = json.dumps({"type": kind, "rev": rev, "data": value}, separators=(",", ":"))
                self.parts[kind] = (rev, value, text)
            revs[kind] = rev
        return revs

    def procedure_dict(self) -> dict | None:
        return None if self.procedure is None else self.procedure.as_dict()

    # ------------------------------------------------------------------ sampler
    def ensure_started(self) -> None:
        """Start the sampler on the running loop (``urc run`` has no lifespan events)."""
        if self._task is None or self._task.done():
            self._task = asyncio.get_running_loop().create_task(self._run(), name="web-live")

    async def _run(self) -> None:
        next_s = time.monotonic()
        while True:
            if self.tracker is not None and time.monotonic() - self._tracking_t > TRACKING_REFRESH_S:
                self._start_refresh()
            try:
                self.frame_text = self.build_frame()
                if self.jogs:
                    await self._expire_jogs()
            except Exception:
                log.exception("live frame failed")
            for fut in self._waiters:
                if not fut.done():
                    fut.set_result(None)
            self._waiters.clear()
            next_s += self.period_s
            delay = next_s - time.monotonic()
            if delay < -self.period_s:
                next_s, delay = time.monotonic(), 0.0
            await asyncio.sleep(max(delay, 0.0))

    async def next_frame(self) -> str:
        fut = asyncio.get_running_loop().create_future()
        self._waiters.add(fut)
        await fut
        return self.frame_text

    def messages_for(self, sent_revs: dict[str, int]) -> list[str]:
        """The current frame for one dashboard, preceded by the parts that changed since
        it last got them (``sent_revs`` is that dashboard's record, updated here)."""
        out = []
        for kind, (rev, _value, text) in self.parts.items():
            if sent_revs.get(kind) != rev:
                sent_revs[kind] = rev
                out.append(text)
        if self.frame_text:
            out.append(self.frame_text)
        return out

    async def serve(self, ws: WebSocket, subprotocol: str | None = None) -> None:
        self.ensure_started()
        await ws.accept(subprotocol=subprotocol)
        self.clients += 1

        async def sender() -> None:
            sent_revs: dict[str, int] = {}
            for text in self.messages_for(sent_revs):
                await ws.send_text(text)
            while True:
                await self.next_frame()
                for text in self.messages_for(sent_revs):  # (read together, no await between)
                    await ws.send_text(text)

        async def receiver() -> None:
            while True:  # the page sends nothing; this notices the close at once
                msg = await ws.receive()
                if msg["type"] == "websocket.disconnect":
                    return

        tasks = [asyncio.create_task(sender()), asyncio.create_task(receiver())]
        try:
            await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for t in tasks:
                t.cancel()
            for t in tasks:
                with contextlib.suppress(asyncio.CancelledError, WebSocketDisconnect, RuntimeError, OSError):
                    await t
            self.clients -= 1
            if ws.client_state == WebSocketState.CONNECTED and ws.application_state == WebSocketState.CONNECTED:
                with contextlib.suppress(RuntimeError, OSError, WebSocketDisconnect):
                    await ws.close()

    # ------------------------------------------------------------------ jog leases
    async def jog(self, axis: str, direction: int, speed: float) -> None:
        """Start or renew a press-and-hold jog; it ends unless renewed in JOG_LEASE_S."""
        self.ensure_started()
        lease = self.jogs.get(axis)
        now = time.monotonic()
        if lease is None or lease.direction != direction or lease.speed != speed:
            await call(self.rotator, Move(axis, direction, speed))
        self.jogs[axis] = JogLease(direction, speed, now + JOG_LEASE_S)

    async def release(self, axis: str | None) -> None:
        for name in ([axis] if axis else list(self.jogs)):
            if self.jogs.pop(name, None) is not None:
                await call(self.rotator, Stop(name))

    async def _expire_jogs(self) -> None:
        now = time.monotonic()
        for axis, lease in list(self.jogs.items()):
            if now > lease.expires_s:
                del self.jogs[axis]
                with contextlib.suppress(CommandRejected):
                    await call(self.rotator, Stop(axis))
                log.warning("jog of %s not renewed by the page: stopped", axis)

    # ------------------------------------------------------------------ procedures
    async def procedure_step(self, fn: Any, *args: Any) -> Any:
        """``await``: one step of a calibration procedure (made, polled, cancelled). A
        procedure is synchronous code that calls the rotator port: it runs on a worker
        thread, where a round trip to the control process blocks that thread only, never
        the event loop; one step at a time, so a cancel never lands inside a poll."""
        async with self._proc_lock:
            return await asyncio.to_thread(fn, *args)

    async def cancel_procedure(self) -> None:
        """Cancel the calibration procedure, if one is there (its own step)."""
        if self.procedure is not None:
            await self.procedure_step(self.procedure.cancel)

    def start_procedure(self, proc: Any) -> None:
        if self.procedure is not None and not self.procedure.finished:
            raise CommandRejected(f"a {self.procedure.kind} calibration is already running", "busy")
        self.procedure = proc
        self._proc_task = asyncio.get_running_loop().create_task(self._run_procedure(proc),
                                                                 name="calibration")

    async def _run_procedure(self, proc: Any) -> None:
        """Feed each new status to the procedure (at the control loop's pace)."""
        period_s = 0.5 / self.rotator.caps.loop_hz
        last_t = None
        while not proc.finished:
            status = self.rotator.status()
            if status.t_s != last_t:
                last_t = status.t_s
                await self.procedure_step(proc.poll, status)
            await asyncio.sleep(period_s)
