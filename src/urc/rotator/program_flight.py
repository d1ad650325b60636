"""The control process's flight of a pass program (:class:`urc.model.program.PassProgram`,
what a program is and why the control process flies it: that module's docstring)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..control.geometry import route_time_s
from ..errors import CommandRejected
from ..model.program import PassProgram, rejoin_aim
from ..model.settings import FIXED_EL_DEG

if TYPE_CHECKING:
    from .commands import Commands
    from .core import Core

#: how often the flown track's setpoint is refreshed (the law extrapolates with the
#: rates between refreshes; the tracker used the same period)
UPDATE_S = 0.2
#: a route round a keep-out zone may take this much longer than its travel at full speed
ROUTE_SLACK_S = 3.0


class ProgramFlight:
    """Flies the loaded pass program, one tick at a time (under the rotator's lock):
    accepts and checks a program, pre-positions, follows, goes round keep-out zones, ends
    it at LOS. Holds the flight's own state; the program itself lives in the Core (the
    status shows it) and the motions go through the rotator's Commands."""

    def __init__(self, core: Core, commands: Commands):
        self.core = core
        self.commands = commands
        #: the pre-position move sent, the next track update, a route round a keep-out
        #: zone flown until then
        self.pre_sent = False
        self.next_update_s = -math.inf
        self.route_until_s = -math.inf

    def accept(self, program: PassProgram) -> None:
        """Accept a pass program (urc.model.program): every pose it may fly inside the
        limits and outside the keep-out zones, checked now; flown from the next tick by
        this process's own clock. Replaces a program loaded before."""
        core = self.core
        self.commands.require_motion_ok(automatic=True)
        why = program.problem()
        if why:
            raise CommandRejected(f"refused: {why}", "invalid")
        if program.los_s <= core.clock.now_s():
            raise CommandRejected(f"refused: the pass of {program.name} is over", "invalid")
        g = core.geometry
        single = "el" not in core.axes
        for az, el, blocked in zip(program.az_deg, program.el_deg, program.blocked):
            if blocked:
                continue  # (not flown: the antenna waits at the zone's edge)
            el = FIXED_EL_DEG if single else el
            if not g.in_limits(az, el, slack_deg=1e-6):
                raise CommandRejected(f"refused: {program.name}'s pose az {az:g}, el {el:g} is outside the "
                                      "limits", "limit")
            zone = g.zone_at(az, el, margin_deg=0.0)
            if zone is not None:
                raise CommandRejected(f"refused: {program.name}'s pose az {az:g}, el {el:g} is in keep-out "
                                      f"zone {zone.name!r}", "keepout")

        def apply() -> None:
            if core.program is not None:
                core.end_program(f"replaced by program {program.program_id}")
            core.program, core.program_state = program, "waiting"
            self.pre_sent, self.next_update_s, self.route_until_s = False, -math.inf, -math.inf
        self.commands.submit("program", apply)

    def cancel(self, program_id: int | None = None) -> None:
        """End the pass program (``program_id``: only if it is that one); the axes stop
        if it was flying."""
        core = self.core

        def apply() -> None:
            p = core.program
            if p is None or (program_id is not None and p.program_id != program_id):
                return
            flying = core.motion == "program"
            core.end_program("cancelled")
            if flying:
                core.target_sky = None
                self.commands.halt(list(core.axes))
        self.commands.submit("cancel_program", apply)

    def advance(self, now_s: float) -> None:
        """Fly the pass program one tick (under the lock): pre-position, follow, end."""
        core = self.core
        p = core.program
        if p is None:
            return
        if now_s >= p.los_s:
            self._end_pass(p, now_s)
            return
        if core.faults:  # paused until cleared; then from where the satellite is
            self.pre_sent, self.next_update_s = False, -math.inf
            return
        if now_s < p.preposition_start_s:
            core.program_state = "waiting"
            return
        core.motion = "program"
        if now_s < p.aos_s:
            core.program_state = "prepositioning"
            if not self.pre_sent:
                self.pre_sent = True
                core.event(f"pre-positioning for {p.name} at az {p.aos_pose[0]:.1f} el {p.aos_pose[1]:.1f}")
                self._fly_to(p.aos_pose, now_s)
            return
        core.program_state = "tracking"
        if now_s < self.next_update_s:
            return
        self.next_update_s = now_s + UPDATE_S
        if p.blocked[p.index_at(now_s)]:
            return  # inside a keep-out zone: wait at its edge
        if now_s < self.route_until_s and core.moving():
            return  # flying round a zone to rejoin the track
        az, el, az_rate, el_rate = p.pose_at(now_s)
        if self._round_zones(p, (az, el), now_s):
            return
        core.target_sky = core.geometry.to_sky(az, el)
        self.commands.follow((az, el), (az_rate, el_rate), now_s, motion="program")

    def _fly_to(self, pose: tuple[float, float], now_s: float) -> bool:
        """A route to ``pose`` round the keep-out zones (the pre-position move)."""
        core = self.core
        route = self.commands.planner.route_to_pose(pose)
        if route is None:
            core.end_program(f"no legal path to az {pose[0]:.1f}, el {pose[1]:.1f}")
            core.event(f"pass program ended: no legal path to az {pose[0]:.1f}, el {pose[1]:.1f}")
            return False
        core.parked = core.parking = False
        core.tracking = False
        core.target_sky = core.geometry.to_sky(*pose)
        self.commands.start_route(route)
        return True

    def _round_zones(self, p: PassProgram, pose: tuple[float, float], now_s: float) -> bool:
        """If the straight way to the track crosses a keep-out zone (the track came out
        from behind one), fly round it to where the track will be on arrival; True if so."""
        core = self.core
        here, rates = core.current_pose(), core.rates()
        aim = rejoin_aim(core.geometry, here, pose, rates, lambda dt_s: p.pose_at(now_s + dt_s)[:2])
        if aim is None:
            return False
        if not self._fly_to(aim, now_s):
            return True
        self.route_until_s = now_s + route_time_s([here] + core.route, rates) + ROUTE_SLACK_S
        core.event(f"going round a keep-out zone to az {aim[0]:.1f} el {aim[1]:.1f}")
        return True

    def _end_pass(self, p: PassProgram, now_s: float) -> None:
        core = self.core
        flying = core.motion == "program"
        core.end_program("done")
        core.event(f"pass of {p.name} ended")
        if not flying or core.faults:
            return
        if p.end == "park":
            try:
                self.commands.park()
            except CommandRejected as exc:
                core.event(f"park after the pass refused: {exc}")
            return
        # hold the LOS pose: the last update's speed must not carry the antenna on
        self.commands.follow(p.los_pose, (0.0, 0.0), now_s, motion="program")
        core.motion = None
