"""Commands: every way of telling the rotator to move, validated at once and queued.

Each command checks what it is given against the limits, keep-out zones, faults, local
controls and the position's uncertainty, raising :class:`CommandRejected` before
anything moves; what it changes is queued as a closure that the next tick applies
(:meth:`Commands.run_queued`), so no command ever sees or leaves half a tick. The
route, track and park being flown are advanced here too, once per tick.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass, replace
from typing import Callable

from ..control import law
from ..control.geometry import declared_boresight, wrap360
from ..control.profile import stopping_distance_deg
from ..errors import CommandRejected
from . import position_record as precord
from .axis import AXES, Axis
from .core import Core
from .guard import Guard
from .planning import Planner
from .records import Records
from ..model.settings import FIXED_EL_DEG, RotatorSettings
from ..model.snapshot import Status


@dataclass(frozen=True)
class _Command:
    name: str
    apply: Callable[[], None]


#: The motion a queued command sets once the tick applies it ("": none, a stop); a name
#: not here leaves the motion as it is. An accepted command counts from its acceptance,
#: not from the next tick: the I/O process may die in between (issue 33).
QUEUED_MOTION = {"goto": "goto", "goto_pose": "goto_pose", "park": "park", "program": "program",
                 "move": "move", "track": "track", "track_pose": "track", "stop": ""}
OPEN_ENDED = ("move", "track")  # (only a live client ends these)


class Commands:
    def __init__(self, core: Core, planner: Planner, records: Records, guard: Guard,
                 status: Callable[[], Status]):
        self.core = core
        self.planner = planner
        self.records = records
        self.guard = guard
        #: the rotator's latest status (goto_az/goto_el keep the other axis' direction)
        self.status = status
        self.queue: collections.deque[_Command] = collections.deque()
        #: local controls held now (front-panel buttons, IR keys): the local operator wins
        self.local_holds: set[str] = set()

    def run_queued(self) -> None:
        """Apply the accepted commands in order (the tick, under the lock)."""
        while self.queue:
            self.queue.popleft().apply()

    def queued_motion(self) -> str | None:
        """(Under the lock.) The motion the newest queued motion command sets ("" a
        stop), or None if none is queued."""
        for cmd in reversed(self.queue):
            if cmd.name in QUEUED_MOTION:
                return QUEUED_MOTION[cmd.name]
        return None

    def submit(self, name: str, apply: Callable[[], None]) -> None:
        core = self.core
        core.last_command_t_s = core.clock.now_s()
        self.queue.append(_Command(name, apply))

    def hold_local(self, control: str, held: bool) -> None:
        """A local control (a front-panel button, an IR remote key, the zero-setting
        procedure) is pressed (``held``) or released. While any is held the local
        operator wins: motion commands from every other source are refused with reason
        "local"; a stop is accepted from anyone. Thread-safe (set operations)."""
        if held:
            self.local_holds.add(control)
        else:
            self.local_holds.discard(control)

    def local_controls(self) -> tuple[str, ...]:
        """The local controls held now (empty: every source may command motion)."""
        if not self.local_holds:  # (the usual case, asked every tick: no sort, no copy)
            return ()
        return tuple(sorted(self.local_holds))

    def refuse_unless_local(self, local: bool) -> None:
        holds = self.local_controls()
        if holds and not local:
            raise CommandRejected(f"refused: local control active ({', '.join(holds)} held at the "
                                  "rotator); stop is still accepted", "local")

    def require_motion_ok(self, automatic: bool, local: bool = False) -> None:
        core = self.core
        self.refuse_unless_local(local)
        if core.faults:
            # only the state fault (it clears itself once a write lands): said as "state",
            # the same refusal as once it is cleared by hand while writes still fail
            state_only = all(f.kind == "state" for f in core.faults)
            raise CommandRejected("refused: fault latched (" + "; ".join(f.reason for f in core.faults)
                                  + ("); it clears itself once the state is saved again" if state_only
                                     else "); clear faults first"), "state" if state_only else "fault")
        if self.records.save_error and any(precord.needs_record(ax) for ax in core.axes.values()):
            # the first tick would hold the axes and latch the state fault: say so now,
            # not "ok" for a move that cannot happen (a fault cleared on a full disk)
            raise CommandRejected(f"refused: state not saved ({self.records.save_error}); motion would stop at "
                                  "once so that the saved position stays true", "state")
        if automatic and core.position_uncertain():
            bounds = ", ".join(f"{n} ±{ax.uncertainty_deg:.2f} deg" for n, ax in core.axes.items()
                               if ax.uncertainty_deg)
            raise CommandRejected(f"refused: position uncertain ({bounds}); re-reference first",
                                  "uncertain")
        self.records.motion_accepted()  # (its reply may wait for the first record: Records)

    def goto_pose(self, az_m_deg: float, el_m_deg: float, name: str = "goto_pose",
                  local: bool = False) -> list[tuple[float, float]]:
        """Fly round any keep-out zone to one *mechanical* pose (wrap and flip chosen
        by the pass planner). Returns the planned waypoints. ``local``: from a local
        control (front panel), allowed while one is held."""
        core = self.core
        self.require_motion_ok(automatic=True, local=local)
        if not (math.isfinite(az_m_deg) and math.isfinite(el_m_deg)):
            raise CommandRejected(f"pose {az_m_deg!r}, {el_m_deg!r} is not finite", "invalid")
        if "el" not in core.axes:
            el_m_deg = FIXED_EL_DEG
        g = core.geometry
        if not g.in_limits(az_m_deg, el_m_deg, slack_deg=1e-6):
            raise CommandRejected(f"pose az {az_m_deg:g}, el {el_m_deg:g} outside the limits", "limit")
        route = self.planner.route_to_pose((az_m_deg, el_m_deg))
        if route is None:
            raise CommandRejected(f"no legal path to pose az {az_m_deg:g}, el {el_m_deg:g}: it or every "
                                  "path to it lies in a keep-out zone", "keepout")
        core.target_sky = g.to_sky(az_m_deg, el_m_deg)
        self.submit_route(name, route)
        return route

    def submit_route(self, name: str, route: list[tuple[float, float]]) -> None:
        core = self.core

        def apply() -> None:
            self.replace_program(name)
            core.parked = core.parking = False
            core.tracking = False
            core.motion = name
            self.start_route(route)
        self.submit(name, apply)

    def goto(self, az_deg: float, el_deg: float) -> list[tuple[float, float]]:
        """Point at sky (az, el). Returns the planned mechanical waypoints (a goto that
        agrees with the pass program flying: that program's pose now, and it flies on)."""
        core = self.core
        self.require_motion_ok(automatic=True)
        agreed = core.agrees_with_program(az_deg, el_deg)
        if agreed is not None:
            return [agreed]
        if "el" not in core.axes:
            el_deg = self.planner.no_el(el_deg)
        route = self.planner.plan(az_deg, el_deg)
        target = (wrap360(az_deg), el_deg) if self.planner.explicit_pose(az_deg, el_deg) is None \
            else core.geometry.to_sky(*route[-1])

        # The target is known from now on (not from the next tick), so that a goto_el
        # right after a goto_az in the same breath keeps the azimuth just asked for.
        core.target_sky = target
        self.submit_route("goto", route)
        return route

    def goto_az(self, az_deg: float) -> list[tuple[float, float]]:
        """Azimuth only: elevation keeps its target (or where it is, after a stop)."""
        core = self.core
        if "el" not in core.axes:
            return self.goto(az_deg, FIXED_EL_DEG)
        el_deg = core.target_sky[1] if core.target_sky else self.status().el_deg
        assert el_deg is not None  # (an elevation axis reports one)
        return self.goto(az_deg, el_deg)

    def goto_el(self, el_deg: float) -> list[tuple[float, float]]:
        """Elevation only: azimuth keeps its target (or where it is, after a stop)."""
        core = self.core
        self.planner.require_el("goto elevation")
        return self.goto(core.target_sky[0] if core.target_sky else self.status().az_deg, el_deg)

    def park(self, local: bool = False) -> list[tuple[float, float]]:
        """Go to the park pose: a *mechanical* pose (the axes' own frame, as the limits
        are), not a sky direction. So parking unwinds the cable to the turn the pose
        names, and a rotator that can flip parks unflipped at el 90 rather than at the
        other side's az 180. ``parked`` turns true once both axes hold there."""
        core = self.core
        route = self.goto_pose(core.settings.park_az_deg, core.settings.park_el_deg, "park", local=local)

        def mark() -> None:
            core.parking = True
        self.submit("park", mark)
        return route

    def track(self, az_deg: float, el_deg: float, az_rate_deg_per_s: float = 0.0,
              el_rate_deg_per_s: float = 0.0, t_ref_s: float | None = None) -> None:
        """Follow a moving sky target: (az, el) at t_ref_s, moving at the given rates.

        Keeps the wrap and flip side of the previous track point (continuity), so a
        pass planned on one side stays there; the pass planner chooses that side.
        """
        core = self.core
        self.require_motion_ok(automatic=True)
        for v in (az_deg, el_deg, az_rate_deg_per_s, el_rate_deg_per_s):
            if not math.isfinite(v):
                raise CommandRejected(f"track value {v!r} is not finite", "invalid")
        if "el" not in core.axes:  # the azimuth follows; where it is in the sky is not asked
            el_deg, el_rate_deg_per_s = FIXED_EL_DEG, 0.0
        t_ref = core.clock.now_s() if t_ref_s is None else t_ref_s
        g = core.geometry
        poses = g.candidates(wrap360(az_deg), el_deg)
        if not poses:
            raise CommandRejected(f"track point az {az_deg:g}, el {el_deg:g} outside the limits", "limit")
        ref = tuple(ax.sp.target_at(t_ref) if core.tracking and ax.sp else ax.meas_deg
                    for ax in core.axes.values()) + (FIXED_EL_DEG,) * (2 - len(core.axes))
        pose = min(poses, key=lambda p: abs(p[0] - ref[0]) + abs(p[1] - ref[1]))
        if g.zone_at(*pose, margin_deg=0.0) or g.segment_clear(core.current_pose(), pose, core.rates()):
            raise CommandRejected(f"track point az {az_deg:g}, el {el_deg:g} is in or behind a keep-out zone",
                                  "keepout")
        flipped = pose[1] > 90.0
        az_rate = az_rate_deg_per_s
        el_rate = -el_rate_deg_per_s if flipped else el_rate_deg_per_s

        core.target_sky = (wrap360(az_deg), el_deg)

        self.submit("track", lambda: self.follow(pose, (az_rate, el_rate), t_ref))

    def track_pose(self, az_m_deg: float, el_m_deg: float, az_rate_deg_per_s: float = 0.0,
                   el_rate_deg_per_s: float = 0.0, t_ref_s: float | None = None) -> None:
        """Follow a planned *mechanical* trajectory point (wrap and flip already chosen
        by the pass planner): the pose at t_ref_s, moving at the given mechanical rates."""
        core = self.core
        self.require_motion_ok(automatic=True)
        values = (az_m_deg, el_m_deg, az_rate_deg_per_s, el_rate_deg_per_s)
        if not all(math.isfinite(v) for v in values):
            raise CommandRejected(f"track pose {values!r} is not finite", "invalid")
        if "el" not in core.axes:
            el_m_deg, el_rate_deg_per_s = FIXED_EL_DEG, 0.0
        g = core.geometry
        if not g.in_limits(az_m_deg, el_m_deg, slack_deg=1e-6):
            raise CommandRejected(f"track pose az {az_m_deg:g}, el {el_m_deg:g} outside the limits", "limit")
        zone = g.zone_at(az_m_deg, el_m_deg, margin_deg=0.0)
        if zone is not None:
            raise CommandRejected(f"track pose az {az_m_deg:g}, el {el_m_deg:g} is in keep-out zone "
                                  f"{zone.name!r}", "keepout")
        t_ref = core.clock.now_s() if t_ref_s is None else t_ref_s
        core.target_sky = g.to_sky(az_m_deg, el_m_deg)

        self.submit("track_pose", lambda: self.follow((az_m_deg, el_m_deg),
                                                      (az_rate_deg_per_s, el_rate_deg_per_s), t_ref))

    def follow(self, pose: tuple[float, float], rates: tuple[float, float], t_ref: float,
               motion: str = "track") -> None:
        """Set moving setpoints. Successive updates of one track keep their sequence
        number, so the law keeps following instead of re-planning at every update.
        ``motion``: "program" when the pass program flies it (it replaces no program)."""
        core = self.core
        if motion != "program":
            self.replace_program(motion)
        was_tracking = core.tracking
        core.parked = core.parking = False
        core.tracking = True
        core.motion = motion
        core.route = []
        seq = core.next_seq()
        for ax, p, r in zip(core.axes.values(), pose, rates):
            lo, hi = ax.limits
            kept = ax.sp if was_tracking else None
            ax.sp = law.Setpoint(min(max(p, lo), hi), r, t_ref, seq=kept.seq if kept is not None else seq,
                                 min_deg=lo, max_deg=hi)

    def move(self, axis: str, direction: int, speed_frac: float = 1.0, local: bool = False) -> None:
        """Manual move (jog) of one axis at a fraction of its top speed, until stop.

        Stops by itself at the soft limit or before a keep-out zone. ``local``: from a
        local control (front panel), allowed while one is held.
        """
        core = self.core
        if axis not in AXES or direction not in (-1, 1):
            raise CommandRejected(f"move needs axis az|el and direction -1|+1, got {axis!r}, {direction!r}")
        if axis == "el":
            self.planner.require_el("move elevation")
        if not (math.isfinite(speed_frac) and 0.0 < speed_frac <= 1.0):
            raise CommandRejected(f"move speed {speed_frac!r} outside 0 < speed <= 1")
        self.require_motion_ok(automatic=False, local=local)
        ax = core.axes[axis]
        if (direction > 0 and ax.limit_max) or (direction < 0 and ax.limit_min):
            raise CommandRejected(f"{axis}: limit switch active in that direction", "limit")
        lo, hi = ax.limits
        end = core.geometry.clear_until(core.current_pose(), axis, hi if direction > 0 else lo)
        cap = max(speed_frac * ax.tuning.max_rate_deg_per_s, ax.tuning.min_rate_deg_per_s)
        core.target_sky = None

        def apply() -> None:
            self.replace_program("move")
            core.parked = core.parking = False
            core.motion = "move"
            others = [n for n in core.axes if n != axis]
            if core.route or core.tracking or any(
                    (sp := core.axes[n].sp) is not None and sp.rate_deg_per_s for n in others):
                # the other axis was flying a route or a track planned for both axes
                # together (or is still following a track whose other axis was stopped);
                # alone it could carry the jog into a zone: stop it too
                self.stop_axes(others)
            core.tracking = False
            core.route = []
            ax.sp = law.Setpoint(end, 0.0, core.clock.now_s(), speed_cap_deg_per_s=cap, seq=core.next_seq())
        self.submit("move", apply)

    def stop(self, axis: str | None = None) -> None:
        """Stop (both axes, or one): decelerate at the axis' limit and hold there."""
        core = self.core
        if axis is not None and axis not in AXES:
            raise CommandRejected(f"stop takes az, el or nothing, got {axis!r}")
        if axis is not None and axis not in core.axes:
            return  # no such axis here: nothing to stop (and the azimuth keeps its goal)
        core.target_sky = None

        def apply() -> None:
            self.replace_program("stop")
            self.halt([axis] if axis else list(core.axes))
        self.submit("stop", apply)

    def halt(self, names: list[str]) -> None:
        """No route, track, park or motion any more; ``names`` decelerate and hold (the
        tick: a stop, a health rule's stop, a cancelled program)."""
        core = self.core
        core.route = []
        core.tracking = False
        core.parking = False  # a park cut short is no park
        core.motion = None
        self.stop_axes(names)

    # ------------------------------------------------------------ stops by a health rule
    def stop_open_ended(self, reason: str) -> bool:
        """The I/O process is silent: stop what only a live client can end (a jog, a
        track fed by updates), and say so; a bounded motion (a goto, a park, a pass
        program: its end was checked when it was accepted, and the guard holds limits
        and zones every tick) flies on to its end. True if something was stopped."""
        core = self.core
        queued = self.queued_motion()
        motion = core.motion if queued is None else queued or None
        if motion not in OPEN_ENDED:
            if motion is not None:
                core.event(f"{reason}: the {motion} flies on to its end (a bounded motion)")
            return False
        # (a jog accepted but not yet applied must not start after this stop)
        self.queue = collections.deque(c for c in self.queue if QUEUED_MOTION.get(c.name) not in OPEN_ENDED)
        core.target_sky = None
        self.halt(list(core.axes))
        # a track resumes by itself: the tracker's next update restarts it once the I/O
        # process talks; a jog needs its client to ask again
        core.note_stop("health", reason, resumes=motion == "track", command=motion)
        return True

    def replace_program(self, by: str) -> None:
        """A motion command replaces a program that is flying (a person wins); a program
        still waiting for its pass is kept (it starts on time, as a scheduled pass)."""
        core = self.core
        if core.program is not None and core.program_state in ("prepositioning", "tracking"):
            core.end_program("stopped" if by == "stop" else f"replaced by {by}")

    def stop_axes(self, names: list[str]) -> None:
        """Decelerate at each axis' limit and hold where it comes to rest (relays: cut)."""
        core = self.core
        for name in names:
            ax = core.axes[name]
            if ax.tuning.drive == "relay" or ax.law.mode != "driving" or ax.positioner is not None:
                ax.sp = None  # (a positioner's controller gets a stop and brakes itself)
                continue
            lo, hi = ax.limits
            rate = ax.law.ref_rate_deg_per_s
            end = ax.law.ref_deg + math.copysign(stopping_distance_deg(rate, ax.tuning.accel_deg_per_s2), rate)
            ax.sp = law.Setpoint(min(max(end, lo), hi), 0.0, core.clock.now_s(), seq=core.next_seq())

    def set_position(self, az_deg: float | None = None, el_deg: float | None = None,
                     local: bool = False) -> None:
        """Re-reference: declare where the antenna points now (Tartu WRAZ/WREL).

        Values are in the extended azimuth frame (e.g. 400 on a 450 deg rotator names
        the overlap), so the wrap side is explicit. Clears that axis' uncertainty.
        ``local``: from a local control; refused from elsewhere while one is held (it
        would cut the operator's jog short).
        """
        core = self.core
        self.refuse_unless_local(local)
        g = core.geometry
        if el_deg is not None:
            self.planner.require_el("set elevation position")
        values = {"az": az_deg, "el": el_deg}
        for name, v in values.items():
            if v is None:
                continue
            if not math.isfinite(v):
                raise CommandRejected(f"{name} {v!r} is not a finite number")
        if g.pointing_deg:  # (the values say where the beam points: the boresight's are set)
            values = declared_boresight(g, values, self.status())
        for name, v in values.items():
            if v is None:
                continue
            lo, hi = core.axes[name].limits
            off = g.az_offset_deg if name == "az" else g.el_offset_deg
            if not lo - 1e-9 <= v - off <= hi + 1e-9:
                raise CommandRejected(f"{name} {v:g} outside {lo + off:g}..{hi + off:g}", "limit")

        def apply() -> None:
            for name, v in values.items():
                if v is None:
                    continue
                off = g.az_offset_deg if name == "az" else g.el_offset_deg
                self.records.searches.pop(name, None)  # a person's word ends a search too
                self.rereference(core.axes[name], v - off)
                core.event(f"{name} re-referenced to {v:.2f} deg")
        self.submit("set_position", apply)

    def adopt_sensor_reading(self, axis: str, local: bool = False, reread: bool = True) -> float:
        """An absolute sensor's constants were just changed (a G4JNT zero offset Z, a
        declination): the axis takes what the sensor reads now as its position, at once
        (call it under ``lock`` together with the change, so no tick sees the jump as a
        fault). The sensor is not re-referenced: that would fold one noisy reading back
        into the constant just set. ``reread=False``: only a constant that turns bearings
        changed (the G4JNT's Z): the axis angle stays as it is, without one more noisy
        reading. Returns the new mechanical angle."""
        core = self.core
        self.refuse_unless_local(local)
        if axis not in core.axes:
            raise CommandRejected(f"no {axis!r} axis on this rotator (it has {', '.join(core.axes)})")
        ax = core.axes[axis]
        if not ax.caps.sensor.absolute:
            raise CommandRejected(f"{axis}: an incremental sensor has no reading to adopt; "
                                  "re-reference it with set_position")
        mech_deg = ax.unwrap(ax.hw.sensor.read_deg() + ax.count_centre_deg, ax.meas_deg) if reread \
            else ax.meas_deg
        lo, hi = ax.limits
        slack = ax.caps.sensor.resolution_deg + 3.0 * ax.caps.sensor.noise_deg   # one noisy reading
        if not lo - slack <= mech_deg <= hi + slack:
            raise CommandRejected(f"{axis}: the new constants put the axis at {mech_deg:.1f} deg, "
                                  f"outside {lo:g}..{hi:g}", "limit")
        self.records.searches.pop(axis, None)
        self.rereference(ax, mech_deg, set_sensor=False)
        core.geometry = self.planner.geometry_for(core.settings)   # a new Z turns the bearings
        off = core.geometry.az_offset_deg if axis == "az" else core.geometry.el_offset_deg
        core.event(f"{axis} re-referenced to {mech_deg + off:.2f} deg (new sensor constants)")
        return mech_deg

    def rereference(self, ax: Axis, mech_deg: float, uncertainty_deg: float = 0.0,
                    set_sensor: bool = True) -> None:
        ax.rereference(mech_deg, uncertainty_deg, set_sensor)
        self.core.route = []
        self.core.parked = self.core.parking = False  # a re-reference ends a park under way
        self.records.mark_dirty()

    def search_frame(self, axis: str, mech_deg: float) -> None:
        """Reference search (homing): re-reference ``axis`` to ``mech_deg`` in a temporary
        frame in which a jog can reach the switch. Until :meth:`end_search` the axis
        counts as uncertain over its whole range, and state records keep the true frame:
        a search interrupted by a crash restarts uncertain, never in the search frame."""
        core = self.core
        self.planner.check_axis(axis)
        if not math.isfinite(mech_deg):
            raise CommandRejected(f"{axis} {mech_deg!r} is not a finite number")

        def apply() -> None:
            ax = core.axes[axis]
            prior, shift = self.records.searches.get(axis, (ax.uncertainty_deg, 0.0))
            self.records.searches[axis] = (prior, shift + mech_deg - ax.meas_deg)
            self.rereference(ax, mech_deg, uncertainty_deg=max(prior, ax.caps.span_deg))
        self.submit("search_frame", apply)

    def end_search(self, axis: str, mech_deg: float | None = None) -> None:
        """End a reference search: the reference found (``mech_deg``, the true mechanical
        angle here), or None to go back to the true frame with the uncertainty there was."""
        core = self.core
        self.planner.check_axis(axis)

        def apply() -> None:
            if axis not in self.records.searches:
                return
            ax = core.axes[axis]
            prior, shift = self.records.searches.pop(axis)
            if mech_deg is None:
                self.rereference(ax, ax.meas_deg - shift, uncertainty_deg=prior)
            else:
                self.rereference(ax, mech_deg)
                core.event(f"{axis} re-referenced to {mech_deg:.2f} deg (mechanical) by its search")
        self.submit("end_search", apply)

    def set_overshoot(self, axis: str, overshoot_deg: float) -> None:
        """Set the coast estimate of a relay axis (Tartu OVRA/OVRE); it keeps learning."""
        core = self.core
        if axis not in AXES:
            raise CommandRejected(f"overshoot needs axis az|el, got {axis!r}")
        if axis == "el":
            self.planner.require_el("elevation overshoot")
        if not (math.isfinite(overshoot_deg) and 0.0 <= overshoot_deg <= 20.0):
            raise CommandRejected(f"overshoot {overshoot_deg!r} outside 0..20 deg")
        ax = core.axes[axis]
        levels = ax.tuning.drive_levels or (1.0,)

        def apply() -> None:
            # the coast scales with the speed of each drive level
            ax.law = replace(ax.law, coast_deg=tuple(overshoot_deg * lv / max(levels) for lv in levels))
            self.records.mark_dirty()
        self.submit("set_overshoot", apply)

    def overshoot_deg(self, axis: str) -> float:
        """The present coast estimate at full drive (what OVRA/OVRE read)."""
        core = self.core
        if axis not in core.axes:
            raise CommandRejected(f"no {axis} axis on this rotator (azimuth only)", "no_axis")
        return max(core.axes[axis].law.coast_deg, default=0.0)

    def reconfigure(self, settings: RotatorSettings) -> None:
        """Apply new limits, keep-out zones, offsets, speeds, park and fault limits while
        running (the settings page). Motion in progress stops: its route was planned
        under the old rules. A new profile or loop rate needs a restart."""
        core = self.core
        settings = settings.completed()
        if settings.caps.name != core.caps.name or settings.caps.loop_hz != core.caps.loop_hz:
            raise CommandRejected("a new profile or loop rate takes effect at the next start")
        geometry = self.planner.geometry_for(settings)
        pose = core.current_pose()
        slack = max(core.caps.axis(n).tolerance_deg for n in core.axes)
        if not geometry.in_limits(*pose, slack_deg=slack):
            raise CommandRejected(f"the antenna (az {pose[0]:.1f}, el {pose[1]:.1f} mechanical) is outside "
                                  "the new limits: move it inside first", "limit")
        zone = geometry.zone_at(*pose, margin_deg=0.0)
        if zone is not None:
            raise CommandRejected(f"the antenna is inside the new keep-out zone {zone.name!r}: "
                                  "move it out first", "keepout")

        def apply() -> None:
            if core.program is not None:  # (planned under the old limits and zones)
                core.end_program("new settings applied")
            core.settings, core.geometry = settings, geometry
            self.guard.set_stall_rule(settings)
            for name, ax in core.axes.items():
                ax.tuning, ax.flim, ax.limits = settings.tuning(name), settings.fault_limits(name), \
                    settings.limits(name)
                ax.sp = None
            core.route = []
            core.tracking = False
            core.parked = core.parking = False
            core.target_sky = None
            core.event("new settings applied (limits, keep-out zones, offsets, speeds, park)")
        self.submit("reconfigure", apply)

    def start_route(self, route: list[tuple[float, float]]) -> None:
        core = self.core
        core.route = list(route)
        self.set_waypoint(core.route[0])

    def set_waypoint(self, pose: tuple[float, float]) -> None:
        core = self.core
        seq = core.next_seq()
        now = core.clock.now_s()
        for ax, p in zip(core.axes.values(), pose):
            ax.sp = law.Setpoint(p, 0.0, now, seq=seq)

    def advance_route(self) -> None:
        core = self.core
        if len(core.route) <= 1:
            return
        if all(ax.law.mode == "holding" and ax.law.seq == ax.sp.seq for ax in core.axes.values()
               if ax.sp is not None):
            core.route.pop(0)
            self.set_waypoint(core.route[0])

    def check_parked(self) -> None:
        """A park under way is done once its last waypoint is held on both axes."""
        core = self.core
        if not core.parking:
            return
        park = {"az": core.settings.park_az_deg, "el": core.settings.park_el_deg}
        if len(core.route) <= 1 and all(
                ax.sp is not None and ax.law.seq == ax.sp.seq and ax.law.mode == "holding"
                and abs(ax.meas_deg - park[n]) <= ax.tuning.restart_deg + ax.caps.sensor.resolution_deg
                for n, ax in core.axes.items()):
            core.parking, core.parked = False, True

    def maybe_idle_park(self, now_s: float) -> None:
        core = self.core
        idle_s = core.settings.idle_park_s
        if idle_s <= 0 or core.parked or core.parking or core.faults or core.tracking or core.position_uncertain():
            return
        if now_s - core.last_command_t_s >= idle_s and not core.moving():
            try:
                self.park()
                core.event(f"auto-park after {idle_s:g} s idle")
            except CommandRejected as exc:
                core.event(f"auto-park refused: {exc}")
                core.last_command_t_s = now_s
