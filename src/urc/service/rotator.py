"""The rotator service: the single owner of both axes.

Everything else (protocol sessions, the tracker, the web page, the CLI) submits commands
through the public methods below and reads immutable :class:`Status` snapshots. Command
methods validate at once — limits, keep-out zones, faults and position uncertainty are
enforced here, once, for every source — and raise :class:`CommandRejected` before
anything moves; accepted commands are queued and applied by :meth:`tick`, the only code
that changes axis state.
"""

from __future__ import annotations

import collections
import functools
import logging
import math
import threading
from dataclasses import dataclass, replace
from typing import Any, Callable

from ..clock import Clock, VirtualClock
from ..control import faults as faultmod
from ..control import law
from ..control import positioner as positioner_law
from ..control.estimator import Estimate, FilterLimits, alpha_beta
from ..control.faults import Fault, FaultLimits, MonitorInputs, MonitorState
from ..control.geometry import Geometry, route_time_s, wrap360
from ..control.profile import stopping_distance_deg
from ..errors import CommandRejected, SensorError, StateFileError
from ..hardware.interfaces import AxisHardware, Hardware
from ..persistence import StateStore
from . import position_record as precord
from .settings import FIXED_EL_DEG, RotatorSettings
from .snapshot import AxisStatus, Status
from .state_writer import StateWriter
from .timing import LoopTiming

log = logging.getLogger(__name__)

AXES = ("az", "el")
#: guard look-ahead: how far ahead (seconds of current motion) keep-out zones are checked.
GUARD_LOOKAHEAD_S = 0.3
#: a speed estimate above this many times the axis' top speed is taken as its top speed
#: when predicting where it would stop
STOP_RATE_MARGIN = 1.25


class _Axis:
    """Per-axis runtime: sensor reading, unwrapping, filtering, law and monitor state."""

    def __init__(self, name: str, hw: AxisHardware, settings: RotatorSettings):
        self.name = name
        self.hw = hw
        #: set when an external controller closes this axis' loop (bridge backend)
        self.positioner = hw.positioner
        #: the target last posted to the positioner (None: stop)
        self.posted_deg: float | None = None
        self.caps = settings.caps.axis(name)
        self.tuning = settings.tuning(name)
        self.flim = settings.fault_limits(name)
        self.limits = settings.limits(name)
        self.modulo = self.caps.sensor.modulo_deg
        # A counting sensor reads count k anywhere from edge k to edge k+1: its middle is
        # the unbiased estimate (half a count is the whole error budget at the floor).
        self.count_centre_deg = 0.0 if self.caps.sensor.absolute else 0.5 * self.caps.sensor.resolution_deg
        self.noisy = self.caps.sensor.noise_deg > 0
        self.meas_deg = 0.0
        self.rate_deg_per_s = 0.0
        self.sensor_ok = False
        self.sensor_error = ""
        self.law = law.initial_state(self.tuning, 0.0)
        self.mon = MonitorState()
        self.sp: law.Setpoint | None = None
        self.out = law.OFF
        self.uncertainty_deg = 0.0
        self.current_a = 0.0
        self.limit_min = self.limit_max = False
        # Speed of a quantised sensor: the slope over a window ten counts long at
        # full speed (differencing tick to tick gives spikes of one count per tick).
        sensor = self.caps.sensor
        window_s = min(0.5, max(0.1, 10.0 * (sensor.resolution_deg + sensor.noise_deg) / self.caps.max_rate_deg_per_s))
        #: speed below which the axis counts as standing: 3 sigma of the estimate's noise
        #: (filtered noise ~0.42 x sensor noise, differenced over the window), at least
        #: two counts per second
        self.still_rate_deg_per_s = max(2 * sensor.resolution_deg, 0.5 * self.caps.min_rate_deg_per_s,
                                        3 * 0.84 * sensor.noise_deg / window_s)
        # the window is kept by time, not by tick count: catch-up ticks microseconds
        # apart would otherwise shrink it to nothing and turn noise into speed
        self.window_s = max(1, round(window_s * settings.caps.loop_hz)) / settings.caps.loop_hz
        self.history: collections.deque[tuple[float, float]] = collections.deque(maxlen=10_000)
        self._t_s = 0.0
        self._filter_rate = 0.0
        self.filter_limits = FilterLimits(1.0 / settings.caps.loop_hz, self.caps.max_rate_deg_per_s)

    @property
    def flim(self) -> FaultLimits:
        if self.positioner is None:
            return self._flim
        # a controller's reports arrive once per poll: between two, the axis may have
        # turned a whole poll period at full speed (not a sensor jump, nor a runaway
        # when it decelerated at its target), and progress shows a target's round trip
        # plus two reports late (not a stall)
        every_s = self.positioner.sample_interval_s()
        travel_deg = self._flim.max_rate_deg_per_s * every_s
        return replace(self._flim, sensor_jump_deg=self._flim.sensor_jump_deg + 2.0 * travel_deg,
                       runaway_deg=self._flim.runaway_deg + travel_deg,
                       stall_timeout_s=self._flim.stall_timeout_s + 2.0 * every_s + self.positioner.latency_s())

    @flim.setter
    def flim(self, value: FaultLimits) -> None:
        self._flim = value

    # ---- control ------------------------------------------------------------------
    def step(self, sp: law.Setpoint | None, now_s: float, dt_s: float) -> None:
        """The law's tick; a positioner axis gets a target to post instead of a duty."""
        if self.positioner is None:
            self.law, self.out = law.step(self.law, sp, self.meas_deg, now_s, dt_s, self.tuning,
                                          self.rate_deg_per_s)
            return
        self.law, self.out, self.posted_deg = positioner_law.step(
            self.law, sp, self.meas_deg, self.rate_deg_per_s, now_s, self.tuning,
            lead_s=self.positioner.latency_s(), still_rate_deg_per_s=self.still_rate_deg_per_s,
            band_deg=max(self.tuning.tolerance_deg, self.positioner.resolution_deg), limits_deg=self.limits)
        if sp is not None and self.out.duty == 0.0:
            # following its target within the band (a slow track goes in the controller's
            # steps): it is where it was told to be, so a runaway is judged from here
            self.mon = replace(self.mon, rest_deg=self.meas_deg)

    def post(self) -> None:
        """Positioner axes: post the target, or stop when there is no setpoint (stop,
        fault, guard, shutdown all clear it)."""
        if self.sp is None or self.posted_deg is None:
            self.positioner.stop()
        elif self.sp.speed_cap_deg_per_s is not None and self.sp.rate_deg_per_s == 0.0:
            # a jog (Rotator.move): the controller's own move, ended at posted_deg (the
            # limit or a zone's edge) by urc
            cap = self.sp.speed_cap_deg_per_s
            self.positioner.move(self.posted_deg, min(1.0, cap / self.tuning.max_rate_deg_per_s), cap)
        else:
            note = getattr(self.positioner, "note_position", None)
            if note is not None:
                note(self.meas_deg)  # the turn it is on: a compass protocol's report names none
            self.positioner.goto(self.posted_deg)

    # ---- sensing ------------------------------------------------------------------
    def set_reference(self, mech_deg: float, at_edge: bool = False) -> None:
        """Re-reference: the position estimate here becomes ``mech_deg``.

        ``at_edge``: the antenna is known to sit on a count edge (a mechanical home is
        one, like an index mark or a limit switch): ``mech_deg`` is then the lower edge of
        the current count and the estimate its middle."""
        ref = mech_deg - (0.0 if at_edge else self.count_centre_deg)
        self.hw.sensor.set_reference_deg(ref if self.modulo is None else ref % self.modulo)

    def unwrap(self, raw_deg: float, near_deg: float) -> float:
        if self.modulo is None:
            return raw_deg
        mech = raw_deg + self.modulo * round((near_deg - raw_deg) / self.modulo)
        # the turn nearest a guess (the park, at a start without saved state) can lie
        # outside the axis' range when another turn is inside it: that one it is
        lo, hi = self.limits
        margin = faultmod.RANGE_MARGIN_DEG
        if not lo - margin <= mech <= hi + margin:
            for alt in (mech - self.modulo, mech + self.modulo):
                if lo - margin <= alt <= hi + margin:
                    return alt
        return mech

    def read(self, dt_s: float) -> float | None:
        self._t_s += dt_s
        try:
            raw = self.hw.sensor.read_deg()
        except SensorError as exc:
            self.sensor_ok, self.sensor_error = False, str(exc)
            return None
        if not math.isfinite(raw):
            self.sensor_ok, self.sensor_error = False, f"non-finite reading {raw!r}"
            return None
        mech = self.unwrap(raw + self.count_centre_deg, self.meas_deg)
        if self.noisy and self.sensor_ok:
            est = alpha_beta(Estimate(self.meas_deg, self._filter_rate), mech, dt_s, self.filter_limits)
            self.meas_deg, self._filter_rate = est.pos_deg, est.rate_deg_per_s
        else:
            self.meas_deg = mech
        # the reported speed: slope over the window (the filter's own rate is too noisy)
        if self.positioner is not None:  # reports come once per poll: span one at least
            self.window_s = max(self.window_s, self.positioner.sample_interval_s())
        self.history.append((self._t_s, self.meas_deg))
        while len(self.history) > 2 and self.history[1][0] <= self._t_s - self.window_s + 1e-9:
            self.history.popleft()
        t_old, p_old = self.history[0]
        if self._t_s - t_old > 0:
            self.rate_deg_per_s = (self.meas_deg - p_old) / (self._t_s - t_old)
        self.sensor_ok, self.sensor_error = True, ""
        return mech

    def read_switches(self) -> None:
        self.limit_min = bool(self.hw.limit_min and self.hw.limit_min.is_active())
        self.limit_max = bool(self.hw.limit_max and self.hw.limit_max.is_active())
        try:
            self.current_a = float(self.hw.motor.read_current_a())
        except Exception:  # a current sense failure must not stop the loop
            self.current_a = 0.0

    def heading_deg(self, count_deg: float) -> float:
        """Where the drive takes the axis within GUARD_LOOKAHEAD_S. A drive that has
        only just started shows no speed yet but still heads where it pushes (else
        restarts could inch the antenna into a zone), and across gear play the sensor
        cannot see it throws the antenna that far on."""
        step = self.rate_deg_per_s * GUARD_LOOKAHEAD_S
        start_deg = count_deg + self.tuning.backlash_deg
        if self.out.duty and step * self.out.duty < start_deg:
            step = math.copysign(start_deg, self.out.duty)
        return self.meas_deg + step

    def stop_position_deg(self) -> float:
        """Where the axis would come to rest if told to stop now."""
        if self.tuning.drive == "relay":
            dist = max(self.law.coast_deg, default=0.0)
        else:
            # no faster than the axis can turn (with a margin for its calibration): a
            # faster estimate is an artefact of the readings (a late controller report
            # then a burst), and squared it made the guard stop a bridged axis 70 deg
            # short of its limit
            top_deg_per_s = STOP_RATE_MARGIN * self.caps.max_rate_deg_per_s
            rate_deg_per_s = max(-top_deg_per_s, min(top_deg_per_s, self.rate_deg_per_s))
            dist = stopping_distance_deg(rate_deg_per_s, self.tuning.accel_deg_per_s2)
        return self.meas_deg + math.copysign(dist, self.rate_deg_per_s)

    def planned_stop_deg(self) -> float | None:
        """Where the law's own braking brings the axis to rest, when the axis is seen to
        follow the law's reference (PWM, driving, within a couple of counts of it); None
        otherwise. The measured speed is a slope over a window, so it lags a braking
        axis and overstates its stopping distance (a goto to a limit was cut short)."""
        if self.tuning.drive != "pwm" or self.law.mode != "driving":
            return None
        if abs(self.meas_deg - self.law.ref_deg) > self.tuning.tolerance_deg + 2 * self.caps.sensor.resolution_deg:
            return None
        rate = self.law.ref_rate_deg_per_s
        return self.meas_deg + math.copysign(stopping_distance_deg(rate, self.tuning.accel_deg_per_s2), rate)

    def status(self) -> AxisStatus:
        return AxisStatus(
            pos_deg=self.meas_deg, rate_deg_per_s=self.rate_deg_per_s,
            target_deg=None if self.sp is None else self.sp.target_deg, mode=self.law.mode,
            duty=self.out.duty, brake_released=self.out.brake_released,
            uncertainty_deg=self.uncertainty_deg, limit_min=self.limit_min,
            limit_max=self.limit_max, current_a=self.current_a,
            sensor_ok=self.sensor_ok, sensor_error=self.sensor_error)


@dataclass(frozen=True)
class _Command:
    name: str
    apply: Callable[[], None]


def _driver_fault(axis: str, motor: Any, now_s: float) -> Fault | None:
    """A motor bridge's own fault output (VNH5019 EN/DIAG, LMD18200 thermal flag,
    BTS7960 IS fault current), where the driver reads one."""
    read = getattr(motor, "driver_fault", None)
    if read is None:
        return None
    try:
        reason = read()
    except Exception as exc:  # an unreadable fault pin is itself a reason to stop
        reason = f"{axis} motor: its fault output cannot be read ({exc})"
    return Fault("driver", axis, reason, now_s) if reason else None


class Rotator:
    def __init__(self, settings: RotatorSettings, hardware: Hardware, clock: Clock,
                 store: StateStore | None = None):
        # every output safe before anything else (a restart may find a motor driving)
        hardware.drive_safe()
        self.settings = settings.completed()
        self.caps = self.settings.caps
        self.hw = hardware
        #: held by the tick and by every command method (see the end of this module): the
        #: loop runs on its own thread, commands come from the asyncio thread
        self.lock = threading.RLock()
        self.clock = clock
        self.store = store
        self.geometry: Geometry = self.settings.geometry()
        # a single-axis rotator has no elevation _Axis at all: its beam stays at
        # FIXED_EL_DEG, which the pose maths below stand in for
        self.axes = {n: _Axis(n, hardware.axis(n), self.settings) for n in self.caps.axes}
        self._commands: collections.deque[_Command] = collections.deque()
        self._route: list[tuple[float, float]] = []
        self._faults: list[Fault] = []
        self._events: collections.deque[str] = collections.deque(maxlen=20)
        self._seq = 0
        self._target_sky: tuple[float, float] | None = None
        self._parked = False
        #: a park accepted and under way: parked once both axes hold at the park pose
        self._parking = False
        self._last_t_s: float | None = None
        self._last_command_t_s = clock.now_s()
        # state records (see position_record): the last one handed to the writer, the
        # newest known to be on disk with its windows, and why saving fails, if it does
        self._writer = None if store is None else StateWriter(
            store, background=not isinstance(clock, VirtualClock), now_s=clock.now_s)
        self._record: dict[str, Any] | None = None
        self._recent: collections.deque[tuple[dict[str, Any], dict[str, tuple[float, float]]]] = \
            collections.deque(maxlen=8)
        self._durable: dict[str, Any] | None = None
        self._durable_windows: dict[str, tuple[float, float]] = {}
        self._record_dirty = False
        self._save_error = ""
        #: reference searches in progress (homing): axis -> (uncertainty before, frame shift)
        self._searches: dict[str, tuple[float, float]] = {}
        self.timing = LoopTiming(self.settings.watchdog_s)
        self._set_stall_rule(self.settings)
        self._heartbeat = False
        self._was_held = False
        self._status: Status | None = None
        self._tracking = False
        #: local controls held now (front-panel buttons, IR keys): the local operator wins
        self._local_holds: set[str] = set()
        self._restore()
        # (after the restore: a sensor constant restored with it may turn bearings)
        self.geometry = self._geometry_for(self.settings)
        self._status = self._build_status(clock.now_s())

    # ======================================================================== startup
    def _restore(self) -> None:
        """Bring back position, wrap and calibration from the state file, and write the
        record of what was concluded before anything can move (a crash right after
        start-up must find it, not an older or missing file)."""
        payload: dict[str, Any] | None = None
        # with no store (tests, tools) the antenna is where the simulator starts it
        fresh = self.store is None or self.store.fresh()
        if self.store is not None:
            try:
                payload = self.store.load()
            except StateFileError as exc:
                self._event(f"state file damaged, not trusted: {exc}")
                self.store.quarantine()
            if payload is not None and payload.get("profile") != self.caps.name:
                self._event(f"state file belongs to profile {payload.get('profile')!r}, ignored")
                payload = None
            elif payload is None and not fresh:
                self._event("no usable state file in a state directory used before")
        # a used state directory without a usable record: where the antenna is, is unknown
        lost = payload is None and not fresh
        now = self.clock.now_s()
        self.hw.poll(now)
        saved_axes = (payload or {}).get("axes", {})
        # with nothing saved, assume the mechanical home where the profile's rotator
        # rests (sky park may differ by the mount offsets)
        home = {"az": self.caps.az.park_deg, "el": self.caps.el.park_deg}
        for name, ax in self.axes.items():
            saved = saved_axes.get(name)
            saved = saved if isinstance(saved, dict) else None
            # a record without this axis (written while the rotator ran single-axis):
            # where the axis is now is unknown
            lost_axis = lost or (payload is not None and saved is None)
            if saved and saved.get("calibration"):
                try:
                    ax.hw.sensor.load_calibration(saved["calibration"])
                except Exception as exc:  # a bad calibration must not prevent start-up
                    self._event(f"{name}: saved calibration rejected ({exc})")
            if saved and saved.get("coast_deg"):
                coast = tuple(float(c) for c in saved["coast_deg"])
                if len(coast) == len(ax.law.coast_deg):
                    ax.law = replace(ax.law, coast_deg=coast)
            win = precord.saved_window(saved) if saved else None
            anchor = float(saved["mech_deg"]) if saved else home[name]
            if win is not None and not precord.known_window(ax, win):
                anchor = (win[0] + win[1]) / 2.0
            if not ax.caps.sensor.absolute:
                self._restore_incremental(ax, saved, win, lost_axis, anchor)
            ax.meas_deg = anchor
            if ax.read(0.0) is None:
                self._event(f"{name}: sensor unreadable at start-up ({ax.sensor_error})")
            else:
                self._check_ambiguity(ax, saved, win, lost_axis)
            if saved and saved.get("uncertainty_deg"):
                ax.uncertainty_deg += float(saved["uncertainty_deg"])
            ax.law = replace(ax.law, ref_deg=ax.meas_deg, last_meas_deg=ax.meas_deg)
        if self.position_uncertain():
            self._event("position uncertain: automatic motion refused until re-referenced "
                        "(set position)")
        if self._writer is not None and self.store is not None:
            if self._submit_record(now, wait=True):
                self.store.mark_initialised()

    def _restore_incremental(self, ax: _Axis, saved: dict | None, win: tuple[float, float] | None,
                             lost: bool, anchor: float) -> None:
        if saved is None:
            ax.set_reference(anchor, at_edge=True)  # resting at its mechanical home
            if lost:
                ax.uncertainty_deg = ax.caps.span_deg
            else:
                self._event(f"{ax.name}: first start in this state directory; assuming park "
                            f"{anchor:.1f} deg (set position if the antenna is elsewhere)")
            return
        if win is None:
            # a record without a window (an older urc): only a standing one is trusted
            if saved.get("moving"):
                ax.uncertainty_deg = ax.caps.span_deg
        elif not precord.known_window(ax, win):
            # it died on the move: the axis is somewhere in the window the record promised
            ax.uncertainty_deg = (win[1] - win[0]) / 2.0 + precord.estimate_slack_deg(ax)
        ax.set_reference(anchor)

    def _check_ambiguity(self, ax: _Axis, saved: dict | None, win: tuple[float, float] | None,
                         lost: bool) -> None:
        """A reading that could also mean another position within the limits (another
        turn of a sensor modulo 360; the other side of the zenith of a folded report):
        the record must tell which, else the axis is uncertain by the distance."""
        lo, hi = ax.limits
        fold = ax.caps.sensor.fold_deg
        alternatives = [ax.meas_deg + k * ax.modulo for k in (-1, 1)] if ax.modulo is not None else []
        if fold is not None and abs(ax.meas_deg - fold) > precord.hold_band_deg(ax):
            alternatives.append(2.0 * fold - ax.meas_deg)
        alternatives = [a for a in alternatives if lo <= a <= hi]
        if not alternatives:
            return
        apart_deg = max(abs(a - ax.meas_deg) for a in alternatives)
        slack = precord.estimate_slack_deg(ax)
        if saved is None:
            if lost:
                ax.uncertainty_deg = apart_deg
            else:
                self._event(f"{ax.name}: first start in this state directory; assuming "
                            f"{ax.meas_deg:.1f} deg, nearest park (also possible: "
                            f"{', '.join(f'{a:.1f}' for a in alternatives)})")
        elif win is not None and any(win[0] - slack <= a <= win[1] + slack for a in alternatives):
            ax.uncertainty_deg = apart_deg  # the record cannot tell which
        elif win is None and saved.get("moving"):
            ax.uncertainty_deg = apart_deg

    # ====================================================================== the tick
    def tick(self, deadline_s: float | None = None) -> Status:
        """Advance the whole rotator by one control period. Only this mutates state.

        ``deadline_s``: when this tick was due (the real-time loop passes it); the tick
        measures how late its outputs were written, its own run time included."""
        with self.lock:
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
        now = self.clock.now_s()
        dt = (1.0 / self.caps.loop_hz) if self._last_t_s is None else max(now - self._last_t_s, 0.0)
        self._last_t_s = now
        self.hw.poll(now)
        for name, ax in self.axes.items():
            meas = ax.read(dt)
            ax.read_switches()
            if meas is not None:
                self._clear_link_fault(ax, meas, now)
            ax.mon, fault = faultmod.check(ax.mon, MonitorInputs(
                now_s=now, meas_deg=meas, sensor_error=ax.sensor_error, duty=ax.out.duty,
                min_duty=ax.tuning.min_duty if ax.tuning.drive == "pwm" else min(ax.tuning.drive_levels or (1.0,)),
                current_a=ax.current_a, limit_min=ax.limit_min, limit_max=ax.limit_max,
                estimate_deg=ax.meas_deg if meas is not None else None), ax.flim)
            if fault is None:
                fault = _driver_fault(name, ax.hw.motor, now)
            if fault is not None:
                if fault.kind == "sensor_range" and meas is not None:
                    ax.meas_deg, ax._filter_rate = meas, 0.0  # show the reading, not the wild estimate
                self._latch(fault)
        while self._commands:
            self._commands.popleft().apply()
        self._advance_route()
        self._check_parked()
        self._maybe_idle_park(now)
        held = self.timing.held(now)
        if self._was_held and not held:
            self._event("control loop on time again: motion resumed")
        self._was_held = held
        for ax in self.axes.values():
            sp = None if self._faults or held else ax.sp
            ax.step(sp, now, dt)
        self._guard()
        self._persist(now)
        for ax in self.axes.values():
            self._apply(ax)
        self._beat()
        self._status = self._build_status(now)
        return self._status

    def _clear_link_fault(self, ax: "_Axis", meas: float, now_s: float) -> None:
        """A bridged controller answers again after its link went down (a USB-serial
        hiccup, the controller restarted): the unreadable-sensor fault clears itself, the
        position is the one just re-read, and the monitors start afresh from it, so the
        gap invents no stall, runaway or jump (issue 21: an unattended station lost every
        pass after one). Only that fault: anything else latched stays."""
        answering = getattr(ax.positioner, "answering", None)
        if answering is None or not any(f.kind == "sensor_dead" and f.axis == ax.name for f in self._faults):
            return
        if not answering():
            return
        self._faults = [f for f in self._faults if not (f.kind == "sensor_dead" and f.axis == ax.name)]
        ax.mon = MonitorState(limit_min=ax.limit_min, limit_max=ax.limit_max)
        ax.meas_deg, ax._filter_rate, ax.rate_deg_per_s = meas, 0.0, 0.0
        ax.history.clear()
        ax.history.append((ax._t_s, meas))
        ax.law = replace(ax.law, ref_deg=meas, last_meas_deg=meas)
        self._event(f"{ax.name}: the controller answers again at {meas:.1f} deg: link fault cleared")

    def note_lateness(self, late_s: float) -> None:
        """A stall of ``late_s`` (more than the watchdog time): the motors stop at once
        and stay off until the loop has been on time for a while; stalls that keep
        happening latch a watchdog fault."""
        if late_s > self.settings.watchdog_s:
            now = self.clock.now_s()
            with self.lock:
                self._on_stall(self.timing.stall(now, late_s), late_s, now)

    def _on_stall(self, verdict: str, late_s: float, now_s: float) -> None:
        t = self.timing
        if verdict == "latch":
            self._latch(Fault("watchdog", None, f"control loop deadline missed by {late_s * 1000:.0f} ms "
                              f"({t.recent_stalls(now_s)} stalls within {t.latch_window_s / 60:g} min)", now_s))
            return
        for ax in self.axes.values():
            ax.out = law.OFF
            self._apply(ax)
        self._was_held = True
        self._event(f"control loop late by {late_s * 1000:.0f} ms: motors stopped, resuming when on time "
                    f"(stall {t.recent_stalls(now_s)} of {t.latch_stalls} that latch a fault within "
                    f"{t.latch_window_s / 60:g} min)")

    def _beat(self) -> None:
        """Toggle the heartbeat output: a square wave while ticks run, for an external
        watchdog (charge pump) that cuts motor power when it stops."""
        if self.hw.heartbeat is None:
            return
        self._heartbeat = not self._heartbeat
        try:
            self.hw.heartbeat.write(self._heartbeat)
        except Exception as exc:  # a failed heartbeat write is the external watchdog's to see
            log.debug("heartbeat write failed: %s", exc)

    def _apply(self, ax: _Axis) -> None:
        if ax.positioner is not None:
            ax.post()
            return
        duty = ax.out.duty
        if ax.hw.brake is not None:
            ax.hw.brake.set_released(ax.out.brake_released)
            if not ax.hw.brake.is_released():
                duty = 0.0
        ax.hw.motor.set_drive(duty)

    def _guard(self) -> None:
        """Last line of defence: no drive beyond a soft limit, an active limit switch or
        into a keep-out zone, whatever the law asked for."""
        for ax in self.axes.values():
            d = ax.out.duty
            if d == 0.0:
                continue
            lo, hi = ax.limits
            slack = ax.tuning.tolerance_deg
            planned = ax.planned_stop_deg()
            rest = ax.stop_position_deg() if planned is None else planned
            # The law brakes to a stop at a limit on its own; this only catches a gross
            # overrun, so the predicted rest point gets half its own stopping distance of
            # benefit of the doubt (the speed estimate lags and is quantised).
            margin = slack + 0.5 * abs(rest - ax.meas_deg)
            # only drive that pushes outwards is cut; braking towards the inside is fine, and
            # so is a correction while backing away from a pressed switch
            heading_deg = ax.sp.target_deg if ax.sp is not None else ax.meas_deg
            to_max = ax.limit_max and heading_deg >= ax.meas_deg
            to_min = ax.limit_min and heading_deg <= ax.meas_deg
            if (d > 0 and (to_max or ax.meas_deg > hi + slack or rest > hi + margin)) or \
               (d < 0 and (to_min or ax.meas_deg < lo - slack or rest < lo - margin)):
                ax.out = replace(ax.out, duty=0.0)
                # hold here, or come back inside if it overran: a standing target within
                # the limits (a park or goto to the limit then still ends at the limit)
                ax.sp = law.Setpoint(min(max(ax.meas_deg, lo), hi), 0.0, self.clock.now_s(),
                                     seq=self._next_seq())
                self._event(f"guard: {ax.name} stopped at {ax.meas_deg:.2f} deg before its limit")
        if not self.geometry.zones:
            return
        present = list(self.axes.values())
        now_pose = self._current_pose()
        # a counting sensor can be a count off (pulse miscounts, the half-count estimate):
        # a pose within a count of a zone is treated as entering it
        count_deg = max(ax.caps.sensor.resolution_deg for ax in present)
        ahead = (self.axes["az"].heading_deg(count_deg),
                 self.axes["el"].heading_deg(count_deg) if "el" in self.axes else FIXED_EL_DEG)
        # (from inside the margin, or a zone, only motion that gets no deeper is let on)
        zone = self.geometry.deeper_into_zone(now_pose, ahead, margin_deg=count_deg)
        if zone is not None:
            for ax in present:
                ax.out, ax.sp = law.OFF, None
            self._route = []
            self._event(f"guard: stopped before keep-out zone {zone.name!r}")

    def _latch(self, fault: Fault) -> None:
        if any(f.kind == fault.kind and f.axis == fault.axis for f in self._faults):
            return
        self._faults.append(fault)
        for ax in self.axes.values():
            ax.sp = None
            ax.out = law.OFF
            self._apply(ax)
        self._route = []
        self._tracking = False
        self._parking = False
        self._target_sky = None
        log.error("FAULT %s: %s", fault.kind, fault.reason)
        self._event(f"fault {fault.kind}: {fault.reason}")

    def announce(self, text: str) -> None:
        """An event from outside the rotator (logged, and in status' recent events)."""
        with self.lock:
            self._event(text)

    def _event(self, text: str) -> None:
        log.warning("%s", text)
        self._events.append(text)

    # ===================================================================== commands
    def _submit(self, name: str, apply: Callable[[], None]) -> None:
        self._last_command_t_s = self.clock.now_s()
        self._commands.append(_Command(name, apply))

    def hold_local(self, control: str, held: bool) -> None:
        """A local control (a front-panel button, an IR remote key, the zero-setting
        procedure) is pressed (``held``) or released. While any is held the local
        operator wins: motion commands from every other source are refused with reason
        "local"; a stop is accepted from anyone. Thread-safe (set operations)."""
        if held:
            self._local_holds.add(control)
        else:
            self._local_holds.discard(control)

    def local_controls(self) -> tuple[str, ...]:
        """The local controls held now (empty: every source may command motion)."""
        return tuple(sorted(self._local_holds))

    def _refuse_unless_local(self, local: bool) -> None:
        holds = self.local_controls()
        if holds and not local:
            raise CommandRejected(f"refused: local control active ({', '.join(holds)} held at the "
                                  "rotator); stop is still accepted", "local")

    def _require_motion_ok(self, automatic: bool, local: bool = False) -> None:
        self._refuse_unless_local(local)
        if self._faults:
            raise CommandRejected("refused: fault latched (" + "; ".join(f.reason for f in self._faults)
                                  + "); clear faults first", "fault")
        if self._save_error and any(precord.needs_record(ax) for ax in self.axes.values()):
            # the first tick would hold the axes and latch the state fault: say so now,
            # not "ok" for a move that cannot happen (a fault cleared on a full disk)
            raise CommandRejected(f"refused: state not saved ({self._save_error}); motion would stop at "
                                  "once so that the saved position stays true", "state")
        if automatic and self.position_uncertain():
            bounds = ", ".join(f"{n} ±{ax.uncertainty_deg:.2f} deg" for n, ax in self.axes.items()
                               if ax.uncertainty_deg)
            raise CommandRejected(f"refused: position uncertain ({bounds}); re-reference first",
                                  "uncertain")

    def _next_seq(self) -> int:
        self._seq += 1
        return self._seq

    def _rates(self) -> tuple[float, float]:
        el = self.axes.get("el")  # (no elevation axis: its pose never changes; any rate)
        return (self.axes["az"].tuning.max_rate_deg_per_s, el.tuning.max_rate_deg_per_s if el else 1.0)

    def _current_pose(self) -> tuple[float, float]:
        el = self.axes.get("el")
        return (self.axes["az"].meas_deg, el.meas_deg if el else FIXED_EL_DEG)

    def _no_el(self, el_deg: float) -> float:
        """A single-axis rotator takes any finite elevation in a two-axis command and
        leaves it aside (each protocol says whether it answers that as its original
        does, or refuses first); its pose keeps FIXED_EL_DEG."""
        if not (isinstance(el_deg, (int, float)) and math.isfinite(el_deg)):
            raise CommandRejected(f"elevation {el_deg!r} is not a finite number", "invalid")
        return FIXED_EL_DEG

    def _require_el(self, what: str) -> None:
        if "el" not in self.axes:
            raise CommandRejected(f"{what}: this rotator has no elevation axis (azimuth only)", "no_axis")

    def _explicit_pose(self, az_deg: float, el_deg: float) -> tuple[float, float] | None:
        """An azimuth outside 0..360 or an elevation past 90 names one mechanical pose.

        The one rule for azimuths outside 0..360, for every protocol (README): within the
        rotator's extended range (limits + offset) they name that wrap turn (-10 on a
        -90..450 rotator, 400 on 0..450); a negative azimuth down to -180 beyond the range
        is a compass bearing, -10 = 350 (clients in -180..180 mode send west negative);
        anything else outside the range is refused."""
        if 0.0 <= az_deg < 360.0 and el_deg <= 90.0:
            return None
        g = self.geometry
        pose = (az_deg - g.az_offset_deg, el_deg - g.el_offset_deg)
        if -180.0 <= az_deg < 0.0 and not g.az_min_deg <= pose[0] <= g.az_max_deg:
            if el_deg <= 90.0:
                return None  # a compass bearing: the planner picks the turn
            return self._explicit_pose(az_deg + 360.0, el_deg)
        if 0.0 <= az_deg < 360.0:
            # a flipped pose with a compass azimuth names the flip, not the wrap turn: the
            # turn nearest in travel, the overlap included (from 355/140, 6.9/137.4 is
            # 366.9, 12 deg on, not 7.0, 348 deg back)
            turns = [(pose[0] + 360.0 * k, pose[1]) for k in range(-2, 3)]
            legal = [p for p in turns if g.in_limits(*p)]
            if legal:
                start = self._current_pose()
                pose = min(legal, key=lambda p: route_time_s([start, p], self._rates()))
        if not g.in_limits(*pose):
            raise CommandRejected(
                f"position az {az_deg:g}, el {el_deg:g} outside the limits "
                f"az {g.az_min_deg + g.az_offset_deg:g}..{g.az_max_deg + g.az_offset_deg:g}, "
                f"el {g.el_min_deg + g.el_offset_deg:g}..{g.el_max_deg + g.el_offset_deg:g}", "limit")
        return pose

    def _plan(self, az_deg: float, el_deg: float) -> list[tuple[float, float]]:
        for v, what in ((az_deg, "azimuth"), (el_deg, "elevation")):
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise CommandRejected(f"{what} {v!r} is not a finite number", "invalid")
        g = self.geometry
        start = self._current_pose()
        pose = self._explicit_pose(az_deg, el_deg)
        if pose is not None:
            route = self._route_to_pose(pose)
        else:
            if not (-90.0 <= el_deg <= 90.0):
                raise CommandRejected(f"elevation {el_deg:g} outside -90..90", "limit")
            if not g.candidates(wrap360(az_deg), el_deg):
                raise CommandRejected(
                    f"position az {az_deg:g}, el {el_deg:g} outside the limits "
                    f"el {g.el_min_deg + g.el_offset_deg:g}..{g.el_max_deg + g.el_offset_deg:g}", "limit")
            route = g.plan(start, wrap360(az_deg), el_deg, self._rates())
        if route is None:
            zones = ", ".join(z.name for z in g.zones) or "none"
            raise CommandRejected(f"no legal path to az {az_deg:g}, el {el_deg:g}: the target or every "
                                  f"path to it lies in a keep-out zone ({zones})", "keepout")
        return route

    def _route_to_pose(self, pose: tuple[float, float]) -> list[tuple[float, float]] | None:
        """A legal route (round keep-out zones) to one mechanical pose, or None."""
        g, start = self.geometry, self._current_pose()
        route = g.plan(start, *g.to_sky(*pose), self._rates())
        route = None if route is None else route[:-1] + [pose]
        if route is not None and g.segment_clear((route[-2] if len(route) > 1 else start), pose, self._rates()):
            route = None
        return route

    def goto_pose(self, az_m_deg: float, el_m_deg: float, name: str = "goto_pose",
                  local: bool = False) -> list[tuple[float, float]]:
        """Fly round any keep-out zone to one *mechanical* pose (wrap and flip chosen
        by the pass planner). Returns the planned waypoints. ``local``: from a local
        control (front panel), allowed while one is held."""
        self._require_motion_ok(automatic=True, local=local)
        if not (math.isfinite(az_m_deg) and math.isfinite(el_m_deg)):
            raise CommandRejected(f"pose {az_m_deg!r}, {el_m_deg!r} is not finite", "invalid")
        if "el" not in self.axes:
            el_m_deg = FIXED_EL_DEG
        g = self.geometry
        if not g.in_limits(az_m_deg, el_m_deg, slack_deg=1e-6):
            raise CommandRejected(f"pose az {az_m_deg:g}, el {el_m_deg:g} outside the limits", "limit")
        route = self._route_to_pose((az_m_deg, el_m_deg))
        if route is None:
            raise CommandRejected(f"no legal path to pose az {az_m_deg:g}, el {el_m_deg:g}: it or every "
                                  "path to it lies in a keep-out zone", "keepout")
        self._target_sky = g.to_sky(az_m_deg, el_m_deg)
        self._submit_route(name, route)
        return route

    def _submit_route(self, name: str, route: list[tuple[float, float]]) -> None:
        def apply() -> None:
            self._parked = self._parking = False
            self._tracking = False
            self._start_route(route)
        self._submit(name, apply)

    def goto(self, az_deg: float, el_deg: float) -> list[tuple[float, float]]:
        """Point at sky (az, el). Returns the planned mechanical waypoints."""
        self._require_motion_ok(automatic=True)
        if "el" not in self.axes:
            el_deg = self._no_el(el_deg)
        route = self._plan(az_deg, el_deg)
        target = (wrap360(az_deg), el_deg) if self._explicit_pose(az_deg, el_deg) is None \
            else self.geometry.to_sky(*route[-1])

        # The target is known from now on (not from the next tick), so that a goto_el
        # right after a goto_az in the same breath keeps the azimuth just asked for.
        self._target_sky = target
        self._submit_route("goto", route)
        return route

    def goto_az(self, az_deg: float) -> list[tuple[float, float]]:
        """Azimuth only: elevation keeps its target (or where it is, after a stop)."""
        if "el" not in self.axes:
            return self.goto(az_deg, FIXED_EL_DEG)
        return self.goto(az_deg, self._target_sky[1] if self._target_sky else self.status().el_deg)

    def goto_el(self, el_deg: float) -> list[tuple[float, float]]:
        """Elevation only: azimuth keeps its target (or where it is, after a stop)."""
        self._require_el("goto elevation")
        return self.goto(self._target_sky[0] if self._target_sky else self.status().az_deg, el_deg)

    def park(self, local: bool = False) -> list[tuple[float, float]]:
        """Go to the park pose: a *mechanical* pose (the axes' own frame, as the limits
        are), not a sky direction. So parking unwinds the cable to the turn the pose
        names, and a rotator that can flip parks unflipped at el 90 rather than at the
        other side's az 180. ``parked`` turns true once both axes hold there."""
        route = self.goto_pose(self.settings.park_az_deg, self.settings.park_el_deg, "park", local=local)

        def mark() -> None:
            self._parking = True
        self._submit("park", mark)
        return route

    def track(self, az_deg: float, el_deg: float, az_rate_deg_per_s: float = 0.0,
              el_rate_deg_per_s: float = 0.0, t_ref_s: float | None = None) -> None:
        """Follow a moving sky target: (az, el) at t_ref_s, moving at the given rates.

        Keeps the wrap and flip side of the previous track point (continuity), so a
        pass planned on one side stays there; the pass planner chooses that side.
        """
        self._require_motion_ok(automatic=True)
        for v in (az_deg, el_deg, az_rate_deg_per_s, el_rate_deg_per_s):
            if not math.isfinite(v):
                raise CommandRejected(f"track value {v!r} is not finite", "invalid")
        if "el" not in self.axes:  # the azimuth follows; where it is in the sky is not asked
            el_deg, el_rate_deg_per_s = FIXED_EL_DEG, 0.0
        t_ref = self.clock.now_s() if t_ref_s is None else t_ref_s
        g = self.geometry
        poses = g.candidates(wrap360(az_deg), el_deg)
        if not poses:
            raise CommandRejected(f"track point az {az_deg:g}, el {el_deg:g} outside the limits", "limit")
        ref = tuple(ax.sp.target_at(t_ref) if self._tracking and ax.sp else ax.meas_deg
                    for ax in self.axes.values()) + (FIXED_EL_DEG,) * (2 - len(self.axes))
        pose = min(poses, key=lambda p: abs(p[0] - ref[0]) + abs(p[1] - ref[1]))
        if g.zone_at(*pose, margin_deg=0.0) or g.segment_clear(self._current_pose(), pose, self._rates()):
            raise CommandRejected(f"track point az {az_deg:g}, el {el_deg:g} is in or behind a keep-out zone",
                                  "keepout")
        flipped = pose[1] > 90.0
        az_rate = az_rate_deg_per_s
        el_rate = -el_rate_deg_per_s if flipped else el_rate_deg_per_s

        self._target_sky = (wrap360(az_deg), el_deg)

        self._submit("track", lambda: self._follow(pose, (az_rate, el_rate), t_ref))

    def track_pose(self, az_m_deg: float, el_m_deg: float, az_rate_deg_per_s: float = 0.0,
                   el_rate_deg_per_s: float = 0.0, t_ref_s: float | None = None) -> None:
        """Follow a planned *mechanical* trajectory point (wrap and flip already chosen
        by the pass planner): the pose at t_ref_s, moving at the given mechanical rates."""
        self._require_motion_ok(automatic=True)
        values = (az_m_deg, el_m_deg, az_rate_deg_per_s, el_rate_deg_per_s)
        if not all(math.isfinite(v) for v in values):
            raise CommandRejected(f"track pose {values!r} is not finite", "invalid")
        if "el" not in self.axes:
            el_m_deg, el_rate_deg_per_s = FIXED_EL_DEG, 0.0
        g = self.geometry
        if not g.in_limits(az_m_deg, el_m_deg, slack_deg=1e-6):
            raise CommandRejected(f"track pose az {az_m_deg:g}, el {el_m_deg:g} outside the limits", "limit")
        zone = g.zone_at(az_m_deg, el_m_deg, margin_deg=0.0)
        if zone is not None:
            raise CommandRejected(f"track pose az {az_m_deg:g}, el {el_m_deg:g} is in keep-out zone "
                                  f"{zone.name!r}", "keepout")
        t_ref = self.clock.now_s() if t_ref_s is None else t_ref_s
        self._target_sky = g.to_sky(az_m_deg, el_m_deg)

        self._submit("track_pose", lambda: self._follow((az_m_deg, el_m_deg),
                                                        (az_rate_deg_per_s, el_rate_deg_per_s), t_ref))

    def _follow(self, pose: tuple[float, float], rates: tuple[float, float], t_ref: float) -> None:
        """Set moving setpoints. Successive updates of one track keep their sequence
        number, so the law keeps following instead of re-planning at every update."""
        was_tracking = self._tracking
        self._parked = self._parking = False
        self._tracking = True
        self._route = []
        seq = self._next_seq()
        for ax, p, r in zip(self.axes.values(), pose, rates):
            lo, hi = ax.limits
            keep = was_tracking and ax.sp is not None
            ax.sp = law.Setpoint(min(max(p, lo), hi), r, t_ref, seq=ax.sp.seq if keep else seq,
                                 min_deg=lo, max_deg=hi)

    def move(self, axis: str, direction: int, speed_frac: float = 1.0, local: bool = False) -> None:
        """Manual move (jog) of one axis at a fraction of its top speed, until stop.

        Stops by itself at the soft limit or before a keep-out zone. ``local``: from a
        local control (front panel), allowed while one is held.
        """
        if axis not in AXES or direction not in (-1, 1):
            raise CommandRejected(f"move needs axis az|el and direction -1|+1, got {axis!r}, {direction!r}")
        if axis == "el":
            self._require_el("move elevation")
        if not (math.isfinite(speed_frac) and 0.0 < speed_frac <= 1.0):
            raise CommandRejected(f"move speed {speed_frac!r} outside 0 < speed <= 1")
        self._require_motion_ok(automatic=False, local=local)
        ax = self.axes[axis]
        if (direction > 0 and ax.limit_max) or (direction < 0 and ax.limit_min):
            raise CommandRejected(f"{axis}: limit switch active in that direction", "limit")
        lo, hi = ax.limits
        end = self.geometry.clear_until(self._current_pose(), axis, hi if direction > 0 else lo)
        cap = max(speed_frac * ax.tuning.max_rate_deg_per_s, ax.tuning.min_rate_deg_per_s)
        self._target_sky = None

        def apply() -> None:
            self._parked = self._parking = False
            others = [n for n in self.axes if n != axis]
            if self._route or self._tracking or any(
                    self.axes[n].sp is not None and self.axes[n].sp.rate_deg_per_s for n in others):
                # the other axis was flying a route or a track planned for both axes
                # together (or is still following a track whose other axis was stopped);
                # alone it could carry the jog into a zone: stop it too
                self._stop_axes(others)
            self._tracking = False
            self._route = []
            ax.sp = law.Setpoint(end, 0.0, self.clock.now_s(), speed_cap_deg_per_s=cap, seq=self._next_seq())
        self._submit("move", apply)

    def stop(self, axis: str | None = None) -> None:
        """Stop (both axes, or one): decelerate at the axis' limit and hold there."""
        if axis is not None and axis not in AXES:
            raise CommandRejected(f"stop takes az, el or nothing, got {axis!r}")
        if axis is not None and axis not in self.axes:
            return  # no such axis here: nothing to stop (and the azimuth keeps its goal)
        self._target_sky = None

        def apply() -> None:
            self._route = []
            self._tracking = False
            self._parking = False  # a park cut short is no park
            self._stop_axes([axis] if axis else list(self.axes))
        self._submit("stop", apply)

    def _stop_axes(self, names: list[str]) -> None:
        """Decelerate at each axis' limit and hold where it comes to rest (relays: cut)."""
        for name in names:
            ax = self.axes[name]
            if ax.tuning.drive == "relay" or ax.law.mode != "driving" or ax.positioner is not None:
                ax.sp = None  # (a positioner's controller gets a stop and brakes itself)
                continue
            lo, hi = ax.limits
            rate = ax.law.ref_rate_deg_per_s
            end = ax.law.ref_deg + math.copysign(stopping_distance_deg(rate, ax.tuning.accel_deg_per_s2), rate)
            ax.sp = law.Setpoint(min(max(end, lo), hi), 0.0, self.clock.now_s(), seq=self._next_seq())

    def set_position(self, az_deg: float | None = None, el_deg: float | None = None,
                     local: bool = False) -> None:
        """Re-reference: declare where the antenna points now (Tartu WRAZ/WREL).

        Values are in the extended azimuth frame (e.g. 400 on a 450 deg rotator names
        the overlap), so the wrap side is explicit. Clears that axis' uncertainty.
        ``local``: from a local control; refused from elsewhere while one is held (it
        would cut the operator's jog short).
        """
        self._refuse_unless_local(local)
        g = self.geometry
        if el_deg is not None:
            self._require_el("set elevation position")
        values = {"az": az_deg, "el": el_deg}
        for name, v in values.items():
            if v is None:
                continue
            if not math.isfinite(v):
                raise CommandRejected(f"{name} {v!r} is not a finite number")
            lo, hi = self.axes[name].limits
            off = g.az_offset_deg if name == "az" else g.el_offset_deg
            if not lo - 1e-9 <= v - off <= hi + 1e-9:
                raise CommandRejected(f"{name} {v:g} outside {lo + off:g}..{hi + off:g}", "limit")

        def apply() -> None:
            for name, v in values.items():
                if v is None:
                    continue
                off = g.az_offset_deg if name == "az" else g.el_offset_deg
                self._searches.pop(name, None)  # a person's word ends a search too
                self._rereference(self.axes[name], v - off)
                self._event(f"{name} re-referenced to {v:.2f} deg")
        self._submit("set_position", apply)

    def adopt_sensor_reading(self, axis: str, local: bool = False, reread: bool = True) -> float:
        """An absolute sensor's constants were just changed (a G4JNT zero offset Z, a
        declination): the axis takes what the sensor reads now as its position, at once
        (call it under ``lock`` together with the change, so no tick sees the jump as a
        fault). The sensor is not re-referenced: that would fold one noisy reading back
        into the constant just set. ``reread=False``: only a constant that turns bearings
        changed (the G4JNT's Z): the axis angle stays as it is, without one more noisy
        reading. Returns the new mechanical angle."""
        self._refuse_unless_local(local)
        if axis not in self.axes:
            raise CommandRejected(f"no {axis!r} axis on this rotator (it has {', '.join(self.axes)})")
        ax = self.axes[axis]
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
        self._searches.pop(axis, None)
        self._rereference(ax, mech_deg, set_sensor=False)
        self.geometry = self._geometry_for(self.settings)   # a new Z turns the bearings
        off = self.geometry.az_offset_deg if axis == "az" else self.geometry.el_offset_deg
        self._event(f"{axis} re-referenced to {mech_deg + off:.2f} deg (new sensor constants)")
        return mech_deg

    def _rereference(self, ax: _Axis, mech_deg: float, uncertainty_deg: float = 0.0,
                     set_sensor: bool = True) -> None:
        if set_sensor:
            ax.set_reference(mech_deg)
        ax.meas_deg = mech_deg
        ax.rate_deg_per_s = ax._filter_rate = 0.0
        ax.history.clear()
        ax.uncertainty_deg = uncertainty_deg
        ax.sp = None
        ax.law = replace(ax.law, ref_deg=mech_deg, ref_rate_deg_per_s=0.0, mode="idle")
        ax.mon = MonitorState()
        self._route = []
        self._parked = self._parking = False  # a re-reference ends a park under way
        self._record_dirty = True

    def search_frame(self, axis: str, mech_deg: float) -> None:
        """Reference search (homing): re-reference ``axis`` to ``mech_deg`` in a temporary
        frame in which a jog can reach the switch. Until :meth:`end_search` the axis
        counts as uncertain over its whole range, and state records keep the true frame:
        a search interrupted by a crash restarts uncertain, never in the search frame."""
        self._check_axis(axis)
        if not math.isfinite(mech_deg):
            raise CommandRejected(f"{axis} {mech_deg!r} is not a finite number")

        def apply() -> None:
            ax = self.axes[axis]
            prior, shift = self._searches.get(axis, (ax.uncertainty_deg, 0.0))
            self._searches[axis] = (prior, shift + mech_deg - ax.meas_deg)
            self._rereference(ax, mech_deg, uncertainty_deg=max(prior, ax.caps.span_deg))
        self._submit("search_frame", apply)

    def end_search(self, axis: str, mech_deg: float | None = None) -> None:
        """End a reference search: the reference found (``mech_deg``, the true mechanical
        angle here), or None to go back to the true frame with the uncertainty there was."""
        self._check_axis(axis)

        def apply() -> None:
            if axis not in self._searches:
                return
            ax = self.axes[axis]
            prior, shift = self._searches.pop(axis)
            if mech_deg is None:
                self._rereference(ax, ax.meas_deg - shift, uncertainty_deg=prior)
            else:
                self._rereference(ax, mech_deg)
                self._event(f"{axis} re-referenced to {mech_deg:.2f} deg (mechanical) by its search")
        self._submit("end_search", apply)

    def _check_axis(self, axis: str) -> None:
        if axis not in AXES:
            raise CommandRejected(f"axis must be az or el, got {axis!r}")
        if axis == "el":
            self._require_el("elevation")

    def set_overshoot(self, axis: str, overshoot_deg: float) -> None:
        """Set the coast estimate of a relay axis (Tartu OVRA/OVRE); it keeps learning."""
        if axis not in AXES:
            raise CommandRejected(f"overshoot needs axis az|el, got {axis!r}")
        if axis == "el":
            self._require_el("elevation overshoot")
        if not (math.isfinite(overshoot_deg) and 0.0 <= overshoot_deg <= 20.0):
            raise CommandRejected(f"overshoot {overshoot_deg!r} outside 0..20 deg")
        ax = self.axes[axis]
        levels = ax.tuning.drive_levels or (1.0,)

        def apply() -> None:
            # the coast scales with the speed of each drive level
            ax.law = replace(ax.law, coast_deg=tuple(overshoot_deg * lv / max(levels) for lv in levels))
            self._record_dirty = True
        self._submit("set_overshoot", apply)

    def overshoot_deg(self, axis: str) -> float:
        """The present coast estimate at full drive (what OVRA/OVRE read)."""
        if axis not in self.axes:
            raise CommandRejected(f"no {axis} axis on this rotator (azimuth only)", "no_axis")
        return max(self.axes[axis].law.coast_deg, default=0.0)

    def _geometry_for(self, settings: RotatorSettings) -> Geometry:
        """The settings' geometry with the sensors' own pointing offsets added to the
        mount offsets: a constant that turns bearings, not the axis (the G4JNT pot's Z,
        the bearing of its end-stop reference; see PotSensor), kept within +-180 so the
        extended frame stays near the axis'."""
        extra = {}
        for name in self.axes:
            z = getattr(self.axes[name].hw.sensor, "pointing_offset_deg", None)
            if isinstance(z, (int, float)) and math.isfinite(z) and z:
                extra[f"{name}_offset_deg"] = getattr(settings, f"{name}_offset_deg") + \
                    (float(z) + 180.0) % 360.0 - 180.0
        return replace(settings, **extra).geometry() if extra else settings.geometry()

    def reconfigure(self, settings: RotatorSettings) -> None:
        """Apply new limits, keep-out zones, offsets, speeds, park and fault limits while
        running (the settings page). Motion in progress stops: its route was planned
        under the old rules. A new profile or loop rate needs a restart."""
        settings = settings.completed()
        if settings.caps.name != self.caps.name or settings.caps.loop_hz != self.caps.loop_hz:
            raise CommandRejected("a new profile or loop rate takes effect at the next start")
        geometry = self._geometry_for(settings)
        pose = self._current_pose()
        slack = max(self.caps.axis(n).tolerance_deg for n in self.axes)
        if not geometry.in_limits(*pose, slack_deg=slack):
            raise CommandRejected(f"the antenna (az {pose[0]:.1f}, el {pose[1]:.1f} mechanical) is outside "
                                  "the new limits: move it inside first", "limit")
        zone = geometry.zone_at(*pose, margin_deg=0.0)
        if zone is not None:
            raise CommandRejected(f"the antenna is inside the new keep-out zone {zone.name!r}: "
                                  "move it out first", "keepout")

        def apply() -> None:
            self.settings, self.geometry = settings, geometry
            self._set_stall_rule(settings)
            for name, ax in self.axes.items():
                ax.tuning, ax.flim, ax.limits = settings.tuning(name), settings.fault_limits(name), \
                    settings.limits(name)
                ax.sp = None
            self._route = []
            self._tracking = False
            self._parked = self._parking = False
            self._target_sky = None
            self._event("new settings applied (limits, keep-out zones, offsets, speeds, park)")
        self._submit("reconfigure", apply)

    def _set_stall_rule(self, settings: RotatorSettings) -> None:
        t = self.timing
        t.watchdog_s, t.recover_s = settings.watchdog_s, settings.watchdog_recover_s
        t.latch_stalls, t.latch_window_s = settings.watchdog_latch_stalls, settings.watchdog_latch_window_s

    def clear_faults(self) -> None:
        """Clear latched faults now, before the reply (a goto right after it must be
        accepted); the monitors re-arm from here."""
        if self._faults:
            self._event("faults cleared: " + "; ".join(f.reason for f in self._faults))
        self._faults.clear()
        self.timing.acknowledge()
        for ax in self.axes.values():
            # re-arm the monitor from here; switches still pressed stay known
            ax.mon = MonitorState(limit_min=ax.limit_min, limit_max=ax.limit_max)
        self._last_command_t_s = self.clock.now_s()
        self._status = self._build_status(self.clock.now_s())

    # ================================================================ route / park
    def _start_route(self, route: list[tuple[float, float]]) -> None:
        self._route = list(route)
        self._set_waypoint(self._route[0])

    def _set_waypoint(self, pose: tuple[float, float]) -> None:
        seq = self._next_seq()
        now = self.clock.now_s()
        for ax, p in zip(self.axes.values(), pose):
            ax.sp = law.Setpoint(p, 0.0, now, seq=seq)

    def _advance_route(self) -> None:
        if len(self._route) <= 1:
            return
        if all(ax.law.mode == "holding" and ax.law.seq == ax.sp.seq for ax in self.axes.values()
               if ax.sp is not None):
            self._route.pop(0)
            self._set_waypoint(self._route[0])

    def _check_parked(self) -> None:
        """A park under way is done once its last waypoint is held on both axes."""
        park = {"az": self.settings.park_az_deg, "el": self.settings.park_el_deg}
        if self._parking and len(self._route) <= 1 and all(
                ax.sp is not None and ax.law.seq == ax.sp.seq and ax.law.mode == "holding"
                and abs(ax.meas_deg - park[n]) <= ax.tuning.restart_deg + ax.caps.sensor.resolution_deg
                for n, ax in self.axes.items()):
            self._parking, self._parked = False, True

    def _maybe_idle_park(self, now_s: float) -> None:
        idle_s = self.settings.idle_park_s
        if idle_s <= 0 or self._parked or self._parking or self._faults or self._tracking or self.position_uncertain():
            return
        if now_s - self._last_command_t_s >= idle_s and not self._moving():
            try:
                self.park()
                self._event(f"auto-park after {idle_s:g} s idle")
            except CommandRejected as exc:
                self._event(f"auto-park refused: {exc}")
                self._last_command_t_s = now_s

    # ====================================================================== state
    def position_uncertain(self) -> bool:
        return any(ax.uncertainty_deg > 0 for ax in self.axes.values())

    def _moving(self) -> bool:
        # coasting counts as moving; sensor noise on a standing axis does not
        return any(ax.law.mode in ("driving", "releasing") or abs(ax.rate_deg_per_s) > ax.still_rate_deg_per_s
                   for ax in self.axes.values())

    def _persist(self, now_s: float) -> None:
        """Keep the state record one step ahead of the axes (see position_record): hand
        the writer a new record when one is due, and give no drive to an axis that could
        leave the window of the newest record on disk within this tick."""
        if self._writer is None:
            return
        self._take_report(now_s)
        if self._record_due(now_s):
            self._submit_record(now_s)
            self._take_report(now_s)
        held = []
        dt_s = 1.0 / self.caps.loop_hz
        for name, ax in self.axes.items():
            if ax.out.duty == 0.0 or not precord.needs_record(ax):
                continue
            p, v = ax.meas_deg, ax.rate_deg_per_s
            c = precord.coast_deg(ax, abs(v) + ax.tuning.accel_deg_per_s2 * dt_s)
            step = (min(p, p + v * dt_s) - c, max(p, p + v * dt_s) + c)
            if not precord.covers(self._durable_windows.get(name), step):
                ax.out = replace(ax.out, duty=0.0)
                held.append(name)
        if held and self._save_error:
            self._latch(Fault("state", None, f"state not saved ({self._save_error}): motion stopped "
                              "so the saved position stays true; retrying", now_s))

    def _take_report(self, now_s: float) -> None:
        assert self._writer is not None
        rep = self._writer.report()
        if rep.durable is not self._durable:
            self._durable = rep.durable
            for payload, windows in self._recent:
                if payload is rep.durable:
                    self._durable_windows = windows
        if rep.error and not self._save_error:
            self._event(f"state not saved: {rep.error} (retrying)")
        elif self._save_error and not rep.error:
            self._event("state saved again")
            if any(f.kind == "state" for f in self._faults):
                # the cause is gone and the record on disk is true again
                self._faults = [f for f in self._faults if f.kind != "state"]
                self._event("state fault cleared: the position record is written again")
        self._save_error = rep.error

    def _record_due(self, now_s: float) -> bool:
        rec = self._record
        if rec is None or self._record_dirty:
            return True
        horizon_s = self.settings.save_interval_s
        windows = self._recent[-1][1]
        for name, ax in self.axes.items():
            saved = rec["axes"][name]
            if saved["uncertainty_deg"] != ax.uncertainty_deg:
                return True
            band = precord.hold_band_deg(ax)
            shift = self._searches.get(name, (0.0, 0.0))[1]
            if precord.standing(ax, self._tracking):
                # at rest: the record should say so (a restart then knows the position)
                if abs(saved["mech_deg"] + shift - ax.meas_deg) > band or (
                        precord.needs_record(ax) and not precord.known_window(ax, windows[name])):
                    return True
            elif precord.needs_record(ax) and not precord.covers(
                    windows[name], precord.reach(ax, now_s, horizon_s / 2.0, with_target=True)):
                return True
        return False

    def _submit_record(self, now_s: float, wait: bool = False) -> bool:
        """Hand the writer a record of the present state (``wait``: write it now)."""
        assert self._writer is not None
        axes: dict[str, Any] = {}
        windows: dict[str, tuple[float, float]] = {}
        for name, ax in self.axes.items():
            try:
                cal = ax.hw.sensor.calibration()
            except Exception:
                cal = {}
            is_standing = precord.standing(ax, self._tracking)
            windows[name] = precord.window(ax, now_s, self.settings.save_interval_s, is_standing)
            # a reference search works in a temporary frame; the record keeps the true one
            shift = self._searches.get(name, (0.0, 0.0))[1]
            axes[name] = {"mech_deg": ax.meas_deg - shift, "rate_deg_per_s": ax.rate_deg_per_s,
                          "moving": not is_standing,
                          "window_deg": [windows[name][0] - shift, windows[name][1] - shift],
                          "calibration": cal, "coast_deg": list(ax.law.coast_deg),
                          "uncertainty_deg": ax.uncertainty_deg}
            if name in self._searches:
                axes[name]["procedure"] = "reference search"
        payload = {"profile": self.caps.name, "axes": axes}
        self._record, self._record_dirty = payload, False
        self._recent.append((payload, windows))
        if wait:
            ok = self._writer.write_now(payload)
        else:
            self._writer.submit(payload)
            ok = True
        self._take_report(now_s)
        return ok

    def save_now(self, timeout_s: float = 5.0) -> bool:
        """Write a record of the present state and wait for it; True once it is on disk."""
        if self._writer is None:
            return True
        with self.lock:  # the record is taken between ticks; the wait is not (see below)
            self._submit_record(self.clock.now_s())
        ok = self._writer.flush(timeout_s)
        with self.lock:
            self._take_report(self.clock.now_s())
            return ok and self._durable is self._record

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
            self._latch(Fault("power_fail", None, f"{reason}: motors stopped, brakes on, state written at once",
                              self.clock.now_s()))
            self.hw.drive_safe()
            self._status = self._build_status(self.clock.now_s())

    def shutdown(self, save: bool = True) -> bool:
        """Motors off, brakes on, every output safe; then the state saved as it is (still
        on the move, it says so: a restart is then uncertain by how far the axis can
        coast). The caller stops first and waits for standstill (``urc.service.loop``);
        ``save=False`` for a start that failed: the saved state stays as it was. True if saved."""
        for ax in self.axes.values():
            ax.sp, ax.out = None, law.OFF
            self._apply(ax)
        self.hw.drive_safe()
        if self._writer is None:
            return True
        ok = self.save_now() if save else True
        self._writer.close()
        return ok

    # ==================================================================== status
    def status(self) -> Status:
        assert self._status is not None
        return self._status

    def _build_status(self, now_s: float) -> Status:
        az, el = self.axes["az"], self.axes.get("el")
        g = self.geometry
        loop = self.timing.health(now_s)
        tgt = self._target_sky
        if el is None:
            # no elevation axis: nothing measured, nothing to report (None, not a 0)
            sky_az, sky_el, flipped, tgt_el = wrap360(az.meas_deg + g.az_offset_deg), None, False, None
        else:
            el_ext = el.meas_deg + g.el_offset_deg
            # within the tolerance past the zenith the antenna stands at its own azimuth,
            # not "flipped" to the other side (a resting antenna at el 90 reads 90.05)
            flipped = el_ext > 90.0 + el.tuning.tolerance_deg
            sky_az, sky_el = g.to_sky(az.meas_deg, el.meas_deg) if flipped else \
                (wrap360(az.meas_deg + g.az_offset_deg), min(el_ext, 180.0 - el_ext))
            tgt_el = None if tgt is None else tgt[1]
        return Status(
            t_s=now_s, profile=self.caps.name, az_deg=round(sky_az, 4) % 360.0, el_deg=sky_el,
            az=az.status(), el=None if el is None else el.status(),
            target_az_deg=None if tgt is None else tgt[0], target_el_deg=tgt_el,
            flipped=flipped,
            wrap_turns=int(math.floor((az.meas_deg + self.geometry.az_offset_deg) / 360.0)),
            moving=self._moving(), parked=self._parked, position_known=not self.position_uncertain(),
            faults=tuple(self._faults), events=tuple(self._events), tick_late_p99_ms=loop.late_p99_ms,
            loop=loop.as_dict(),
            local_control=self.local_controls(),
            sim_truth=self.hw.sim_truth(),
            limits={n: ax.limits for n, ax in self.axes.items()},
            offsets={"az": self.geometry.az_offset_deg, "el": self.geometry.el_offset_deg},
            state_error=self._save_error, axes=tuple(self.axes),
            procedures={n: "reference search" for n in self._searches})


def _holding_lock(method: Callable) -> Callable:
    @functools.wraps(method)
    def locked(self: Rotator, *args: Any, **kwargs: Any) -> Any:
        with self.lock:
            return method(self, *args, **kwargs)
    return locked


# The control loop runs on its own thread: every command validates against the axes and
# queues its change under the same lock the tick holds, so it never sees half a tick.
# (Reading ``status()`` needs no lock: a Status is immutable.)
for _name in ("goto", "goto_pose", "goto_az", "goto_el", "park", "track", "track_pose", "move", "stop",
              "set_position", "adopt_sensor_reading", "set_overshoot", "reconfigure", "clear_faults",
              "shutdown"):
    setattr(Rotator, _name, _holding_lock(getattr(Rotator, _name)))
