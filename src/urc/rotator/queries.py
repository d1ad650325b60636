"""Hardware queries and calibration procedures (:class:`urc.model.messages.Query`), run
where the hardware is.

A protocol command or a web route that needs more than the status (a sensor's count,
its constants, a raw reading) or a calibration step that no tick may split asks with
one typed message: :func:`urc.model.effects.ask` sends it to the control process from the I/O process
(one round trip, however much the handler reads), or runs its handler at once on a
rotator in this process (tests, tools), with the handlers below, which this module
registers there when imported. They are the only code the control process runs for a
query: one per message type, looked up by type.
"""

from __future__ import annotations

from typing import Any, Callable

from ..errors import CommandRejected, UrcError
from ..model import effects
from ..model.messages import (ApplyCalibration, BeginHandCalibration, Goto, GotoPose, Reset, ResetOutcome, ApplyTwelveDirection, CompassField, CountReading, DescribeSensors,
                            ControllerHome, HardwareInfo, HardwareSummary, MotorDuties, PotApply, PotReading, PotState, PotUnits, Query,
                            RawVectors, SensorCalibrations, SensorCount, SimClear, SimFault)


def handle(rot: Any, query: Query) -> Any:
    """Run ``query`` on the real rotator ``rot`` (its handler, by the query's type)."""
    handler = HANDLERS.get(type(query))
    if handler is None:
        raise TypeError(f"{type(query).__name__} is not a query the control process answers")
    return handler(rot, query)


def _axis_sensor(rot: Any, axis: str) -> Any:
    """The axis' sensor, None when the rotator has no such axis (a single-axis elevation)."""
    if axis not in ("az", "el"):
        raise ValueError(f"axis must be az or el, got {axis!r}")
    try:
        return rot.hw.axis(axis).sensor
    except (AttributeError, ValueError):  # (ValueError: no elevation axis)
        return None


def _sensor_count(rot: Any, q: SensorCount) -> CountReading:
    sensor = _axis_sensor(rot, q.axis)
    if sensor is None:
        return CountReading(None, None)
    step = getattr(getattr(sensor, "caps", None), "resolution_deg", None)
    counts = getattr(sensor, "counts", None)
    if counts is None or not step:
        return CountReading(None, step)
    # (the counter starts at 0 in whatever pose the controller powered up: counted from
    # the axis' reference, as the position is)
    return CountReading(round(int(counts()) + getattr(sensor, "reference_deg", 0.0) / step), step)


def _calibrations(rot: Any, _q: SensorCalibrations) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    for axis in ("az", "el"):
        sensor = _axis_sensor(rot, axis)
        constants = getattr(sensor, "calibration", None)
        out[axis] = dict(constants()) if constants is not None else {}
    return out


def _raw_parts(rot: Any) -> tuple[Any, Any] | None:
    """The compass driver's magnetometer, and the tilt driver's accelerometer (or the
    compass's own); None without both."""
    az, el = _axis_sensor(rot, "az"), _axis_sensor(rot, "el")
    mag = getattr(az, "mag", None)
    acc = getattr(el, "accel", None) or getattr(az, "accel", None)
    return None if mag is None or acc is None else (mag, acc)


def _raw_vectors(rot: Any, _q: RawVectors) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
    parts = _raw_parts(rot)
    if parts is None:
        return None
    mag, acc = parts
    return tuple(float(v) for v in mag.read_vector()), tuple(float(v) for v in acc.read_vector())


def _begin_hand_calibration(rot: Any, q: BeginHandCalibration) -> bool:
    if _raw_parts(rot) is None:
        return False
    rot.stop()
    rot.hold_local(q.hold, True)
    return True


def _reset(rot: Any, q: Reset) -> ResetOutcome:
    calibrations = _calibrations(rot, SensorCalibrations())
    rot.stop()
    rot.clear_faults()
    if not isinstance(q.home, (Goto, GotoPose)):
        raise TypeError(f"a reset goes home with a Goto or GotoPose, not {type(q.home).__name__}")
    try:
        getattr(rot, q.home.METHOD)(**q.home.arguments())
    except CommandRejected as exc:
        return ResetOutcome(calibrations, str(exc))
    return ResetOutcome(calibrations, None)


def _pot_state(rot: Any, _q: PotState) -> PotReading | None:
    """A G4JNT-style ratiometric pot: its constants include K and it reports the ADC
    count behind each reading."""
    sensor = _axis_sensor(rot, "az")
    if sensor is None or not hasattr(sensor, "last_counts"):
        return None
    try:
        cal = dict(sensor.calibration())
    except (AttributeError, UrcError):
        return None
    if "K" not in cal or "M" not in cal:
        return None
    return PotReading(cal, int(sensor.last_counts))


def _pot_units(rot: Any, q: PotUnits) -> float:
    from ..procedures import calibration
    return calibration.pot_units(calibration.sensor_of(rot, q.axis), q.samples)


def _compass_field(rot: Any, q: CompassField) -> tuple[float, float]:
    from ..procedures import calibration
    return calibration.compass_field(calibration.sensor_of(rot, q.axis), q.samples)


def _describe(rot: Any, _q: DescribeSensors) -> dict[str, Any]:
    from ..procedures import calibration
    return calibration.describe_sensors(rot)


def _apply(rot: Any, q: ApplyCalibration) -> float:
    from ..procedures import calibration
    if q.require:
        constants = getattr(_axis_sensor(rot, q.axis), "calibration", None)
        have = dict(constants()) if constants is not None else {}
        missing = [k for k in q.require if k not in have]
        if missing:
            raise calibration.NoSuchConstant(f"the {q.axis} sensor has no {', '.join(missing)}: nothing loaded")
    return calibration.apply_sensor_calibration(rot, q.axis, dict(q.values), local=q.local)


def _pot_apply(rot: Any, q: PotApply) -> dict[str, float]:
    from ..procedures import calibration
    return calibration.pot_apply(rot, q.axis, [tuple(p) for p in q.points])


def _twelve(rot: Any, q: ApplyTwelveDirection) -> bool:
    from ..procedures import calibration
    on_disk = calibration.apply_twelve_direction(rot, dict(q.result))
    if q.release is not None:
        rot.hold_local(q.release, False)
    return on_disk


def _controller_home(rot: Any, _q: ControllerHome) -> None:
    home = getattr(getattr(rot.hw.axis("az"), "positioner", None), "request_home", None)
    if home is None:
        raise CommandRejected("no controller to home here: homing on the controller's own endstops is for a "
                              "bridged controller that has them (the SatNOGS firmware)", "invalid")
    rot.stop()
    reason = home()
    if reason:
        raise CommandRejected(f"the controller cannot home: {reason}", "invalid")


def _hardware_info(rot: Any, _q: HardwareInfo) -> HardwareSummary:
    hw = getattr(rot, "hw", None)
    path = getattr(getattr(rot, "store", None), "path", None)
    return HardwareSummary(str(getattr(hw, "backend", "")), _sim_world(hw) is not None,
                           "" if path is None else str(path.parent))


def _sim_world(hw: Any) -> Any:
    """The simulated world behind the hardware, None on real hardware."""
    return hw.world


def _motor_duties(rot: Any, _q: MotorDuties) -> dict[str, float]:
    return {axis: float(rot.hw.axis(axis).motor.duty) for axis in rot.caps.axes}


def _world(rot: Any) -> Any:
    # the simulator, or the gpio backend on emulated parts (the faults reach them)
    world = _sim_world(rot.hw)
    if world is None:
        raise PermissionError("fault injection exists only on the simulator (sim, or gpio emulated)")
    return world


def _sim_fault(rot: Any, q: SimFault) -> None:
    _world(rot).inject(q.axis, q.kind, **q.params)


def _sim_clear(rot: Any, q: SimClear) -> None:
    _world(rot).clear(q.axis, q.kind)


#: query type -> its handler (the only code a query runs)
HANDLERS: dict[type[Query], Callable[[Any, Any], Any]] = {
    SensorCount: _sensor_count, SensorCalibrations: _calibrations, RawVectors: _raw_vectors,
    BeginHandCalibration: _begin_hand_calibration, Reset: _reset,
    PotState: _pot_state, PotUnits: _pot_units, CompassField: _compass_field, DescribeSensors: _describe,
    ApplyCalibration: _apply, PotApply: _pot_apply, ApplyTwelveDirection: _twelve,
    ControllerHome: _controller_home, HardwareInfo: _hardware_info, MotorDuties: _motor_duties, SimFault: _sim_fault, SimClear: _sim_clear,
}

effects.handle_queries_with(handle)
