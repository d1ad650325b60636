"""Faults and the guard: what stops the rotator whatever it was asked to do.

Each tick :meth:`Guard.sense` reads the axes and runs the fault monitors (sensor, stall,
runaway, limit switches, a motor driver's own fault output); a fault is latched: every
output off, the motion abandoned, and no drive until the faults are cleared.
:meth:`Guard.limit` is the last line of defence after the law: no drive past a soft
limit or a pressed switch, nor into a keep-out zone. A late control loop stops the
motors (:meth:`Guard.on_stall`); stalls that keep happening latch a watchdog fault.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from typing import Any

from ..control import faults as faultmod
from ..control import law
from ..control.evolve import construct
from ..control.faults import Fault, MonitorInputs
from .axis import Axis
from .core import Core
from .guard_resume import GuardRetry
from ..model.settings import FIXED_EL_DEG, RotatorSettings
from .timing import LoopTiming

log = logging.getLogger("urc.rotator.rotator")


def driver_fault(axis: str, motor: Any, now_s: float) -> Fault | None:
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


def motor_power_fault(hw: Any, now_s: float) -> Fault | None:
    """The safety chain's read-back OFF while the heartbeat runs (the hardware's watch,
    read after each heartbeat write: urc.hardware.supply_watch): the motors have no
    supply while urc drives them."""
    read = getattr(hw, "motor_power_fault", None)
    reason = read() if read is not None else ""
    return Fault("motor_power", None, reason, now_s) if reason else None


class Guard:
    def __init__(self, core: Core, timing: LoopTiming):
        self.core = core
        self.timing = timing
        #: a standing target the limit guard cut short on a prediction alone
        self.retry = GuardRetry()

    def set_stall_rule(self, settings: RotatorSettings) -> None:
        t = self.timing
        t.watchdog_s, t.recover_s = settings.watchdog_s, settings.watchdog_recover_s
        t.latch_stalls, t.latch_window_s = settings.watchdog_latch_stalls, settings.watchdog_latch_window_s

    # ---------------------------------------------------------------- faults
    def latch(self, fault: Fault) -> None:
        """Latch ``fault`` (once per kind and axis): every output off now, the motion
        abandoned; no drive until the faults are cleared."""
        core = self.core
        if any(f.kind == fault.kind and f.axis == fault.axis for f in core.faults):
            return
        core.faults.append(fault)
        if core.motion is not None or core.program_state in ("prepositioning", "tracking"):
            core.last_stop = {"kind": "fault", "reason": fault.reason, "command": core.motion or "program",
                              "t_s": core.clock.now_s(), "resumes": False}
        for ax in core.axes.values():
            ax.sp = None
            ax.out = law.OFF
            ax.apply()
        core.abandon_motion()
        log.error("FAULT %s: %s", fault.kind, fault.reason)
        core.event(f"fault {fault.kind}: {fault.reason}")

    def clear(self) -> None:
        """Clear latched faults; the monitors re-arm from here."""
        core = self.core
        if core.faults:
            core.event("faults cleared: " + "; ".join(f.reason for f in core.faults))
        core.faults.clear()
        self.timing.acknowledge()
        for ax in core.axes.values():
            ax.rearm_monitor()  # switches still pressed stay known
        core.last_command_t_s = core.clock.now_s()

    def sense(self, now_s: float, dt_s: float) -> None:
        """Read every axis (sensor, switches, current) and run its fault monitor."""
        for name, ax in self.core.axes.items():
            meas = ax.read(dt_s)
            ax.read_switches()
            if meas is not None and ax.positioner is not None:  # (only a bridged axis' link comes back)
                self._clear_link_fault(ax, meas)
            tuning = ax.tuning
            # (construct: made every tick, see urc.control.evolve)
            ax.mon, fault = faultmod.check(ax.mon, construct(
                MonitorInputs, now_s=now_s, meas_deg=meas, sensor_error=ax.sensor_error, duty=ax.out.duty,
                min_duty=tuning.min_duty if tuning.drive == "pwm" else min(tuning.drive_levels or (1.0,)),
                current_a=ax.current_a, limit_min=ax.limit_min, limit_max=ax.limit_max,
                estimate_deg=ax.meas_deg if meas is not None else None), ax.flim)
            if fault is None:
                fault = driver_fault(name, ax.hw.motor, now_s)
            if fault is None and ax.current_failures >= faultmod.SENSOR_DEAD_TICKS:
                fault = Fault("driver", name, f"{name} motor: current sense unreadable {ax.current_failures} "
                              f"times running ({ax.current_error}): no overcurrent or bridge fault signal "
                              "can be seen", now_s)
            if fault is not None:
                if fault.kind == "sensor_range" and meas is not None:
                    ax.show_reading(meas)  # the reading, not the wild estimate
                self.latch(fault)
        fault = motor_power_fault(self.core.hw, now_s)
        if fault is not None:
            self.latch(fault)

    def _clear_link_fault(self, ax: Axis, meas: float) -> None:
        """A bridged controller answers again after its link went down (a USB-serial
        hiccup, the controller restarted): the unreadable-sensor fault clears itself, the
        position is the one just re-read, and the monitors start afresh from it, so the
        gap invents no stall, runaway or jump (issue 21: an unattended station lost every
        pass after one). Only that fault: anything else latched stays."""
        core = self.core
        answering = getattr(ax.positioner, "answering", None)
        if answering is None or not any(f.kind == "sensor_dead" and f.axis == ax.name for f in core.faults):
            return
        if not answering():
            return
        core.faults = [f for f in core.faults if not (f.kind == "sensor_dead" and f.axis == ax.name)]
        ax.restart_from(meas)
        core.event(f"{ax.name}: the controller answers again at {meas:.1f} deg: link fault cleared")

    def on_stall(self, verdict: str, late_s: float, now_s: float) -> bool:
        """A stall of ``late_s``: the motors off at once, or (``verdict`` "latch": they
        keep happening) a watchdog fault. True when the outputs are held off (not latched)."""
        t = self.timing
        if verdict == "latch":
            self.latch(Fault("watchdog", None, f"control loop deadline missed by {late_s * 1000:.0f} ms "
                             f"({t.recent_stalls(now_s)} stalls within {t.latch_window_s / 60:g} min)", now_s))
            return False
        for ax in self.core.axes.values():
            ax.out = law.OFF
            ax.apply()
        self.core.note_stop("health", f"control loop late by {late_s * 1000:.0f} ms: motors stopped, resuming "
                            f"when on time for {t.recover_s:g} s (stall {t.recent_stalls(now_s)} of "
                            f"{t.latch_stalls} that latch a fault within {t.latch_window_s:g} s)",
                            resumes=self.core.motion is not None)
        return True

    # ---------------------------------------------------------------- the guard
    def retry_after_cut(self, now_s: float) -> None:
        """A target the guard cut short on a prediction, approached again from rest."""
        core = self.core
        for ax in core.axes.values():
            target = self.retry.due(ax.name, ax.sp, ax.law, abs(ax.rate_deg_per_s) <= ax.still_rate_deg_per_s)
            if target is not None:
                ax.sp = law.Setpoint(target, 0.0, now_s, seq=core.next_seq())
                self.retry.retrying(ax.name, ax.sp.seq)
                core.event(f"{ax.name}: approaching {target:.2f} deg again after the guard's stop")

    def limit(self) -> None:
        """Last line of defence: no drive beyond a soft limit, an active limit switch or
        into a keep-out zone, whatever the law asked for."""
        core = self.core
        for ax in core.axes.values():
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
            switch_or_over = (to_max or ax.meas_deg > hi + slack) if d > 0 else (to_min or ax.meas_deg < lo - slack)
            if switch_or_over or (d > 0 and rest > hi + margin) or (d < 0 and rest < lo - margin):
                ax.out = replace(ax.out, duty=0.0)
                # hold here, or come back inside if it overran: a standing target within
                # the limits (a park or goto to the limit then still ends at the limit)
                cut_sp = ax.sp
                ax.sp = law.Setpoint(min(max(ax.meas_deg, lo), hi), 0.0, core.clock.now_s(),
                                     seq=core.next_seq())
                again = self.retry.cut(ax.name, cut_sp, ax.sp.seq, (lo, hi), predicted_only=not switch_or_over)
                core.event(f"guard: {ax.name} stopped at {ax.meas_deg:.2f} deg before its limit"
                           + ("; its target is approached again once it rests" if again else ""))
        if not core.geometry.zones:
            return
        present = list(core.axes.values())
        now_pose = core.current_pose()
        # a counting sensor can be a count off (pulse miscounts, the half-count estimate):
        # a pose within a count of a zone is treated as entering it
        count_deg = max(ax.caps.sensor.resolution_deg for ax in present)
        ahead = (core.axes["az"].heading_deg(count_deg),
                 core.axes["el"].heading_deg(count_deg) if "el" in core.axes else FIXED_EL_DEG)
        # (from inside the margin, or a zone, only motion that gets no deeper is let on)
        zone = core.geometry.deeper_into_zone(now_pose, ahead, margin_deg=count_deg)
        if zone is not None:
            for ax in present:
                ax.out, ax.sp = law.OFF, None
            core.route = []
            core.event(f"guard: stopped before keep-out zone {zone.name!r}")
