"""The tracker: feeds the rotator service time-tagged setpoints with feed-forward.

A satellite is flown pass by pass: each pass is planned whole before it starts (wrap,
flip, rate limits, keep-out, see planner.py) and the plan is handed to the rotator as a
program (urc.model.program): the control process then pre-positions at the AOS pose in
time, follows the planned trajectory smoothly (moving setpoints, not threshold jumps)
and parks after LOS if configured, by its own clock, whether or not this process is
running meanwhile. The tracker watches the program's state in the status, uploads it
again to a control process that restarted, and plans the next pass. Continuous targets (Sun, Moon, a fixed direction, a
place, a balloon) are followed while above the horizon.

Sans-I/O in time: ``step(now_s)`` is called periodically by the control loop (or a test
on a virtual clock); ``unix_at(now_s)`` maps the loop's clock to UTC.
"""

from __future__ import annotations

import itertools
import logging
import math
from dataclasses import dataclass, replace
from typing import Any, Callable

import numpy as np

from ..control.geometry import route_time_s
from ..errors import CommandRejected
from ..model.program import PassProgram, rejoin_aim
from ..model.settings import FIXED_EL_DEG
from .elements import ElementSet
from .passes import Pass, find_passes
from .planner import AxisLimits, Plan, PlanError, plan_pass
from .station import Station
from .targets import SatelliteTarget, Target

log = logging.getLogger(__name__)

#: how often setpoints are refreshed; between updates the law extrapolates with the rate
UPDATE_S = 0.2
#: pass track sample step for planning
PLAN_STEP_S = 1.0
#: a route round a keep-out zone may take this much longer than its travel at full speed
ROUTE_SLACK_S = 3.0
#: how far ahead the next pass of a followed satellite is searched
SEARCH_HOURS = 24.0
#: elements older than this (days from their epoch) are flagged when tracked: a LEO set
#: drifts by kilometres a day, so the pass times and pointing slip
STALE_ELEMENTS_DAYS = 14.0
EARTH_RADIUS_KM = 6371.0
#: a continuous target whose path is known ahead (Sun, Moon) is planned over its arc above
#: the horizon, this far ahead at most, in steps of ARC_STEP_S
ARC_HORIZON_S = 24 * 3600.0
ARC_STEP_S = 60.0
#: the exact target is flown on the arc plan's wrap turn and flip; where it is further than
#: this from the plan's pose, the plan's pose is flown (a keyhole: the plan holds the azimuth)
ARC_FOLLOW_DEG = 0.5


#: program ids: unique within this process (a restarted control process knows none)
_PROGRAM_IDS = itertools.count(1)
#: a program uploaded this long ago that the status does not show is sent again (the
#: control process restarted, or lost it): it takes it at its next tick
PROGRAM_RESEND_S = 0.5


@dataclass
class _PassJob:
    target: SatelliteTarget
    pass_: Pass
    plan: Plan
    state: str = "waiting"  # waiting -> prepositioning -> tracking -> done
    #: the program flying it (urc.model.program), and when it was last sent
    program_id: int | None = None
    sent_s: float = -math.inf
    #: its step-track (urc.peaking.steptrack), made when the tracker has ``step_track``
    steptrack: Any = None


def _standing_deg(axis: Any, moving: bool) -> float:
    """Where an axis will stand, for the pre-positioning's travel: the end of the motion
    under way (a park after the last pass goes on until the next pass's pre-positioning
    starts; planned from where it was, a G-5500 parking 400 deg started 30 s late and
    met a pass 108 deg off: busy_soak), else where it is."""
    if moving and axis.target_deg is not None:
        return float(axis.target_deg)
    return float(axis.pos_deg)


class Tracker:
    def __init__(self, rotator, station: Station, unix_at: Callable[[float], float], *,
                 park_after_pass: bool = True, min_el_deg: float = 0.0):
        self.rot = rotator
        self.station = station
        self.unix_at = unix_at
        self.park_after_pass = park_after_pass
        self.min_el_deg = min_el_deg
        self.target: Target | None = None
        self.job: _PassJob | None = None
        self.follow_satellite = False
        self.last_error = ""
        self._next_update_s = -math.inf
        self._ground_cache: tuple | None = None
        self._route_until_s = -math.inf  # a routed move round a zone runs until then
        #: the plan of a continuous target's arc (wrap turn and flip) and whether the arc
        #: goes on past its end (cut at ARC_HORIZON_S, not at the horizon): re-planned then
        self._arc: Plan | None = None
        self._arc_goes_on = False
        self._arc_retry_u = -math.inf  # no arc could be planned: not tried again before then
        self._arc_pending: Any = None  # (generation, Future) of an arc planned on ``background``
        #: where the next pass is searched and planned: None = at once, in the caller (tests
        #: on virtual time); an executor (``urc run``) keeps that work off the event loop,
        #: whose silence would stop the axes (issue 21: 8 s after `urc track` and at LOS)
        self.background: Any = None
        self._planning: Any = None  # the pending search (a Future), its result installed by step
        self._generation = 0        # bumped by every command: a stale search is dropped
        #: newer elements for the satellite being followed, used from its next pass
        self._next_elements: ElementSet | None = None
        #: step-track: ``step_track(job, tracker)`` makes a pass's StepTrack
        #: (urc.peaking.steptrack.factory), which corrects its program by the signal
        self.step_track: Callable[[Any, Any], Any] | None = None

    # ------------------------------------------------------------------ commands
    def track(self, target: Target, now_s: float) -> None:
        """Follow a target: a satellite pass after pass, anything else continuously."""
        self.stop_tracking()
        self.target = target
        if isinstance(target, SatelliteTarget):
            self.follow_satellite = True
            self._plan_next(target, now_s)
        self._next_update_s = -math.inf

    def track_pass(self, elements: ElementSet, p: Pass, now_s: float) -> Plan:
        """Fly one given pass (the web page's "track this pass"), planned here."""
        return self.fly(self.plan_pass(elements, p, now_s))

    def plan_pass(self, elements: ElementSet, p: Pass, now_s: float) -> _PassJob:
        """One given pass and its plan; pure like ``_search_and_plan`` (a worker may run it)."""
        target = SatelliteTarget(elements, self.station)
        return _PassJob(target, p, self._plan(target, p, now_s))

    def fly(self, job: _PassJob) -> Plan:
        """Fly a pass planned by ``plan_pass``."""
        self.stop_tracking()
        self.target, self.job = job.target, job
        return job.plan

    def start_pass(self, elements: ElementSet, p: Pass, now_s: float) -> None:
        """Fly one given pass (a scheduled one), planned on ``background`` when there is
        one: planning a pass costs up to seconds of CPU, and on the event loop its
        silence stopped the axes mid-pre-positioning (issue 21). Status says "planning"
        until ``step`` installs the plan."""
        if self.background is None:
            self.track_pass(elements, p, now_s)
            return
        self.stop_tracking()
        target = SatelliteTarget(elements, self.station)
        self.target = target
        self._generation += 1
        self._planning = (self._generation, self.background.submit(self._plan_or_why, target, p, now_s))

    def _plan_or_why(self, target: SatelliteTarget, p: Pass, now_s: float) -> tuple[_PassJob | None, str]:
        try:
            return _PassJob(target, p, self._plan(target, p, now_s)), ""
        except PlanError as exc:
            return None, f"{target.name}: {exc}"

    def stop_tracking(self) -> None:
        job = self.job
        if job is not None and job.steptrack is not None:
            job.steptrack.close()
        if job is not None and job.program_id is not None:
            try:  # (only that program: one the operator loaded since is left alone)
                self.rot.cancel_program(job.program_id)
            except CommandRejected as exc:
                log.warning("cancelling the pass program of %s: %s", job.target.name, exc)
        self.target = None
        self.job = None
        self._generation += 1
        self._planning = None
        self._next_elements = None
        self._arc = None
        self._arc_retry_u = -math.inf
        self._arc_pending = None
        self.follow_satellite = False
        self.last_error = ""

    @property
    def arc(self) -> Plan | None:
        """The plan of the continuous target's arc being flown (Sun, Moon), if any."""
        return self._arc

    # ------------------------------------------------------------------ planning
    def _axis_limits(self) -> tuple[AxisLimits, AxisLimits]:
        s = self.rot.settings
        return (AxisLimits(s.az_tuning.max_rate_deg_per_s, s.az_tuning.accel_deg_per_s2),
                AxisLimits(s.el_tuning.max_rate_deg_per_s, s.el_tuning.accel_deg_per_s2))

    def _plan(self, target: SatelliteTarget, p: Pass, now_s: float) -> Plan:
        t = np.arange(p.aos_unix_s, p.los_unix_s + PLAN_STEP_S, PLAN_STEP_S)
        t[-1] = min(t[-1], p.los_unix_s)
        la = target.look(t)
        st = self.rot.status()
        az, el = self._axis_limits()
        if st.el is not None:
            # the plan's time base is UTC; the pre-positioning start is compared in UTC too
            return plan_pass(t, la.az_deg, la.el_deg, self.rot.geometry, az, el,
                             (_standing_deg(st.az, st.moving), _standing_deg(st.el, st.moving)), self.unix_at(now_s))
        # a single-axis rotator: the azimuth follows the whole pass (above min_el) with
        # the beam at the horizon; no flip, no elevation targets. The plan keeps the
        # satellite's true elevation for display.
        beam_el = np.full_like(la.el_deg, FIXED_EL_DEG)
        plan = plan_pass(t, la.az_deg, beam_el, self.rot.geometry, az, el,
                         (_standing_deg(st.az, st.moving), FIXED_EL_DEG), self.unix_at(now_s))
        return replace(plan, sky_el_deg=np.asarray(la.el_deg, dtype=float))

    def use_elements(self, elements: ElementSet) -> bool:
        """Newer elements for the satellite being followed: used from its next pass (the
        pass being flown keeps its plan). False if that satellite is not followed."""
        if not (isinstance(self.target, SatelliteTarget) and self.follow_satellite
                and self.target.elements.norad_id == elements.norad_id):
            return False
        self._next_elements = elements
        return True

    @property
    def generation(self) -> int:
        """Bumped by every tracking command: work planned meanwhile is stale."""
        return self._generation

    @property
    def planning(self) -> bool:
        """A search for the next pass is running in the background."""
        return self._planning is not None

    def _plan_next(self, target: SatelliteTarget, now_s: float) -> None:
        if self._next_elements is not None:
            target = SatelliteTarget(self._next_elements, self.station)
            self.target, self._next_elements = target, None
        self.job = None
        if self.background is None:
            self._install(self._search_and_plan(target, now_s))
            return
        self._generation += 1
        self._planning = (self._generation, self.background.submit(self._search_and_plan, target, now_s))

    def _collect(self) -> None:
        """Install a background search once it is done (on the caller's thread)."""
        generation, future = self._planning
        if not future.done():
            return
        self._planning = None
        if generation != self._generation:
            return  # the operator asked for something else meanwhile
        try:
            result = future.result()
        except Exception as exc:  # a bad element set, a bug: shown, never raised into the loop
            log.exception("planning the next pass failed")
            result = None, f"planning the next pass failed: {exc}"
        self._install(result)

    def _install(self, result: tuple[_PassJob | None, str]) -> None:
        self.job, self.last_error = result
        if self.job is None and not self.follow_satellite and self.target is not None:
            # one given pass (scheduled) that cannot be flown: said, and the schedule goes on
            log.warning("pass not flown: %s", self.last_error)
            self.target = None

    def _search_and_plan(self, target: SatelliteTarget, now_s: float) -> tuple[_PassJob | None, str]:
        """The next pass of ``target`` and its plan, or (None, why not). Pure: it may run
        on a worker thread (it reads the rotator's immutable status only)."""
        now_u = self.unix_at(now_s)
        if target.elements.sgp4_error:
            return None, f"{target.name}: {target.elements.sgp4_error} at the elements' epoch: " \
                "import newer elements"
        passes = [p for p in find_passes(target.elements, self.station, now_u,
                                         duration_s=SEARCH_HOURS * 3600, min_el_deg=self.min_el_deg)
                  if p.los_unix_s > now_u + 1.0]
        if not passes:
            return None, f"{target.name}: no pass in the next {SEARCH_HOURS:g} h"
        try:
            return _PassJob(target, passes[0], self._plan(target, passes[0], now_s)), ""
        except PlanError as exc:
            return None, f"{target.name}: {exc}"

    # ------------------------------------------------------------------ the loop
    def step(self, now_s: float) -> None:
        if self._planning is not None:
            self._collect()
        if now_s < self._next_update_s or self.target is None:
            return
        self._next_update_s = now_s + UPDATE_S
        try:
            if self.job is not None:
                self._step_pass(now_s)
            elif not isinstance(self.target, SatelliteTarget):
                self._step_continuous(now_s)
        except CommandRejected as exc:
            # a fault or keep-out refuses this update; keep trying, show why
            self.last_error = str(exc)

    def _step_pass(self, now_s: float) -> None:
        """The control process flies the pass (its program); here it is uploaded, sent
        again to a control process that lost it (restarted), and its end is taken."""
        job = self.job
        assert job is not None  # (step calls this only with a job)
        st = self.rot.status()
        if job.program_id is not None:
            if st.program is not None and st.program["id"] == job.program_id:
                job.state = st.program["state"]
                if self.step_track is not None:
                    self._step_track(job, st, now_s)
                return
            end = st.program_end
            if end is not None and end["id"] == job.program_id:
                self._program_ended(job, end["why"], now_s)
                return
            if st.t_s < job.sent_s + PROGRAM_RESEND_S:
                return  # (taken at the control process's next tick)
        if self.unix_at(now_s) >= job.pass_.los_unix_s:
            self._program_ended(job, "done", now_s)
            return
        self._upload(job, now_s)

    def _upload(self, job: _PassJob, now_s: float) -> None:
        plan = job.plan
        offset_s = self.unix_at(now_s) - now_s  # UTC minus the control loop's clock
        program = PassProgram(
            program_id=job.program_id or next(_PROGRAM_IDS), name=job.target.name,
            t_s=tuple((plan.t_s - offset_s).tolist()), az_deg=tuple(plan.az_deg.tolist()),
            el_deg=tuple(plan.el_deg.tolist()), blocked=tuple(plan.blocked.tolist()),
            preposition_start_s=min(plan.preposition_start_s - offset_s, float(plan.t_s[0] - offset_s)),
            end="park" if self.park_after_pass else "hold")
        resent = job.program_id is not None
        job.program_id, job.sent_s = program.program_id, now_s
        self.rot.fly_program(program)
        log.info("pass of %s %s to the control process (AOS %s)", job.target.name,
                 "uploaded again" if resent else "uploaded", job.pass_.aos.isoformat())

    @staticmethod
    def new_program_id() -> int:
        return next(_PROGRAM_IDS)

    def _step_track(self, job: _PassJob, st: Any, now_s: float) -> None:
        """Step-track: the pass's program replaced by the one its signal corrects (the
        control process checks its poses on accept, as any program's); said in events."""
        if job.steptrack is None:
            job.steptrack = self.step_track(job, self)  # type: ignore[misc]
        track = job.steptrack
        program = track.step(st, now_s, self.unix_at(now_s) - now_s, job.state)
        if program is not None:
            try:
                self.rot.fly_program(program)
                job.program_id, job.sent_s = program.program_id, now_s
            except CommandRejected as exc:  # the program flying keeps flying
                track.upload_refused(str(exc), self.unix_at(now_s))
        for text in track.take_events():
            log.info("%s", text)
            try:
                self.rot.announce(text)
            except Exception:  # (the control link busy or gone: the log line stands)
                log.debug("step-track event not announced", exc_info=True)

    def _program_ended(self, job: _PassJob, why: str, now_s: float) -> None:
        """The pass program is over: flown to LOS, or cut short (a stop or another
        command from a client: a person's word, never resumed by itself)."""
        job.state = "done"
        if job.steptrack is not None:
            job.steptrack.close()  # (its reader's thread; the status keeps its estimate)
        if why != "done":
            log.warning("pass of %s not flown on: %s", job.target.name, why)
            job.program_id = None  # (nothing to cancel any more)
            self.stop_tracking()
            self.last_error = f"pass of {job.target.name} not flown on: {why}"
            return
        log.info("pass of %s ended", job.target.name)
        if self.follow_satellite:
            self._plan_next(job.target, now_s)
        else:
            self.target = None
            self.job = None

    def _go_round_zones(self, az_m: float, el_m: float, now_s: float, plan: Plan | None = None,
                        u: float = 0.0) -> bool:
        """If the straight way from the antenna to a pose crosses a keep-out zone (the
        track came out from behind one, a pre-positioning move), fly a route round it,
        to where the track will be on arrival; True if so."""
        g = self.rot.geometry
        if not g.zones:
            return False
        st = self.rot.status()
        here = (st.az.pos_deg, FIXED_EL_DEG if st.el is None else st.el.pos_deg)
        az_lim, el_lim = self._axis_limits()
        rates = (az_lim.max_rate_deg_per_s, el_lim.max_rate_deg_per_s)
        pose = (az_m, el_m)
        aim = rejoin_aim(g, here, pose, rates, (lambda dt_s: plan.pose_at(u + dt_s)[:2]) if plan is not None
                         else (lambda _dt_s: pose))
        if aim is None:
            return False
        az_m, el_m = aim
        route = self.rot.goto_pose(az_m, el_m)
        self._route_until_s = now_s + route_time_s([here] + route, rates) + ROUTE_SLACK_S
        log.info("going round a keep-out zone to az %.1f el %.1f", az_m, el_m)
        return True

    def _step_continuous(self, now_s: float) -> None:
        u = self.unix_at(now_s)
        az, el = self.target.position(u)
        if el < self.min_el_deg:
            self.last_error = f"{self.target.name} is below {self.min_el_deg:g} deg elevation"
            self._arc = None  # the next rise is planned afresh
            return
        az_rate, el_rate = self.target.rate(u)
        arc = self._arc_for(u)
        if arc is None:
            self.rot.track(az, el, az_rate, el_rate, now_s)
        elif not (now_s < self._route_until_s and self.rot.status().moving):  # not flying round a zone
            pose = self._arc_pose(arc, u, az, el, az_rate, el_rate)
            if not self._go_round_zones(pose[0], pose[1], now_s, arc, u):
                self.rot.track_pose(*pose, now_s)
        self.last_error = ""

    # When a continuous target flips (issue 12, for a station left alone for a month).
    # The Sun and the Moon move predictably: their arc above the horizon is planned like a
    # pass when they rise (or tracking starts), and flown on the plan's wrap turn and
    # flip. So under flip = "auto" they fly over the top exactly when that saves an
    # unwind or a keyhole swing somewhere on the arc (the planner keeps the unflipped pose
    # whenever it is as good), decided before it matters, never by a 180 deg swing
    # mid-track: the Sun culminating across the wrap point (north of the zenith, south
    # of the tropic of Cancer or in southern summer, the midnight sun) no longer unwinds
    # 360 deg at noon. The wrap turn is chosen the same way on rotators that cannot flip.
    # A balloon (NMEA) or a fixed direction is not planned: a balloon's path beyond the
    # next minute is unknown, so a flip could cost a half-turn swing for nothing; it is
    # followed on the side it is on (continuity), and a fixed direction needs no side.
    def _arc_for(self, u: float) -> Plan | None:
        if not hasattr(self.target, "look") or isinstance(self.target, SatelliteTarget) \
                or not self.rot.settings.caps.has_el:  # a single-axis rotator: no side to choose
            return None
        if self._arc_pending is not None:  # (planned on ``background``: the loop never waits)
            generation, future = self._arc_pending
            if not future.done():
                return self._arc if self._arc is not None and u <= self._arc.t_s[-1] else None
            self._arc_pending = None
            if generation == self._generation:
                arc, goes_on, why = future.result()
                self._install_arc(arc, goes_on, why, u)
            return self._arc
        due = u >= self._arc_retry_u if self._arc is None else self._arc_goes_on and u > self._arc.t_s[-1]
        if due:
            continuing = self._arc is not None
            if self.background is None:
                arc, goes_on, why = self._plan_arc_or_why(u, continuing)
                self._install_arc(arc, goes_on, why, u)
            else:  # a day's arc costs tens of ms of numpy and skyfield: not on the event loop
                self._arc_pending = (self._generation, self.background.submit(self._plan_arc_or_why, u, continuing))
                return None if self._arc is None or u > self._arc.t_s[-1] else self._arc
        return self._arc

    def _install_arc(self, arc: Plan | None, goes_on: bool, why: str, u: float) -> None:
        if why:
            log.warning("%s: no plan for its arc (%s); followed on the side it is on", self.target.name, why)
        self._arc, self._arc_goes_on = arc, goes_on
        if arc is None:  # planning costs tens of ms: not at every update
            self._arc_retry_u = u + ARC_STEP_S

    def _plan_arc_or_why(self, u: float, continuing: bool) -> tuple[Plan | None, bool, str]:
        """(the arc's plan or None, whether the arc goes on past its end, why not); pure:
        it may run on a worker thread (it reads the rotator's immutable status only)."""
        try:
            arc, goes_on = self._plan_arc(u, continuing)
            return arc, goes_on, ""
        except PlanError as exc:
            return None, False, str(exc)
        except Exception as exc:  # (a bug: said, and the target followed on its side)
            log.exception("planning the arc failed")
            return None, False, repr(exc)

    def _plan_arc(self, u: float, continuing: bool) -> tuple[Plan | None, bool]:
        t = np.arange(u, u + ARC_HORIZON_S + ARC_STEP_S / 2, ARC_STEP_S)
        la = self.target.look(t)
        below = np.flatnonzero(la.el_deg < self.min_el_deg)
        goes_on = len(below) == 0
        n = len(t) if goes_on else int(below[0])
        if n < 2:
            return None, goes_on
        st = self.rot.status()
        az, el = self._axis_limits()
        arc = plan_pass(t[:n], la.az_deg[:n], la.el_deg[:n], self.rot.geometry, az, el,
                        (st.az.pos_deg, st.el.pos_deg), u, continuing=continuing)
        log.info("%s: arc planned for %.0f min: %s, wrap turn %d%s", self.target.name, (t[n - 1] - u) / 60,
                 "over the top" if arc.flip else "not flipped", arc.wrap_turns,
                 "".join(f"; {note}" for note in arc.notes))
        return arc, goes_on

    def _arc_pose(self, arc: Plan, u: float, az: float, el: float, az_rate: float,
                  el_rate: float) -> tuple[float, float, float, float]:
        """The mechanical pose and rates that point at (az, el) on the arc plan's side:
        its flip at this moment, the wrap turn nearest its pose."""
        g = self.rot.geometry
        plan_az, plan_el, plan_az_rate, plan_el_rate = arc.pose_at(u)
        az, el = g.boresight_of(az, el)  # (the beam on (az, el): a pointing model in force)
        if plan_el + g.el_offset_deg > 90.0:
            az, el, el_rate = az + 180.0, 180.0 - el, -el_rate
        az_m, el_m = az - g.az_offset_deg, el - g.el_offset_deg
        az_m += 360.0 * round((plan_az - az_m) / 360.0)
        if abs(az_m - plan_az) + abs(el_m - plan_el) > ARC_FOLLOW_DEG:
            return plan_az, plan_el, plan_az_rate, plan_el_rate
        return az_m, el_m, az_rate, el_rate

    # ------------------------------------------------------------------ status
    def status(self, now_s: float) -> dict[str, Any] | None:
        if self.target is None:
            return None
        u = self.unix_at(now_s)
        out: dict[str, Any] = {"target": self.target.name, "error": self.last_error or None,
                               "stopped": _not_following(self.rot.status()), "t_unix_s": u}
        try:
            out["az_deg"], out["el_deg"] = self.target.position(u)
            # with the rates, a status computed a second ago is brought up to date cheaply
            # (cycle.tracking_now) instead of showing where the target was then
            out["az_rate_deg_per_s"], out["el_rate_deg_per_s"] = self.target.rate(u)
        except Exception as exc:  # a target that cannot be computed now must not break status
            out["az_deg"] = out["el_deg"] = None
            out["error"] = str(exc)
        else:
            if not isinstance(self.target, SatelliteTarget) and out["el_deg"] < self.min_el_deg \
                    and not out["error"]:
                # said at once, not only from the next update on
                out["error"] = f"{self.target.name} is below {self.min_el_deg:g} deg elevation"
        if self.job is None and self._planning is not None:
            out["state"] = "planning"  # the next pass is being searched for and planned
        if self.job is not None:
            plan, p = self.job.plan, self.job.pass_
            step = max(1, len(plan.t_s) // 200)
            out["state"] = self.job.state
            out["plan"] = {"aos": p.aos.isoformat(), "los": p.los.isoformat(), "tca": p.tca.isoformat(),
                           "max_el_deg": p.max_el_deg, "flip": plan.flip, "wrap_turns": plan.wrap_turns,
                           **plan.summary(),
                           "track": [[_iso(t), float(a), float(e)] for t, a, e in
                                     zip(plan.t_s[::step], plan.sky_az_deg[::step], plan.sky_el_deg[::step])]}
            if self.job.steptrack is not None:
                out["step_track"] = self.job.steptrack.status(u)
        if self._arc is not None and self._arc.notes:
            out["warnings"] = list(self._arc.notes)  # e.g. the midnight sun: no turn holds a day
        if isinstance(self.target, SatelliteTarget):
            age_days = (u - self.target.elements.epoch_unix_s) / 86400.0
            if age_days > STALE_ELEMENTS_DAYS:
                out["warnings"] = [f"the elements of {self.target.name} are {age_days:.0f} days old "
                                   f"(epoch {self.target.elements.epoch:%Y-%m-%d}): pass times and "
                                   "pointing drift; update them (urc tle update)"]
            # the ground track costs ~15 ms of skyfield: recomputed every 10 s
            key = (self.target.elements.norad_id, int(u // 10))
            if self._ground_cache is None or self._ground_cache[0] != key:
                self._ground_cache = (key, _ground_track(self.target, u))
            out.update(self._ground_cache[1])
        return out


def _not_following(st) -> str | None:
    """Why the antenna is not following the target right now (None while it is): a
    latched fault stops tracking until cleared (updates resume then), a late control
    loop holds the motors for a moment."""
    if st.faults:
        return "stopped: fault latched (" + "; ".join(f.reason for f in st.faults) + \
            "); clear faults to resume"
    if st.loop.get("held"):
        return "paused: the control loop was late; resuming when it is on time"
    return None


def _iso(unix_s: float) -> str:
    from datetime import datetime, timezone
    return datetime.fromtimestamp(unix_s, timezone.utc).isoformat()


def _ground_track(target: SatelliteTarget, u: float) -> dict[str, Any]:
    """Sub-satellite points +-45 min, the current point and the footprint radius."""
    from skyfield.api import EarthSatellite, wgs84

    from . import sky
    ts = sky.timescale()
    sat = EarthSatellite.from_satrec(target.elements.satrec, ts)
    times = ts.from_datetimes([sky.utc_datetime(x) for x in np.arange(u - 2700.0, u + 2701.0, 60.0)])
    sub = wgs84.subpoint_of(sat.at(times))
    now = sat.at(ts.from_datetime(sky.utc_datetime(u)))
    here = wgs84.subpoint_of(now)
    height_km = float(wgs84.height_of(now).km)
    footprint_km = EARTH_RADIUS_KM * math.acos(EARTH_RADIUS_KM / (EARTH_RADIUS_KM + max(height_km, 0.0)))
    return {"ground_track": [[round(float(a), 3), round(float(o), 3)]
                             for a, o in zip(sub.latitude.degrees, sub.longitude.degrees)],
            "sat_lat_deg": float(here.latitude.degrees), "sat_lon_deg": float(here.longitude.degrees),
            "footprint_km": footprint_km}
