"""Calibration procedures: zero, two-point pot (G4JNT), magnetometer (SARCNET), homing (BIG-RAS).

The pure maths is in :mod:`calibration_maths` and SARCNET's hand-held 12-direction state
machine in :mod:`calibration_twelve` (both re-exported here). Here: one-shot steps run where the hardware is
(each the handler of a typed query, urc.rotator.queries: the control process runs it whole,
under the rotator's lock where it needs it), then long procedures that use only the
rotator's public commands and those queries. Long procedures are
small state machines: :meth:`Procedure.poll` is called with each new status (after every
control tick in tests on virtual time, every few tens of ms by the web server), issues
rotator commands and reports progress. They never touch axis state directly; a
calibration constant reaches the rotator through :func:`apply_sensor_calibration`, which
keeps the reading continuous and re-references with ``set_position`` so the fault monitor
sees no jump and the state save persists the new constants.
"""

from __future__ import annotations

import contextlib
import math
from typing import Any, Sequence

import numpy as np

from ..errors import CommandRejected
from ..hardware.drivers.sensors import chip_horizontal
from ..model.messages import ApplyCalibration, CompassField, DescribeSensors, SensorCalibrations
# (re-exported: callers name them as calibration.<name>)
from .calibration_maths import (CalibrationError, EllipsoidFit, HardIronFit, NoSuchConstant,  # noqa: F401
                                SoftIronFit, circular_mean_deg, fit_ellipsoid, fit_hard_iron,
                                fit_soft_iron, two_point_pot)
from .calibration_twelve import TwelveDirectionCalibration  # noqa: F401 (re-exported)
from .hub import HubProcedure
from ..model.snapshot import Status


# ================================================================= sensor access
def _check_axis(rotator: Any, axis: str) -> None:
    if axis not in ("az", "el"):
        raise CalibrationError(f"axis must be az or el, got {axis!r}")
    if axis not in rotator.caps.axes:
        raise CalibrationError("this rotator has no elevation axis (azimuth only)")


def sensor_of(rotator: Any, axis: str) -> Any:
    """The axis' sensor, on a rotator in this process (a query handler's: from the I/O
    process the sensor is reached through urc.rotator.queries)."""
    _check_axis(rotator, axis)
    return rotator.hw.axis(axis).sensor


def average_reading_deg(sensor: Any, samples: int = 16) -> float:
    """Mean of several readings (circular for sensors that wrap at their modulo)."""
    values = [sensor.read_deg() for _ in range(samples)]
    modulo = getattr(sensor.caps, "modulo_deg", None)
    return circular_mean_deg(values) * (modulo / 360.0) if modulo else float(np.mean(values))


def pot_units(sensor: Any, samples: int = 32) -> float:
    """The pot's linearised reading P (G4JNT: 4096 N/(2048-N)), averaged over samples."""
    raw = getattr(sensor, "raw_units", None)
    if raw is None:
        raise CalibrationError(f"the {sensor.caps.kind} sensor gives no raw pot reading (P)")
    return float(np.mean([raw() for _ in range(samples)]))


def compass_field(sensor: Any, samples: int = 16) -> tuple[float, float]:
    """Raw horizontal field (bx, by), averaged: what the hard-iron fit needs
    (:meth:`urc.hardware.drivers.CompassSensor.read_field`)."""
    read = getattr(sensor, "read_field", None)
    if read is None:
        raise CalibrationError(f"the {sensor.caps.kind} sensor gives no raw magnetic field")
    pts = np.array([read() for _ in range(samples)], dtype=float)
    return float(pts[:, 0].mean()), float(pts[:, 1].mean())


def describe_sensors(rotator: Any) -> dict[str, Any]:
    """Per axis: sensor kind, present constants and which procedures apply."""
    out = {}
    for axis in rotator.caps.axes:
        hw = rotator.hw.axis(axis)
        sensor = hw.sensor
        try:
            constants = dict(sensor.calibration())
        except Exception:  # a driver without constants still gets the zero page
            constants = {}
        procs = ["zero"]
        if hasattr(sensor, "raw_units"):
            procs.append("pot")
        if axis == "az" and hasattr(sensor, "read_field"):
            procs.append("magnetometer")
        if hw.limit_min is not None:
            procs.append("homing")
        out[axis] = {"kind": sensor.caps.kind, "absolute": sensor.caps.absolute,
                     "resolution_deg": sensor.caps.resolution_deg, "calibration": constants,
                     "procedures": procs}
    return out


# ================================================================= one-shot steps
def apply_sensor_calibration(rotator: Any, axis: str, values: dict[str, Any], samples: int = 16,
                             local: bool = False) -> float:
    """Load new constants into the sensor and re-reference the axis to what they say.

    An absolute sensor (pot, compass, AS5600): the constants are loaded exactly as
    given and the axis adopts the sensor's new reading at once (``adopt_sensor_reading``),
    both under the rotator's lock so no tick sees the step as a sensor jump. (Formerly
    the sensor was put back on its old reading and ``set_position`` re-referenced it,
    which re-derived the offset constant from one noisy reading: a G4JNT Z entered as
    0.9 was stored as 0.9 +- 0.15.) An incremental sensor: put back on its old reading,
    then ``set_position`` moves the axis by the change its constants make. Either way
    the state save persists the new constants. Returns the new mechanical angle.
    """
    sensor = sensor_of(rotator, axis)
    # the control loop runs on its own thread: hold its lock so that no tick reads the
    # sensor between the new constants and the re-reference (in urc run this runs in
    # the control process, where the lock is)
    with getattr(rotator, "lock", contextlib.nullcontext()):
        old = dict(sensor.calibration())
        adopt = getattr(rotator, "adopt_sensor_reading", None)
        if sensor.caps.absolute and adopt is not None:
            sensor.load_calibration(values)
            # constants that turn bearings only (a pot's Z) leave the axis angle alone
            turned = {k for k, v in dict(sensor.calibration()).items() if not _same(v, old.get(k))}
            reread = not turned or not turned <= set(getattr(sensor, "pointing_keys", ()))
            try:
                return adopt(axis, local=local, reread=reread)
            except Exception:
                sensor.load_calibration(old)
                raise
        modulo = getattr(sensor.caps, "modulo_deg", None)
        r0 = average_reading_deg(sensor, samples)
        sensor.load_calibration(values)
        try:
            r1 = average_reading_deg(sensor, samples)
            delta = r1 - r0
            if modulo:
                delta = (delta + modulo / 2) % modulo - modulo / 2
            status = rotator.status()
            mech_new = getattr(status, axis).pos_deg + delta
            sensor.set_reference_deg(r0)
            rotator.set_position(**{f"{axis}_deg": mech_new + status.offsets.get(axis, 0.0)}, local=local)
        except Exception:
            sensor.load_calibration(old)
            raise
    return mech_new


def _same(a: Any, b: Any) -> bool:
    """One constant unchanged (a value that went through a protocol's integer units
    comes back a last bit off)."""
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)
    return a == b


def zero(rotator: Any, az_deg: float | None = None, el_deg: float | None = None) -> None:
    """Declare where the antenna points now (pointing frame, wrap side explicit)."""
    rotator.set_position(az_deg, el_deg)


def pot_apply(rotator: Any, axis: str, points: Sequence[tuple[float, float]]) -> dict[str, float]:
    """Two (bearing_deg, P) points -> M, C; load them and re-reference.

    Bearings are where the antenna pointed (pointing frame); the offsets (the mount's
    and the pot's own Z, the bearing of its reference, which stays) are taken off,
    since the pot measures the axis angle.
    """
    if len(points) != 2:
        raise CalibrationError(f"two-point calibration needs exactly 2 points, got {len(points)}")
    sensor = sensor_of(rotator, axis)
    if "pot" not in describe_sensors(rotator)[axis]["procedures"]:
        raise CalibrationError(f"{axis}: the {sensor.caps.kind} sensor is not a potentiometer")
    off = rotator.status().offsets.get(axis, 0.0)
    (b1, p1), (b2, p2) = points
    m, c = two_point_pot(b1 - off, p1, b2 - off, p2)
    if m == 0 or not math.isfinite(m):
        raise CalibrationError("the fitted slope M is not usable")
    old = dict(sensor.calibration())
    mech = apply_sensor_calibration(rotator, axis, {"M": m, "C": c})
    return {"M": m, "C": c, "Z": float(old.get("Z", 0.0)), "old_M": float(old.get("M", math.nan)),
            "old_C": float(old.get("C", math.nan)), "position_deg": mech + off}


# =============================================================== long procedures
def _ask(rotator: Any, query: Any, here: Any) -> Any:
    """A long procedure's query: one round trip when ``rotator`` stands in for the
    control process's (RemoteRotator.ask), else ``here()`` on this one. (Not
    urc.model.effects.ask: its handlers, urc.rotator.queries, call this module.)"""
    remote = getattr(rotator, "ask", None)
    return remote(query) if remote is not None else here()


class Procedure(HubProcedure):
    """A calibration that takes time. Call :meth:`poll` with each new status."""

    FAILS_ON = (CommandRejected, CalibrationError)

    def __init__(self, rotator: Any, axis: str):
        _check_axis(rotator, axis)
        super().__init__(rotator, axis)
        self._phase = "start"
        self._since_s: float | None = None

    # -- helpers --------------------------------------------------------------------
    def _fail(self, reason: str) -> None:
        self._stop_antenna()
        self._undo()
        reason = f"{reason}; {self.error}" if self.error else reason
        self.state, self.error, self.step = "failed", reason, f"failed: {reason}"

    def _cancelled(self) -> None:
        self._undo()
        self.state, self.step = "cancelled", "cancelled: antenna stopped" + \
            (f"; {self.error}" if self.error else "")

    def _undo(self) -> None:
        """Put back anything temporary (subclasses)."""

    def _goto_phase(self, phase: str, status: Status) -> None:
        self._phase, self._since_s = phase, status.t_s

    def _elapsed_s(self, status: Status) -> float:
        return 0.0 if self._since_s is None else status.t_s - self._since_s


class MagnetometerCalibration(Procedure):
    """SARCNET: stop at 12 directions, sample the raw field, fit the hard-iron offset."""

    kind = "magnetometer"
    DIRECTIONS = 12
    #: a sample is taken once the antenna has stood still this long (noise settles)
    DWELL_S = 0.5
    #: give up on one direction after this long
    MOVE_TIMEOUT_S = 240.0
    #: a fit worse than this (RMS off-circle / radius) is refused
    MAX_RMS_REL = 0.05

    def __init__(self, rotator: Any, axis: str = "az"):
        super().__init__(rotator, axis)
        described = _ask(rotator, DescribeSensors(), lambda: describe_sensors(rotator))
        if axis != "az" or "magnetometer" not in described[axis]["procedures"]:
            raise CalibrationError("magnetometer calibration needs a compass on the azimuth axis")
        self.samples: list[tuple[float, float]] = []
        self._start_az_deg = 0.0
        self._el_deg = 0.0

    def _target_az(self) -> float:
        return (self._start_az_deg + 360.0 * len(self.samples) / self.DIRECTIONS) % 360.0

    def _poll(self, status: Status) -> None:
        n = self.DIRECTIONS
        if self._phase == "start":
            if status.faults:
                raise CalibrationError("clear the faults first")
            self._start_az_deg = status.az_deg
            if status.el_deg is not None:  # (azimuth only: the goto's elevation is left aside)
                lo, hi = status.limits["el"]
                off = status.offsets.get("el", 0.0)
                # hold elevation where it is (a noisy tilt sensor may read just below the limit)
                self._el_deg = min(max(status.el_deg, lo + off), min(hi + off, 90.0))
            self._move(status)
        elif self._phase == "moving":
            if status.faults:
                raise CalibrationError("fault during the turn: " + status.faults[0].reason)
            if self._elapsed_s(status) > self.MOVE_TIMEOUT_S:
                raise CalibrationError(f"direction {len(self.samples) + 1} not reached in time")
            # wait for the command to take effect, then for the antenna to stand still
            if self._elapsed_s(status) >= 0.2 and self._still(status):
                self._goto_phase("dwell", status)
        elif self._phase == "dwell":
            if not self._still(status):
                self._goto_phase("moving", status)
            elif self._elapsed_s(status) >= self.DWELL_S:
                self.samples.append(tuple(_ask(self.rotator, CompassField(self.axis),
                                               lambda: compass_field(sensor_of(self.rotator, self.axis)))))
                self.progress = len(self.samples) / (n + 1)
                if len(self.samples) < n:
                    self._move(status)
                else:
                    self._finish()

    def _move(self, status: Status) -> None:
        az = self._target_az()
        self.step = f"turning to direction {len(self.samples) + 1} of {self.DIRECTIONS} (az {az:.0f} deg)"
        self.rotator.goto(az, self._el_deg)
        self._goto_phase("moving", status)

    #: an ellipse longer than this (long/short axis) is corrected for soft iron too
    SOFT_IRON_RATIO = 1.02

    def _finish(self) -> None:
        fit = fit_hard_iron(self.samples)
        soft = None
        try:
            soft = fit_soft_iron(self.samples)
        except CalibrationError:
            pass
        if soft is not None and soft.axis_ratio > self.SOFT_IRON_RATIO and soft.rms_rel <= self.MAX_RMS_REL:
            # an ellipse: its centre is the hard iron, its shape the soft iron
            fit = HardIronFit(soft.x, soft.y, fit.radius, soft.rms_rel, fit.max_gap_deg)
        else:
            soft = None
        if fit.rms_rel > self.MAX_RMS_REL:
            raise CalibrationError(f"field samples scatter {fit.rms_rel * 100:.1f}% off the circle "
                                   "(soft iron or a magnet nearby?); calibration not applied")
        if fit.max_gap_deg > 120.0:
            raise CalibrationError(f"the samples leave a {fit.max_gap_deg:.0f} deg gap; "
                                   "the antenna did not turn all the way round")
        old = _ask(self.rotator, SensorCalibrations(),
                   lambda: {self.axis: dict(sensor_of(self.rotator, self.axis).calibration())})[self.axis]
        # the centre is on the boom's axes; the hard iron is taken off on the chip's
        hx, hy = chip_horizontal(fit.x, fit.y)
        constants: dict[str, Any] = {"hard_iron_x": hx, "hard_iron_y": hy}
        if "soft_iron" in old:
            constants["soft_iron"] = list(soft.matrix) if soft is not None else [1.0, 0.0, 0.0, 1.0]
        if "mag_matrix" in old:   # fitted on the raw field: replaces the hand-held 3-D one
            constants["mag_matrix"] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        mech = _ask(self.rotator, ApplyCalibration(self.axis, constants),
                    lambda: apply_sensor_calibration(self.rotator, self.axis, constants))
        self.result = {"hard_iron_x": hx, "hard_iron_y": hy, "field_radius": fit.radius,
                       "rms_rel": fit.rms_rel, "max_gap_deg": fit.max_gap_deg,
                       "old_hard_iron_x": old.get("hard_iron_x"), "old_hard_iron_y": old.get("hard_iron_y"),
                       "soft_iron": list(soft.matrix) if soft is not None else None,
                       "samples": [list(s) for s in self.samples], "position_deg": mech}
        self.progress, self.state = 1.0, "done"
        self.step = f"done: hard iron ({hx:+.4f}, {hy:+.4f}), scatter {fit.rms_rel * 100:.2f}%"


class LimitSwitchHoming(Procedure):
    """BIG-RAS: jog slowly onto the lower limit switch, back off until it releases, and
    re-reference from that edge.

    ``switch_deg`` is the mechanical angle at which the switch trips (BIG-RAS mounts them
    2 deg outside the working range, the default). To let the jog reach the switch even
    when the count says the axis is already at its soft limit, the search runs in a
    temporary frame shifted to the top of the range (``Rotator.search_frame``: never
    persisted, the axis uncertain meanwhile; undone on cancel or failure).
    """

    kind = "homing"
    SEARCH_ROUNDS = 3
    #: travel past the switch edge before the final reading (inside the soft limits)
    CLEAR_MARGIN_DEG = 1.0
    TIMEOUT_S = 900.0
    BACKOFF_TRIES = 20

    def __init__(self, rotator: Any, axis: str, speed_frac: float | None = None,
                 switch_deg: float | None = None):
        super().__init__(rotator, axis)
        if "homing" not in _ask(rotator, DescribeSensors(), lambda: describe_sensors(rotator))[axis]["procedures"]:
            raise CalibrationError(f"{axis}: no lower limit switch to home on")
        caps = rotator.caps.axis(axis)
        self.lo_deg, self.hi_deg = rotator.status().limits[axis]
        self.switch_deg = self.lo_deg - 2.0 if switch_deg is None else float(switch_deg)
        if not self.lo_deg - 20.0 <= self.switch_deg <= self.lo_deg:
            raise CalibrationError(f"switch angle {self.switch_deg:g} must lie within 20 deg below "
                                   f"the lower limit {self.lo_deg:g}")
        self.speed_frac = speed_frac if speed_frac is not None else \
            min(1.0, caps.min_rate_deg_per_s / caps.max_rate_deg_per_s)
        if not 0.0 < self.speed_frac <= 1.0:
            raise CalibrationError(f"speed {self.speed_frac!r} outside 0 < speed <= 1")
        self.offset_deg = rotator.status().offsets.get(axis, 0.0)
        self._shift_deg = 0.0           # temporary frame = true frame + shift
        self._searching = False
        self._rounds = 0
        self._edge_deg: float | None = None
        self._backoff_tries = 0
        self._t0_s: float | None = None

    def _undo(self) -> None:
        if self._searching:
            # back to the true frame (the count is intact) with the uncertainty it had
            self.rotator.end_search(self.axis, None)
            self._searching = False
            self._shift_deg = 0.0

    def _poll(self, status: Status) -> None:
        ax = getattr(status, self.axis)
        if self._t0_s is None:
            self._t0_s = status.t_s
        if status.t_s - self._t0_s > self.TIMEOUT_S:
            raise CalibrationError("homing took too long")
        other = [f for f in status.faults if not (f.kind == "limit_switch" and f.axis == self.axis)]
        if other:
            raise CalibrationError("fault: " + other[0].reason)
        phase = self._phase
        if phase == "start":
            if status.faults or ax.limit_min:
                self._clear(status)
                return
            self._search(status, ax.pos_deg)
        elif phase == "search":
            self.progress = 0.1 + 0.4 * min(1.0, self._elapsed_s(status) / 120.0)
            if ax.limit_min or status.faults:
                self.step = "lower limit switch reached; waiting for the axis to stop"
                self._goto_phase("stopping", status)
            elif self._elapsed_s(status) > 0.5 and self._still(status):
                # the jog ended at the soft limit of the shifted frame: shift again
                if self._rounds >= self.SEARCH_ROUNDS:
                    raise CalibrationError("the lower limit switch was not found")
                self._search(status, ax.pos_deg)
        elif phase == "stopping":
            if not status.moving:
                self._clear(status)
        elif phase == "clear":
            # the clear is applied on the next tick; a move before that would be refused
            if not status.faults:
                self._back_off(status)
            elif self._elapsed_s(status) > 2.0:
                raise CalibrationError("the limit-switch fault did not clear")
        elif phase == "backoff":
            self.progress = 0.6
            if not ax.limit_min:  # (at once: a release seen late is an edge recorded past it)
                self._edge_deg = ax.pos_deg
                self.step = "switch released; moving clear of it"
                self._goto_phase("clearing", status)
            elif self._elapsed_s(status) < 0.2:
                return
            elif self._still(status) and self._elapsed_s(status) > 0.5:
                # The rotator's guard drops a jog the moment the law brakes (negative
                # duty) while the lower switch is pressed, e.g. when a coarse count steps
                # ahead of the ramp; each try still gains a count, so try again.
                self._backoff_tries += 1
                if self._backoff_tries > self.BACKOFF_TRIES:
                    raise CalibrationError("the limit switch did not release when backing off")
                self._back_off(status)
        elif phase == "clearing":
            self.progress = 0.75
            assert self._edge_deg is not None
            if ax.pos_deg - self._edge_deg >= (self.lo_deg - self.switch_deg) + self.CLEAR_MARGIN_DEG:
                self.rotator.stop(self.axis)
                self._goto_phase("settling", status)
            elif self._still(status) and self._elapsed_s(status) > 0.5:
                raise CalibrationError("the axis stopped before clearing the switch")
        elif phase == "settling":
            self.progress = 0.9
            if self._elapsed_s(status) >= 0.3 and self._still(status):
                self._finish(ax.pos_deg)

    def _search(self, status: Status, pos_deg: float) -> None:
        self._rounds += 1
        # Shift the frame so (nearly) the whole range lies below: the jog may now reach
        # the switch. Room is kept at the top for backing off and clearing the switch.
        top = self.hi_deg - (self.lo_deg - self.switch_deg) - self.CLEAR_MARGIN_DEG - 2.0
        # a search frame, never persisted: the rotator keeps the true one in the state
        # record and calls the axis uncertain until the search ends
        self.rotator.search_frame(self.axis, top)
        self._searching = True
        self._shift_deg += top - pos_deg
        self.rotator.move(self.axis, -1, self.speed_frac)
        self.step = f"jogging slowly down to the lower limit switch (round {self._rounds})"
        self._goto_phase("search", status)

    def _clear(self, status: Status) -> None:
        if status.faults:
            self.rotator.clear_faults()
        self._goto_phase("clear", status)

    def _back_off(self, status: Status) -> None:
        self.rotator.move(self.axis, +1, self.speed_frac)
        self.step = "backing off the switch"
        self._goto_phase("backoff", status)

    def _finish(self, pos_deg: float) -> None:
        assert self._edge_deg is not None
        true_deg = self.switch_deg + (pos_deg - self._edge_deg)
        before_deg = pos_deg - self._shift_deg
        self._shift_deg = 0.0
        self.rotator.end_search(self.axis, true_deg)
        self._searching = False
        self.result = {"switch_deg": self.switch_deg, "position_deg": true_deg + self.offset_deg,
                       "correction_deg": true_deg - before_deg}
        self.progress, self.state = 1.0, "done"
        self.step = (f"done: re-referenced to {true_deg + self.offset_deg:.2f} deg "
                     f"(the count was off by {before_deg - true_deg:+.2f} deg)")


def apply_twelve_direction(rotator: Any, result: dict[str, Any]) -> bool:
    """Load a :class:`TwelveDirectionCalibration` result into the compass (azimuth) and
    the tilt sensor (elevation) and write the state record at once (the constants live
    in it). All or nothing: a sensor that refuses puts both back.

    No re-reference, unlike :func:`apply_sensor_calibration`: the board is in the
    operator's hand, so its readings say nothing about where the antenna points; the
    compass and tilt sensor are absolute and read the antenna again, with the new
    constants, once the board is back on the boom. The 3-D soft iron replaces the
    horizontal one of the turn-round procedure. Returns whether the record reached disk.
    """
    accel = {"accel_offset": result["accel_offset"], "accel_scale": result["accel_scale"]}
    hx, hy, hz = result["mag_offset"]
    steps: list[tuple[Any, dict[str, Any]]] = [
        (sensor_of(rotator, "az"), {"hard_iron_x": hx, "hard_iron_y": hy, "hard_iron_z": hz,
                                  "mag_matrix": result["mag_matrix"], "soft_iron": [1.0, 0.0, 0.0, 1.0],
                                  **accel})]
    # azimuth only: no tilt sensor, the compass carries its own accelerometer
    el_sensor = sensor_of(rotator, "el") if "el" in rotator.caps.axes else None
    if el_sensor is not None and "accel_offset" in el_sensor.calibration():
        steps.append((el_sensor, accel))
    with getattr(rotator, "lock", contextlib.nullcontext()):
        done: list[tuple[Any, dict[str, Any]]] = []
        try:
            for sensor, values in steps:
                old = dict(sensor.calibration())
                sensor.load_calibration(values)
                done.append((sensor, old))
        except Exception:
            for sensor, old in reversed(done):
                sensor.load_calibration(old)
            raise
    save = getattr(rotator, "save_now", None)
    return bool(save()) if save is not None else False
