"""The I/O process's side of the control process: a Rotator that lives in another process.

``urc run`` runs the control loop in a process of its own (:mod:`.control_process`):
within one interpreter the loop thread had to win Python's global lock from the
event-loop thread, and under a flood of requests on two cores the OS preempted that
thread while it held the lock, so ticks waited for a whole scheduler slice (10-19 ms
p99, bench/loop_bench.py, against 0.1-0.2 ms for a C thread in the same run). The
control process runs only the rotator, its hardware and the loop, at real-time
priority; everything that answers the network stays here.

:class:`RemoteRotator` stands in for the Rotator here, over the link's client end
(:mod:`.client`):

* the control process publishes a :class:`Status` after every tick; :meth:`RemoteRotator.status`
  returns the newest, so reading status (every protocol's position query) costs no
  round trip; a status that stopped coming is a ``control`` fault, and the sessions'
  view refuses to give it out as a position;
* every command is one typed request, answered with its result or its exception (its
  own class, so each protocol still answers in its own error form): web routes await
  :meth:`RemoteRotator.call`, protocol sessions are stepped on by
  :meth:`RemoteRotator.call_then`, threads block in :meth:`RemoteRotator.request`;
* the hardware stays over there: what a protocol or route needs of it (a sensor's count
  or constants, a calibration step) is one typed query (:class:`urc.model.messages.Query`,
  :meth:`RemoteRotator.ask`, answered by :mod:`.queries`), one round trip each; only data
  comes back.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

from ..clock import RealClock
from ..control.faults import Fault
from ..model.messages import (AdoptSensorReading, Announce, CancelProgram, ClearFaults, EndSearch, FlyProgram, Goto,
                              GotoAz, GotoEl, GotoPose, HardwareInfo, HoldLocal, LocalControls, Move, OvershootQuery,
                              Park, PositionUncertain, PowerFail, Query, Reconfigure, Request, SaveNow, SearchFrame,
                              SetOvershoot, SetPosition, Stop, Track, TrackPose)
from ..model.snapshot import Status
from .client import CALL_TIMEOUT_S, ControlLink, ControlUnavailable, Then

if TYPE_CHECKING:
    import asyncio

#: how long a stop waits for its confirmation (it is applied however late it arrives,
#: so a longer wait would only keep its caller from telling the operator)
STOP_ACK_S = 1.0#: a status older than this means the control process has stopped publishing (it
#: publishes every tick)
STATUS_STALE_S = 1.0
#: ... and sooner while the axes moved: a position that old may already be degrees off
#: (at 6 deg/s, 1 s was 3 deg given as current by rotctld's ``p``; issue 20)
MOVING_STATUS_STALE_S = 0.3



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

    def call_then(self, request: Request, then: Then) -> None:
        """:meth:`call` with a callback, ``then(value, None)`` or ``then(None, exception)``,
        on the event loop (urc.servers.common's sessions: no future between the reply and
        the session's next step)."""
        if isinstance(request, HardwareInfo):
            import asyncio

            asyncio.get_running_loop().call_soon(then, self.hardware, None)
            return
        self._link.submit_then(request, then, self._timeout_s(request), finish=lambda value: self._accepted(request, value))

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
