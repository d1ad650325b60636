"""The rotator service: the single owner of both axes.

Everything else (protocol sessions, the tracker, the web page, the CLI) submits commands
through the public methods of :class:`Rotator` and reads immutable :class:`Status`
snapshots. Command methods validate at once — limits, keep-out zones, faults and
position uncertainty are enforced here, once, for every source — and raise
:class:`CommandRejected` before anything moves; accepted commands are queued and applied
by :meth:`Rotator.tick`, the only code that changes axis state.

:class:`Rotator` is a facade over parts that each hold one concern (all share one
:class:`~urc.rotator.core.Core`: settings, geometry, axes, what the rotator is doing,
faults and events):

* ``axis.py`` — one axis: sensor reading, unwrapping, filtering, law, outputs;
* ``commands.py`` — every command validated, queued, applied by the tick; the route,
  track and park being flown advanced each tick;
* ``planning.py`` — what a command names in the rotator's frame, and the route there;
* ``guard.py`` — fault monitors, latched faults, the limit and keep-out guard, stalls;
* ``records.py`` — position records: restored at start-up, persisted every tick;
* ``status_builder.py`` — the Status clients read.

The lock: the control loop ticks on its own thread while commands come from others.
:func:`~urc.rotator.locking.locked_api` wraps every public method in ``with self.lock``
when the class is made, so a new command is locked by construction; the few that must
not take it on entry are marked :func:`~urc.rotator.locking.lock_free` with the reason
(tests/rotator/test_rotator_lock.py proves both).
"""

from __future__ import annotations

import logging
import threading

from ..clock import Clock
from ..control import law
from ..control.faults import Fault
from ..control.geometry import Geometry
from ..hardware.interfaces import Hardware
from ..errors import CommandRejected
from ..persistence import StateStore
from .axis import Axis
from .commands import OPEN_ENDED, Commands
from .core import Core
from .guard import Guard
from .locking import lock_free, locked_api
from .planning import Planner
from ..model.program import PassProgram
from .program_flight import ProgramFlight
from .records import Records
from ..model.settings import FIXED_EL_DEG, RotatorSettings
from ..model.snapshot import Status
from .status_builder import build_status
from .timing import LoopTiming

__all__ = ["FIXED_EL_DEG", "Rotator", "RotatorSettings"]

log = logging.getLogger(__name__)

Pose = tuple[float, float]


@locked_api
class Rotator:
    def __init__(self, settings: RotatorSettings, hardware: Hardware, clock: Clock,
                 store: StateStore | None = None):
        # every output safe before anything else (a restart may find a motor driving)
        hardware.drive_safe()
        settings = settings.completed()
        self.caps = settings.caps
        self.hw = hardware
        #: held by every public method but the few marked lock_free (see the module's
        #: docstring): the loop runs on its own thread, commands come from others
        self.lock = threading.RLock()
        self.axes = {n: Axis(n, hardware.axis(n), settings) for n in self.caps.axes}
        self._core = core = Core(settings, hardware, clock, self.axes)
        self.timing = LoopTiming(settings.watchdog_s)
        self._guard = Guard(core, self.timing)
        self._guard.set_stall_rule(settings)
        self._records = Records(core, store, self._guard.latch)
        self._planner = Planner(core)
        self._commands = Commands(core, self._planner, self._records, self._guard, self.status)
        self._flight = ProgramFlight(core, self._commands)
        self._last_t_s: float | None = None
        self._heartbeat = False
        self._was_held = False
        self._status: Status | None = None
        self._records.restore()
        # (after the restore: a sensor constant restored with it may turn bearings)
        core.geometry = self._planner.geometry_for(settings)
        self._status = self._build_status(clock.now_s())

    # ---------------------------------------------------------------- shared state
    @property
    def settings(self) -> RotatorSettings:
        return self._core.settings

    @property
    def geometry(self) -> Geometry:
        return self._core.geometry

    @property
    def clock(self) -> Clock:
        return self._core.clock

    @clock.setter
    def clock(self, clock: Clock) -> None:
        self._core.clock = clock

    @property
    def store(self) -> StateStore | None:
        return self._records.store

    @store.setter
    def store(self, store: StateStore | None) -> None:
        self._records.store = store

    # ---------------------------------------------------------------- the tick
    def tick(self, deadline_s: float | None = None) -> Status:
        """Advance the whole rotator by one control period. Only this mutates state.

        ``deadline_s``: when this tick was due (the real-time loop passes it); the tick
        measures how late its outputs were written, its own run time included."""
        start_s = self.clock.now_s()
        start_late_s = 0.0 if deadline_s is None else start_s - deadline_s
        self.note_lateness(start_late_s)  # late already: the outputs stay off this tick
        status = self._tick()
        if deadline_s is None:
            return status
        end_s = self.clock.now_s()
        self.timing.record(end_s - deadline_s, end_s - start_s)
        if start_late_s <= self.settings.watchdog_s < end_s - deadline_s:
            # a stall inside this tick: its outputs have been standing meanwhile
            self.note_lateness(end_s - deadline_s)
            status = self._status = self._build_status(end_s)
        return status

    def _tick(self) -> Status:
        core, commands = self._core, self._commands
        now = self.clock.now_s()
        dt = (1.0 / self.caps.loop_hz) if self._last_t_s is None else max(now - self._last_t_s, 0.0)
        self._last_t_s = now
        self.hw.poll(now)
        self._guard.sense(now, dt)
        commands.run_queued()
        self._flight.advance(now)
        commands.advance_route()
        self._guard.retry_after_cut(now)
        commands.check_parked()
        commands.maybe_idle_park(now)
        held = self.timing.held(now)
        if self._was_held and not held:
            core.event("control loop on time again: motion resumed" if core.motion else
                       "control loop on time again")
        self._was_held = held
        for ax in self.axes.values():
            sp = None if core.faults or held else ax.sp
            ax.step(sp, now, dt)
        self._guard.limit()
        self._records.persist(now)
        for ax in self.axes.values():
            ax.apply()
        self._beat(now)
        self._status = self._build_status(now)
        return self._status

    def note_lateness(self, late_s: float) -> None:
        """A stall of ``late_s`` (more than the watchdog time): the motors stop at once
        and stay off until the loop has been on time for a while; stalls that keep
        happening latch a watchdog fault."""
        if late_s > self.settings.watchdog_s:
            now = self.clock.now_s()
            if self._guard.on_stall(self.timing.stall(now, late_s), late_s, now):
                self._was_held = True

    def _beat(self, now_s: float) -> None:
        """Toggle the heartbeat output: a square wave while ticks run, for an external
        watchdog (charge pump) that cuts motor power when it stops. The hardware then
        reads the chain's read-back (motor power lost while the heartbeat runs: a
        ``motor_power`` fault at the next tick's sense)."""
        if self.hw.heartbeat is None:
            return
        self._heartbeat = not self._heartbeat
        self.hw.beat(self._heartbeat, now_s)

    # ---------------------------------------------------------------- commands
    def goto(self, az_deg: float, el_deg: float) -> list[Pose]:
        """Point at sky (az, el). Returns the planned mechanical waypoints."""
        return self._commands.goto(az_deg, el_deg)

    def goto_az(self, az_deg: float) -> list[Pose]:
        """Azimuth only: elevation keeps its target (or where it is, after a stop)."""
        return self._commands.goto_az(az_deg)

    def goto_el(self, el_deg: float) -> list[Pose]:
        """Elevation only: azimuth keeps its target (or where it is, after a stop)."""
        return self._commands.goto_el(el_deg)

    def goto_pose(self, az_m_deg: float, el_m_deg: float, name: str = "goto_pose",
                  local: bool = False) -> list[Pose]:
        """Fly round any keep-out zone to one *mechanical* pose. Returns the waypoints."""
        return self._commands.goto_pose(az_m_deg, el_m_deg, name, local=local)

    def park(self, local: bool = False) -> list[Pose]:
        """Go to the park pose (a mechanical pose); ``parked`` once both axes hold there."""
        return self._commands.park(local=local)

    def track(self, az_deg: float, el_deg: float, az_rate_deg_per_s: float = 0.0,
              el_rate_deg_per_s: float = 0.0, t_ref_s: float | None = None) -> None:
        """Follow a moving sky target: (az, el) at t_ref_s, moving at the given rates."""
        self._commands.track(az_deg, el_deg, az_rate_deg_per_s, el_rate_deg_per_s, t_ref_s)

    def track_pose(self, az_m_deg: float, el_m_deg: float, az_rate_deg_per_s: float = 0.0,
                   el_rate_deg_per_s: float = 0.0, t_ref_s: float | None = None) -> None:
        """Follow a planned *mechanical* trajectory point (wrap and flip chosen)."""
        self._commands.track_pose(az_m_deg, el_m_deg, az_rate_deg_per_s, el_rate_deg_per_s, t_ref_s)

    def move(self, axis: str, direction: int, speed_frac: float = 1.0, local: bool = False) -> None:
        """Manual move (jog) of one axis until stop, the limit or a keep-out zone."""
        self._commands.move(axis, direction, speed_frac, local=local)

    def stop(self, axis: str | None = None) -> None:
        """Stop (both axes, or one): decelerate at the axis' limit and hold there."""
        self._commands.stop(axis)

    def stop_open_ended(self, reason: str) -> bool:
        """A health rule (the I/O process silent): stop a jog or an update-fed track,
        said with ``reason``; bounded motions fly on. True if something stopped."""
        return self._commands.stop_open_ended(reason)

    def bounded_in_flight(self) -> str:
        """The bounded motion under way that flies on without the I/O process ("pass
        program", "goto", "park", ...; a program waiting for its pass counts), or ""."""
        core = self._core
        # (a command counts once accepted, though the next tick applies it; a program
        # waiting for its pass starts on time whatever else is queued)
        queued = self._commands.queued_motion()
        if queued == "program" or core.program is not None and (queued is None or core.program_state == "waiting"):
            return "pass program"
        if queued is not None:
            return "" if queued in OPEN_ENDED else queued
        if core.motion in (None, *OPEN_ENDED):
            return ""
        # (the route keeps its last waypoint once there: under way while not reached)
        ahead = len(core.route) > 1 or bool(core.route) and any(
            abs(p - m) > 2 * core.caps.axis(n).tolerance_deg
            for n, p, m in zip(core.axes, core.route[-1], core.current_pose()))
        return core.motion if ahead or core.parking or self.status().moving else ""

    def fly_program(self, program: PassProgram) -> None:
        """Fly a planned pass by this process's clock (program track, urc.model.program)."""
        self._flight.accept(program)

    def cancel_program(self, program_id: int | None = None) -> None:
        """End the pass program (only ``program_id``, if given); stops it if flying."""
        self._flight.cancel(program_id)

    def set_position(self, az_deg: float | None = None, el_deg: float | None = None,
                     local: bool = False) -> None:
        """Re-reference: declare where the antenna points now (extended frame)."""
        self._commands.set_position(az_deg, el_deg, local=local)

    def adopt_sensor_reading(self, axis: str, local: bool = False, reread: bool = True) -> float:
        """An absolute sensor's constants changed: the axis takes its reading as its
        position at once (call under ``lock`` with the change). Returns the angle."""
        return self._commands.adopt_sensor_reading(axis, local=local, reread=reread)

    def search_frame(self, axis: str, mech_deg: float) -> None:
        """Reference search (homing): a temporary frame until :meth:`end_search`."""
        self._commands.search_frame(axis, mech_deg)

    def end_search(self, axis: str, mech_deg: float | None = None) -> None:
        """End a reference search: the reference found, or None to go back."""
        self._commands.end_search(axis, mech_deg)

    def set_overshoot(self, axis: str, overshoot_deg: float) -> None:
        """Set the coast estimate of a relay axis (Tartu OVRA/OVRE); it keeps learning."""
        self._commands.set_overshoot(axis, overshoot_deg)

    def overshoot_deg(self, axis: str) -> float:
        """The present coast estimate at full drive (what OVRA/OVRE read)."""
        return self._commands.overshoot_deg(axis)

    def reconfigure(self, settings: RotatorSettings) -> None:
        """Apply new limits, keep-out zones, offsets, speeds, park and fault limits
        while running; motion in progress stops."""
        self._commands.reconfigure(settings)

    @lock_free("a set's add or discard (atomic): a pin's callback thread must not wait for a tick")
    def hold_local(self, control: str, held: bool) -> None:
        """A local control (a front-panel button, an IR remote key, the zero-setting
        procedure) is pressed (``held``) or released. While any is held the local
        operator wins: motion commands from every other source are refused with reason
        "local"; a stop is accepted from anyone."""
        self._commands.hold_local(control, held)

    @lock_free("reads a copy of the set of held controls, which hold_local changes atomically")
    def local_controls(self) -> tuple[str, ...]:
        """The local controls held now (empty: every source may command motion)."""
        return self._commands.local_controls()

    # ---------------------------------------------------------------- faults, events
    def clear_faults(self) -> None:
        """Clear latched faults now, before the reply (a goto right after it must be
        accepted); the monitors re-arm from here."""
        self._guard.clear()
        self._status = self._build_status(self.clock.now_s())

    def announce(self, text: str) -> None:
        """An event from outside the rotator (logged, and in status' recent events)."""
        self._core.event(text)

    def position_uncertain(self) -> bool:
        return self._core.position_uncertain()

    @lock_free("makes every output safe before it waits for the lock (a tick may hold it), "
               "then takes the lock itself to latch the fault")
    def power_fail(self, reason: str = "power-fail input: supply lost") -> None:
        """The supply is going (a power-fail input, BIG-RAS's interrupt): every output
        safe first (written without waiting for a tick that may hold the lock), then a
        ``power_fail`` fault latched so no tick drives again until it is cleared.
        Callable from any thread (a pin's edge callback); the caller then saves the
        state (:meth:`save_now`, which waits for the disk: not on a pin's callback
        thread, which also serves the encoder edges)."""
        self.hw.drive_safe()
        with self.lock:
            for ax in self.axes.values():
                ax.sp, ax.out = None, law.OFF
            self._guard.latch(Fault("power_fail", None, f"{reason}: motors stopped, brakes on, state written "
                                    "at once", self.clock.now_s()))
            self.hw.drive_safe()
            self._status = self._build_status(self.clock.now_s())

    def safety_chain_failed(self, reason: str) -> None:
        """The safety chain's start-up self-test failed (urc.hardware.safety_test): the
        motors could stay powered with nothing in control, so nothing drives until a
        person has mended it and cleared the fault."""
        self.hw.drive_safe()
        self._guard.latch(Fault("safety_chain", None, reason, self.clock.now_s()))
        self._status = self._build_status(self.clock.now_s())

    # ---------------------------------------------------------------- records
    @lock_free("takes the lock to take the record and read the report; waiting for the disk "
               "under it would stop the control loop")
    def save_now(self, timeout_s: float = 5.0) -> bool:
        """Write a record of the present state and wait for it; True once it is on disk."""
        records = self._records
        if records.writer is None:
            return True
        with self.lock:  # the record is taken between ticks; the wait is not (see below)
            records.submit_record(self.clock.now_s())
        ok = records.writer.flush(timeout_s)
        with self.lock:
            records.take_report(self.clock.now_s())
            return ok and records.durable is records.record

    @lock_free("reads the calling thread's own number (thread-local)")
    def motion_ticket(self) -> int | None:
        """The moving command this thread's last call accepted, if its reply must wait
        for the motion's first state record (urc.rotator.records); taken once."""
        return self._records.motion_ticket()

    @lock_free("waits for the tick and the disk, which under the lock would stop the control loop")
    def confirm_motion_record(self, ticket: int, timeout_s: float) -> None:
        """Issue 36.19: standing, nothing is written, so a disk that has just failed is
        found only by the first record of the next motion. Wait for moving command
        ``ticket``'s first record: on disk (or not known within ``timeout_s``, a slow
        card: the command stands and flies once it lands), return; failed, stop the
        motion with the state fault latched and refuse the command (reason "state")."""
        landed, why = self._records.await_motion_record(ticket, timeout_s)
        if landed is not False:
            return
        with self.lock:
            if not self._records.refuse_motion(self.clock.now_s()):
                return  # (a retry landed meanwhile: the command stands)
        raise CommandRejected(f"refused: state not saved ({why}): motion stopped so that the saved "
                              "position stays true; the state fault clears itself once a write succeeds",
                              "state")

    def shutdown(self, save: bool = True) -> bool:
        """Motors off, brakes on, every output safe; then the state saved as it is (still
        on the move, it says so: a restart is then uncertain by how far the axis can
        coast). The caller stops first and waits for standstill (``urc.rotator.loop``);
        ``save=False`` for a start that failed: the saved state stays as it was. True if saved."""
        for ax in self.axes.values():
            ax.sp, ax.out = None, law.OFF
            ax.apply()
        self.hw.drive_safe()
        writer = self._records.writer
        if writer is None:
            return True
        ok = self.save_now() if save else True
        writer.close()
        return ok

    # ---------------------------------------------------------------- status
    @lock_free("returns the Status the last tick or command published: immutable")
    def status(self) -> Status:
        assert self._status is not None
        return self._status

    def _build_status(self, now_s: float) -> Status:
        health = self.timing.health(now_s)
        return build_status(self._core, now_s, health, self.timing.health_dict(health), self._records.save_error,
                            self._commands.local_controls(), searches=tuple(self._records.searches))
