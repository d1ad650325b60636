"""Perform a command the web API and MQTT share: the body checked (:mod:`.bodies`), then
one request to the rotator over the link (``urc.model.effects.call``), or the tracker's
or the hub's part of it.

Each method takes its body as a model or as plain data (a dict: checked here, Invalid if
wrong, nothing sent) and returns a plain value or raises a CommandRejected with its reason
(the rotator's own refusals pass through as they came). The front ends only translate:
urc.api and urc.web's routes to HTTP, urc.mqtt.commands to its cmd/result JSON.
"""

from __future__ import annotations

import asyncio
import inspect
import logging
import math
from dataclasses import dataclass
from typing import Any, Protocol

from ..errors import CommandRejected, UrcError
from ..model.messages import (
    ClearFaults,
    ControllerHome,
    Goto,
    GotoAz,
    HardwareInfo,
    Move,
    Park,
    PotApply,
    PotUnits,
    SetPosition,
    Stop,
)
from ..model.messages import SimClear as SimClearQuery
from ..model.messages import SimFault as SimFaultQuery
from ..model.effects import call
from ..model.effects import ask
from ..link.client import StopQueued
from .bodies import (
    AxisRequest,
    GotoRequest,
    HomingRequest,
    MoveRequest,
    PassRequest,
    PositionRequest,
    PotApplyRequest,
    SimClear,
    SimFault,
    StopRequest,
    TrackRequest,
    ZeroRequest,
)
from .errors import NotSimulated, TrackerFailed, TrackingOff, parse

log = logging.getLogger(__name__)

#: a route the rotator plans for a goto or park: (az, el) waypoints
Route = list[tuple[float, float]]


class Hub(Protocol):
    """What a command needs of the I/O process's live hub (urc.web.live.Hub): its jog
    leases, its calibration procedure, its cached tracking status."""

    async def release(self, axis: str | None) -> None: ...
    async def cancel_procedure(self) -> None: ...
    async def refresh_tracking(self) -> None: ...
    async def procedure_step(self, fn: Any, *args: Any) -> Any: ...
    def start_procedure(self, proc: Any) -> None: ...


@dataclass(frozen=True)
class Stopped:
    #: sent but not confirmed by the control process yet (held up): it runs as soon as
    #: that process resumes; ``note`` says so
    queued: bool = False
    note: str = ""


@dataclass(frozen=True)
class PotReading:
    p: float
    reading_deg: float


def _load_calibration() -> Any:
    from ..procedures import calibration

    return calibration


async def _calibration() -> Any:
    """urc.procedures.calibration, imported at the first command that needs it and on a
    worker thread (lazy: its numpy would cost every start, and the event loop ~0.15 s)."""
    return await asyncio.to_thread(_load_calibration)


class Dispatcher:
    """The shared commands on one rotator, its tracker (None: no tracking) and its hub
    (None: no jogs, procedures or tracking status to keep, as in MQTT's tests)."""

    def __init__(self, rotator: Any, tracker: Any = None, hub: Hub | None = None):
        self.rotator = rotator
        self.tracker = tracker
        self.hub = hub

    # -------------------------------------------------------------- motion
    async def goto(self, req: GotoRequest | dict) -> Route:
        req = parse(GotoRequest, req)
        if req.el_deg is None:
            return await call(self.rotator, GotoAz(req.az_deg))
        return await call(self.rotator, Goto(req.az_deg, req.el_deg))

    async def park(self) -> Route:
        return await call(self.rotator, Park())

    async def stop(self, req: StopRequest | dict | None = None) -> Stopped:
        """Stop. Without an axis: everything — jogs, a calibration, tracking, both axes.

        The stop goes out first: nothing else may delay it, and a tracker or procedure
        that fails to stop cannot keep it from the rotator. The rest follows even when
        the rotator's stop failed (the link down: the hub and the tracker must not go on
        commanding), and then that failure is raised."""
        axis = parse(StopRequest, req or {}).axis
        out, failed = Stopped(), None
        try:
            await call(self.rotator, Stop(axis))
        except StopQueued as exc:
            out = Stopped(queued=True, note=str(exc))
        except Exception as exc:  # (raised below, once the rest is stopped)
            failed = exc
        try:
            if self.hub is not None:
                await self.hub.release(axis)
                if axis is None:
                    await self.hub.cancel_procedure()  # (its step runs off the loop: urc.web.live)
            if axis is None and getattr(self.tracker, "stop", None) is not None:
                await self._tracker("stop")
        except Exception:
            if failed is None:
                raise
            log.warning("stopping the rest after a failed stop", exc_info=True)
        if failed is not None:
            raise failed
        return out

    async def move(self, req: MoveRequest | dict) -> None:
        req = parse(MoveRequest, req)
        await call(self.rotator, Move(req.axis, req.direction, req.speed))

    async def set_position(self, req: PositionRequest | dict) -> None:
        req = parse(PositionRequest, req)
        await call(self.rotator, SetPosition(req.az_deg, req.el_deg))

    async def clear_faults(self) -> None:
        await call(self.rotator, ClearFaults())

    # -------------------------------------------------------------- tracking
    async def track(self, req: TrackRequest | dict) -> None:
        req = parse(TrackRequest, req)
        await self._tracker("track", req.model_dump(exclude_none=True))

    async def track_pass(self, req: PassRequest | dict) -> None:
        req = parse(PassRequest, req)
        await self._tracker("track_pass", norad=req.norad, aos=req.aos)

    async def track_stop(self) -> None:
        await self._tracker("stop")

    async def _tracker(self, name: str, *args: Any, **kw: Any) -> Any:
        """Run a tracker command (plain or ``async``: a TrackingService's commands are
        coroutines) and refresh the hub's tracking status. Its own errors (UrcError)
        pass through; anything else it raises is a refusal too (TrackerFailed), not a
        crash: the page and MQTT show the reason."""
        if self.tracker is None:
            raise TrackingOff()
        fn = getattr(self.tracker, name)
        try:
            out = fn(*args, **kw)
            if inspect.isawaitable(out):
                out = await out
        except UrcError:
            raise
        except Exception as exc:
            log.warning("tracker refused %s: %s", name, exc, exc_info=True)
            raise TrackerFailed(exc) from exc
        if self.hub is not None:
            await self.hub.refresh_tracking()
        return out

    # -------------------------------------------------------------- calibration
    async def zero(self, req: ZeroRequest | dict) -> None:
        """Declare where the antenna points now (re-reference)."""
        req = parse(ZeroRequest, req)
        await call(self.rotator, SetPosition(req.az_deg, req.el_deg))  # (calibration.zero's request)

    async def pot_read(self, req: AxisRequest | dict) -> PotReading:
        """The pot's linearised reading P here (averaged), and the bearing read with it."""
        req = parse(AxisRequest, req)
        p = await call(self.rotator, PotUnits(req.axis))
        status = self.rotator.status()  # (the reply's: read with P)
        return PotReading(p, getattr(status, req.axis).pos_deg + status.offsets.get(req.axis, 0.0))

    async def pot_apply(self, req: PotApplyRequest | dict) -> dict[str, float | None]:
        """M and C from two (bearing, P) points, loaded; NaN (a constant never set) as
        None, which JSON can carry."""
        req = parse(PotApplyRequest, req)
        result = await call(self.rotator, PotApply(req.axis, tuple((p.bearing_deg, p.p) for p in req.points)))
        return {k: v if math.isfinite(v) else None for k, v in result.items()}

    async def controller_home(self) -> None:
        await call(self.rotator, ControllerHome())

    async def magnetometer(self) -> None:
        """Start the 12-direction hard-iron calibration as the hub's procedure."""
        hub = self._procedures()
        cal = await _calibration()
        hub.start_procedure(await hub.procedure_step(cal.MagnetometerCalibration, self.rotator))

    async def homing(self, req: HomingRequest | dict) -> None:
        """Start limit-switch homing of one axis as the hub's procedure."""
        req = parse(HomingRequest, req)
        hub = self._procedures()
        cal = await _calibration()
        hub.start_procedure(await hub.procedure_step(cal.LimitSwitchHoming, self.rotator, req.axis,
                                                     req.speed_frac, req.switch_deg))

    # -------------------------------------------------------------- simulator (debug)
    async def sim_fault(self, req: SimFault | dict) -> None:
        """Make the simulated hardware fail (the controller is not told). NotSimulated on
        other hardware; ValueError: a fault this rotator cannot have."""
        req = parse(SimFault, req)
        kw = {k: v for k, v in (("deg", req.deg), ("duty", req.duty), ("which", req.which),
                                ("delay_s", req.delay_s), ("reads", req.reads)) if v is not None}
        self._simulated()
        await call(self.rotator, SimFaultQuery(req.axis, req.kind, kw))

    async def sim_clear(self, req: SimClear | dict) -> None:
        """Repair the simulated hardware (latched faults still need clearing)."""
        req = parse(SimClear, req)
        self._simulated()
        await call(self.rotator, SimClearQuery(req.axis, req.kind))

    def _simulated(self) -> None:
        # the simulator, or the gpio backend on emulated parts (the faults reach them)
        if not ask(self.rotator, HardwareInfo()).simulator:  # (no round trip: sent once at start)
            raise NotSimulated()

    def _procedures(self) -> Hub:
        if self.hub is None:
            raise CommandRejected("no calibration procedures here: they run in urc run's I/O process", "busy")
        return self.hub
