"""The physics-simulator hardware backend (the default backend, a real backend).

``build_sim_hardware(caps, clock, state_dir, options)`` returns a
:class:`~urc.hardware.interfaces.Hardware` whose devices sit on a :class:`SimWorld`:
DC or relay/AC motors through a gearbox with backlash, stiction, end stops, brakes,
limit switches, wind, and each profile's sensor (encoder, pulse counter, pot, AS5600,
magnetometer). ``hardware.world`` is the world, for fault injection and truth.

Options (all optional): ``seed`` (int, 1), ``wind`` (bool, True), ``truth_file`` (path,
default ``state_dir/"simulator-truth.json"``; ``None`` disables persistence),
``start_az_deg`` / ``start_el_deg`` (initial true angles without a truth file, default
park), ``fault_injection`` (faults active from the start: a list of
``{"axis": "az", "kind": "jam", ...kwargs}`` or a mapping ``{"az": {"jam": {...}}}``),
``sensor_noise`` (bool, True), ``truth_interval_s`` (float, 0.02: least clock time
between truth writes), ``truth_wall_interval_s`` (float, 0.02: least wall time between
writes, so a fast virtual clock is not slowed by file writes; 0 = exactly repeatable), ``heartbeat_file``
(path, default ``state_dir/"heartbeat"`` on a real clock, none on a virtual one; ``None``: no file): the simulated heartbeat output's level and
toggle count, also in the truth as ``heartbeat``; ``motor_enable_timeout_s`` (float, None =
not wired): the external safety chain (:mod:`.safety`), motor power held only while the
heartbeat's rising edges come at most this far apart, in the truth as ``motor_enable``
(its faults: ``fault_injection`` on axis "chain"); ``motor_enable_sense`` ("contact", the
default, "q", or None: not wired): the chain's read-back input, ``Hardware.enable_sense``,
read from the model when the chain is;
``truth_log`` (path, default the environment variable ``URC_SIM_TRUTH_LOG``, else none): the
iron's history appended as JSON lines (:mod:`.truthlog`), for benchmarks; ``pointing_error``
(a mapping of pointing-model terms in degrees, e.g. ``{"ia_deg": 0.5, "tf_deg": 1.0}``,
:class:`urc.pointing.model.PointingModel`; default none): where the beam truly points,
for a simulated power source (``world.pointing_error``); the control never sees it.
``stepper_driver`` ("a4988", the default, "drv8825", "tmc2208", "tmc2209"): the step/dir
chip of a profile with steppers (satnogs-v3, :attr:`.params.SimAxisParams.stepper`),
whose axes the simulator drives as the gpio backend does (:mod:`.stepdrive`): urc's
step/dir driver, the step count as the sensor, the stepper model moving the axis.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any

from ...caps import RotatorCaps
from ...clock import Clock, VirtualClock
from ...errors import ConfigError
from ..interfaces import AxisHardware, Hardware
from .outputs import SimDigitalOutput
from .params import (PHYSICS, SimAxisParams, SimRotatorParams, SimSensorParams, params_for_caps,
                     physics_for)
from .truthlog import ENV as TRUTH_LOG_ENV
from .safety import CHAIN_FAULT_KINDS, SimEnableSense
from .world import FAULT_KINDS, SimWorld

log = logging.getLogger(__name__)

_OPTIONS = {"seed", "wind", "truth_file", "start_az_deg", "start_el_deg", "fault_injection",
            "sensor_noise", "truth_interval_s", "truth_wall_interval_s", "heartbeat_file",
            "motor_enable_timeout_s", "motor_enable_sense", "truth_log", "pointing_error",
            "stepper_driver"}


def build_sim_hardware(caps: RotatorCaps, clock: Clock, state_dir: Path,
                       options: dict[str, Any]) -> Hardware:
    options = dict(options or {})
    unknown = set(options) - _OPTIONS
    if unknown:
        log.warning("simulator: ignoring unknown options %s", ", ".join(sorted(unknown)))
    world, params = make_world(caps, clock, state_dir, options)
    steppers = _steppers(caps, clock, world, params, options.get("stepper_driver", "a4988"))
    syncs = [sync for _, _, sync, _ in steppers.values()]

    def axis_hw(name: str) -> AxisHardware:
        lo, hi = world.limits[name]
        motor, sensor, _, _ = steppers.get(name, (world.motors[name], world.sensors[name], None, None))
        return AxisHardware(motor=motor, sensor=sensor, brake=world.brakes[name], limit_min=lo, limit_max=hi)

    def poll(now_s: float) -> None:
        with world.lock:             # (the step count and the axis: one state of the iron)
            world.advance_to(now_s)
            for sync in syncs:
                sync()

    def close() -> None:
        for motor, _, _, _ in steppers.values():
            motor.close()            # the train cut and the chip disabled, as the gpio backend's
        heartbeat.close()
        world.close()

    # the file is for watching a running ``urc run`` from outside; on a virtual clock
    # (tests, benchmarks: thousands of rotators) it would only be one more thread each
    default_file = None if isinstance(clock, VirtualClock) else Path(state_dir) / "heartbeat"
    heartbeat_file = options.get("heartbeat_file", default_file)
    heartbeat = SimDigitalOutput("heartbeat", Path(heartbeat_file) if heartbeat_file else None,
                                 on_write=world.enable.heartbeat if world.enable is not None else None)

    sense_point = options.get("motor_enable_sense", "contact")
    try:
        sense = SimEnableSense(world.enable, clock.now_s, sense_point) \
            if world.enable is not None and sense_point is not None else None
    except ValueError as exc:
        raise ConfigError(f"simulator options: {exc}", key="hardware.options") from exc

    def truth() -> dict[str, Any]:
        out = world.truth()  # (a dict of its own: added to, not copied, every tick)
        out["heartbeat"] = heartbeat.truth()
        if world.enable is not None:
            out["motor_enable"] = world.enable.truth()
        return out

    # a single-axis rotator: the simulated mechanics keep an elevation joint (standing
    # at its park), but no part of it is wired: nothing drives or reads it
    return Hardware(backend="sim", az=axis_hw("az"), el=axis_hw("el") if caps.has_el else None,
                    poll_hook=poll if syncs else world.advance_to, truth_hook=truth, heartbeat=heartbeat,
                    motor_enable_timeout_s=world.enable.timeout_s if world.enable is not None else None,
                    enable_sense=sense,
                    close_hook=close,
                    # (the simulated chips: "az stepper", as the gpio emulation names them)
                    parts=[(f"{name} stepper", chip) for name, (_, _, _, chip) in steppers.items()],
                    # what a motor driver's over-current trip would be set to: well above
                    # running current, below the stall current a jam draws
                    world=world, overcurrent_a={n: 0.8 * params.axis(n).stall_current_a for n in ("az", "el")})


def _steppers(caps: RotatorCaps, clock: Clock, world: SimWorld, params: SimRotatorParams,
              driver: Any) -> dict[str, tuple[Any, Any, Any, Any]]:
    """axis -> (motor, sensor, sync, chip) for each wired axis whose physics is a stepper."""
    from ..drivers.stepdir_chips import STEPDIR_CHIPS
    names = [n for n in ("az", "el") if (n == "az" or caps.has_el) and params.axis(n).stepper is not None]
    if not names:
        return {}
    if driver not in STEPDIR_CHIPS:
        raise ConfigError(f"simulator options: unknown stepper_driver {driver!r}", key="hardware.options",
                          expected=" | ".join(sorted(STEPDIR_CHIPS)), found=driver)
    from .stepdrive import build_sim_stepper
    out = {}
    for name in names:
        motor, sensor, chip, sync = build_sim_stepper(name, caps, world, clock, driver)
        out[name] = (motor, sensor, sync, chip)
    return out


def make_world(caps: RotatorCaps, clock: Clock, state_dir: Path,
               options: dict[str, Any]) -> tuple[SimWorld, SimRotatorParams]:
    """The simulated rotator the sim backend and the emulated gpio backend stand on."""
    # A profile's own physics when the caps are that profile's; else derived from caps.
    params = PHYSICS.get(caps.name)
    if params is None or params_for_caps(caps) != params:
        params = params_for_caps(caps)
    truth_file = options.get("truth_file", Path(state_dir) / "simulator-truth.json")
    start = {axis: float(options[f"start_{axis}_deg"])
             for axis in ("az", "el") if options.get(f"start_{axis}_deg") is not None}
    try:
        world = SimWorld(caps, params, clock,
                         truth_path=Path(truth_file) if truth_file else None,
                         seed=int(options.get("seed", 1)), wind=bool(options.get("wind", True)),
                         start_deg=start, sensor_noise=bool(options.get("sensor_noise", True)),
                         truth_interval_s=float(options.get("truth_interval_s", 0.02)),
                         truth_wall_interval_s=float(options.get("truth_wall_interval_s", 0.02)),
                         motor_enable_timeout_s=_timeout(options.get("motor_enable_timeout_s")),
                         truth_log=options.get("truth_log", os.environ.get(TRUTH_LOG_ENV) or None),
                         pointing_error=_pointing_error(options.get("pointing_error")))
    except (TypeError, ValueError, AttributeError) as exc:
        raise ConfigError(f"simulator options: {exc}", key="hardware.options") from exc
    for axis, kind, kw in _fault_list(options.get("fault_injection")):
        world.inject(axis, kind, **kw)
    return world, params


def _pointing_error(spec: Any) -> Any:
    if spec is None:
        return None
    from ...pointing.model import PointingModel
    return spec if isinstance(spec, PointingModel) else PointingModel.from_dict(dict(spec))


def _timeout(value: Any) -> float | None:
    return None if value is None else float(value)


def _fault_list(spec: Any) -> list[tuple[str, str, dict[str, Any]]]:
    if not spec:
        return []
    out = []
    try:
        if isinstance(spec, dict):
            for axis, kinds in spec.items():
                for kind, kw in kinds.items():
                    out.append((axis, kind, dict(kw or {})))
        else:
            for item in spec:
                item = dict(item)
                out.append((item.pop("axis"), item.pop("kind"), item))
    except (TypeError, KeyError, AttributeError, ValueError) as exc:
        raise ConfigError(f"simulator fault_injection: {exc}", key="hardware.fault_injection",
                          expected="[{axis, kind, ...}] or {axis: {kind: {...}}}",
                          found=spec) from exc
    for axis, kind, _ in out:
        if axis == "chain" and kind in CHAIN_FAULT_KINDS:
            continue
        if axis not in ("az", "el") or kind not in FAULT_KINDS:
            raise ConfigError(f"simulator fault_injection: bad axis/kind {axis!r}/{kind!r}",
                              key="hardware.fault_injection",
                              expected=f"axis az|el, kind {'|'.join(FAULT_KINDS)}; or axis chain, "
                                       f"kind {'|'.join(CHAIN_FAULT_KINDS)}",
                              found=(axis, kind))
    return out


__all__ = ["build_sim_hardware", "physics_for", "params_for_caps", "PHYSICS", "SimWorld",
           "SimAxisParams", "SimRotatorParams", "SimSensorParams", "SimDigitalOutput", "FAULT_KINDS"]
