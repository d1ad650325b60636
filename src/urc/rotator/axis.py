"""One axis of the rotator at run time: its sensor reading (unwrapped, filtered, its
speed), the control law's state and output, and the fault monitor's state.

The :class:`~urc.rotator.rotator.Rotator` owns one :class:`Axis` per axis it has; only
the tick (and the commands it applies) change one. What an axis can do on its own lives
here; what needs both axes (routes, keep-out zones, faults) lives in the rotator's parts.
"""

from __future__ import annotations

import collections
import math
from typing import Any

from ..control import faults as faultmod
from ..control import law
from ..control import positioner as positioner_law
from ..control.estimator import Estimate, FilterLimits, alpha_beta
from ..control.evolve import construct, evolve
from ..control.faults import FaultLimits, MonitorState
from ..control.profile import stopping_distance_deg
from ..errors import SensorError
from ..hardware.interfaces import AxisHardware
from ..model.settings import RotatorSettings
from ..model.snapshot import AxisStatus

AXES = ("az", "el")
#: guard look-ahead: how far ahead (seconds of current motion) keep-out zones are checked.
GUARD_LOOKAHEAD_S = 0.3
#: a speed estimate above this many times the axis' top speed is taken as its top speed
#: when predicting where it would stop
STOP_RATE_MARGIN = 1.25


class Axis:
    """Per-axis runtime: sensor reading, unwrapping, filtering, law and monitor state."""

    def __init__(self, name: str, hw: AxisHardware, settings: RotatorSettings):
        self.name = name
        self.hw = hw
        #: set when an external controller closes this axis' loop (bridge backend)
        self.positioner = hw.positioner
        #: why an open-loop step count stopped being the position (a stepper driver's
        #: ``position_lost``; None: the motor has no such count)
        motor: Any = hw.motor
        self._lost_position = (lambda: motor.position_lost) if hasattr(motor, "position_lost") else None
        #: how far off such a count may be at most (a translator reset at rest), 0: exact
        self._position_bound = (lambda: motor.position_bound_deg) if hasattr(motor, "position_bound_deg") else None
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
        #: the motor current this tick for the fault monitor (NaN: unknown, e.g. a
        #: BTS7960 below its duty floor), and the last known one, which status shows
        self.current_a = 0.0
        self.shown_current_a = 0.0
        #: consecutive current-sense reads that raised, and the last error (the guard
        #: stops the axis after a few: its overcurrent rule and fault signal are blind)
        self.current_failures = 0
        self.current_error = ""
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
        return evolve(self._flim, sensor_jump_deg=self._flim.sensor_jump_deg + 2.0 * travel_deg,
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
        # a controller unheard for SENSOR_DEAD_TICKS (its link lost): the last speed seen
        # is not a motion this axis can see, nor a drive to show (the record keeps it)
        heard = self.mon.unreadable_ticks < faultmod.SENSOR_DEAD_TICKS
        self.law, self.out, self.posted_deg = positioner_law.step(
            self.law, sp, self.meas_deg, self.rate_deg_per_s if heard else 0.0, now_s, self.tuning,
            lead_s=self.positioner.latency_s(), still_rate_deg_per_s=self.still_rate_deg_per_s,
            band_deg=max(self.tuning.tolerance_deg, self.positioner.resolution_deg), limits_deg=self.limits)
        if sp is not None and self.out.duty == 0.0:
            # following its target within the band (a slow track goes in the controller's
            # steps): it is where it was told to be, so a runaway is judged from here
            self.mon = evolve(self.mon, rest_deg=self.meas_deg)

    def post(self) -> None:
        """Positioner axes: post the target, or stop when there is no setpoint (stop,
        fault, guard, shutdown all clear it)."""
        positioner = self.positioner
        assert positioner is not None  # (only an axis with one posts)
        if self.sp is None or self.posted_deg is None:
            positioner.stop()
        elif self.sp.speed_cap_deg_per_s is not None and self.sp.rate_deg_per_s == 0.0:
            # a jog (Rotator.move): the controller's own move, ended at posted_deg (the
            # limit or a zone's edge) by urc
            cap = self.sp.speed_cap_deg_per_s
            positioner.move(self.posted_deg, min(1.0, cap / self.tuning.max_rate_deg_per_s), cap)
        else:
            note = getattr(positioner, "note_position", None)
            if note is not None:
                note(self.meas_deg)  # the turn it is on: a compass protocol's report names none
            positioner.goto(self.posted_deg)

    def apply(self) -> None:
        """Write the output to the hardware: the drive (none while a brake is engaged),
        or a positioner's target."""
        if self.positioner is not None:
            self.post()
            return
        duty = self.out.duty
        if self.hw.brake is not None:
            self.hw.brake.set_released(self.out.brake_released)
            if not self.hw.brake.is_released():
                duty = 0.0
        self.hw.motor.set_drive(duty)

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
            est = alpha_beta(construct(Estimate, pos_deg=self.meas_deg, rate_deg_per_s=self._filter_rate), mech, dt_s,
                             self.filter_limits)
            self.meas_deg, self._filter_rate = est.pos_deg, est.rate_deg_per_s
        else:
            self.meas_deg = mech
        # the reported speed: slope over the window (the filter's own rate is too noisy)
        if self.positioner is not None:  # reports come once per poll: span one at least
            self.window_s = max(self.window_s, self.positioner.sample_interval_s())
        t_s, meas_deg, history = self._t_s, self.meas_deg, self.history  # (every tick: locals)
        history.append((t_s, meas_deg))
        window_start_s = t_s - self.window_s + 1e-9
        while len(history) > 2 and history[1][0] <= window_start_s:
            history.popleft()
        t_old, p_old = history[0]
        if t_s - t_old > 0:
            self.rate_deg_per_s = (meas_deg - p_old) / (t_s - t_old)
        if self._lost_position is not None and self._lost_position() and self.uncertainty_deg < self.caps.span_deg:
            # an open-loop count that lost steps (a stepper cut or disabled mid-move): not
            # the position any more, after the fault is cleared too, until re-referenced
            self.uncertainty_deg = self.caps.span_deg
        if self._position_bound is not None and self._position_bound() > self.uncertainty_deg:
            self.uncertainty_deg = self._position_bound()
        self.sensor_ok, self.sensor_error = True, ""
        return mech

    def read_switches(self) -> None:
        self.limit_min = bool(self.hw.limit_min and self.hw.limit_min.is_active())
        self.limit_max = bool(self.hw.limit_max and self.hw.limit_max.is_active())
        try:
            self.current_a = float(self.hw.motor.read_current_a())
            self.current_failures = 0
        except Exception as exc:  # must not stop the loop: unknown this tick, the guard counts
            self.current_a = math.nan
            self.current_failures += 1
            self.current_error = f"{type(exc).__name__}: {exc}"
        if not math.isnan(self.current_a):
            self.shown_current_a = self.current_a

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
        dist = stopping_distance_deg(rate, self.tuning.accel_deg_per_s2)
        sp = self.sp
        if sp is not None and sp.rate_deg_per_s == 0.0:
            # the reference never brakes below the slowest speed (control.profile): it
            # runs at that speed to a standing target and stops there, short of its own
            # braking distance (an axis that follows fast, a stepper, sat on the limit
            # with that distance still ahead of it and was cut short)
            ahead_deg = (sp.target_at(sp.t_ref_s) - self.law.ref_deg) * math.copysign(1.0, rate)
            if ahead_deg >= 0.0:
                dist = min(dist, ahead_deg)
        return self.meas_deg + math.copysign(dist, rate)

    def status(self) -> AxisStatus:
        out = self.out
        # (construct: made every tick, see urc.control.evolve)
        return construct(
            AxisStatus, pos_deg=self.meas_deg, rate_deg_per_s=self.rate_deg_per_s,
            target_deg=None if self.sp is None else self.sp.target_deg, mode=self.law.mode,
            duty=out.duty, brake_released=out.brake_released,
            uncertainty_deg=self.uncertainty_deg, limit_min=self.limit_min,
            limit_max=self.limit_max, current_a=self.shown_current_a,
            sensor_ok=self.sensor_ok, sensor_error=self.sensor_error)

    # ---- re-starting the estimate ---------------------------------------------------
    def rearm_monitor(self) -> None:
        """The fault monitor starts afresh from here; switches still pressed stay known."""
        self.mon = MonitorState(limit_min=self.limit_min, limit_max=self.limit_max)

    def show_reading(self, meas_deg: float) -> None:
        """Take the raw reading as the estimate (not the filter's wild one)."""
        self.meas_deg, self._filter_rate = meas_deg, 0.0

    def restart_from(self, meas_deg: float) -> None:
        """Estimate, speed window, law and monitor start afresh at ``meas_deg`` (a link
        that answers again: the gap must invent no stall, runaway or jump)."""
        self.rearm_monitor()
        self.meas_deg, self._filter_rate, self.rate_deg_per_s = meas_deg, 0.0, 0.0
        self.history.clear()
        self.history.append((self._t_s, meas_deg))
        self.law = evolve(self.law, ref_deg=meas_deg, last_meas_deg=meas_deg)

    def rereference(self, mech_deg: float, uncertainty_deg: float = 0.0, set_sensor: bool = True) -> None:
        """The axis is at ``mech_deg`` now, known to ``uncertainty_deg``: no setpoint, the
        law idle there, the monitor re-armed. ``set_sensor``: the sensor re-referenced too
        (not when its own constants were just changed)."""
        if set_sensor:
            self.set_reference(mech_deg)
        self.meas_deg = mech_deg
        self.rate_deg_per_s = self._filter_rate = 0.0
        self.history.clear()
        self.uncertainty_deg = uncertainty_deg
        self.sp = None
        self.law = evolve(self.law, ref_deg=mech_deg, ref_rate_deg_per_s=0.0, mode="idle")
        self.mon = MonitorState()
