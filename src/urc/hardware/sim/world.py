"""SimWorld: both axes of the simulated rotator, its devices, faults and persisted truth.

The world advances its physics to a clock time in fixed substeps (``advance_to``), so
the result does not depend on how often it is polled. Its true mechanical state is
"real iron": written atomically to a truth file (at most every ``truth_interval_s`` of
clock time, only when it changed, and on ``close``) and read back by the next world, as
if the controller had been restarted on the same rotator. A process that dies without
``close`` leaves its motor lines at their last level, as a Pi does: the next world runs
the motors on from the last record until the safety relay cut them (when the part is
wired) or, without it, until that next world opened (the process that takes the lines
over and drives them safe). ``truth_log`` keeps the history as well (:mod:`.truthlog`).

(Over 600 lines on purpose: the world's physics, devices, faults and truth are one
simulated rotator, and the faults act on all of them at once.)
"""

from __future__ import annotations

import functools
import json
import logging
import math
import os
import random
import threading
import time
from pathlib import Path
from typing import Any, Mapping

from ...caps import RotatorCaps
from ...clock import Clock, VirtualClock
from .drives import SimBrake, SimLimitSwitch, SimMotor
from .params import SimRotatorParams
from .physics import AxisPhysics
from .safety import CHAIN_FAULT_KINDS, MotorPowerEnable
from .sensors import FaultySensor, SensorBoard, make_sensor
from .truthlog import TruthLog

log = logging.getLogger(__name__)

AXES = ("az", "el")
TRUTH_VERSION = 1
FAULT_KINDS = ("sensor_stuck", "sensor_jump", "sensor_dead", "jam", "runaway",
               "limit_switch", "reverse_wiring", "slow_read")
#: the "axis" the safety chain's faults are injected on (:data:`CHAIN_FAULT_KINDS`)
CHAIN = "chain"
#: a coast-down after a restart is simulated for at most this long.
_MAX_COAST_S = 120.0
#: a dead process's motor run-on is simulated for at most this long (longer than any
#: seed machine takes from one end stop to the other: the motor stalls there)
_MAX_RUN_ON_S = 120.0


def _serialised(method):
    """One caller at a time: the world is one piece of iron, and the control process acts
    on it from more than one thread (the loop's tick, and the tick watch driving the
    outputs safe: after a SIGSTOP both wake at once). Unserialised, two threads stepped
    the same substeps or took the same brake event."""
    @functools.wraps(method)
    def serialised(self, *args, **kwargs):
        with self.lock:
            return method(self, *args, **kwargs)
    return serialised


class SimWorld:
    def __init__(self, caps: RotatorCaps, params: SimRotatorParams, clock: Clock, *,
                 truth_path: Path | None, seed: int = 1, wind: bool = True,
                 start_deg: dict[str, float] | None = None, sensor_noise: bool = True,
                 truth_interval_s: float = 0.02, truth_wall_interval_s: float = 0.02,
                 motor_enable_timeout_s: float | None = None, truth_log: Path | str | None = None,
                 pointing_error: Any = None):
        self.caps = caps
        #: where the beam truly points differs from the axes' angles by this
        #: :class:`urc.pointing.model.PointingModel` (None: the beam is the boresight).
        #: Only a simulated power source reads it (urc.peaking.simsource.true_beam);
        #: the axes, the sensors and the control never see it.
        self.pointing_error = pointing_error
        self.params = params
        self.clock = clock
        #: held by every call that reads or changes the iron (re-entrant: a heartbeat
        #: edge and a drive first advance the world)
        self.lock = threading.RLock()
        self.seed = int(seed)
        self.truth_path = Path(truth_path) if truth_path is not None else None
        self.truth_interval_s = float(truth_interval_s)
        # Writing a file costs ~0.1-0.4 ms; under a virtual clock running 100x real time
        # that would dominate, so writes are also spaced by this much wall time. Set 0
        # for a truth file that is exactly repeatable under a virtual clock.
        self.truth_wall_interval_s = float(truth_wall_interval_s)
        self.dt_s = params.substep_s
        start_deg = start_deg or {}
        #: the external safety chain (heartbeat -> motor power enable), None = not wired
        self.enable = MotorPowerEnable(motor_enable_timeout_s, clock.now_s) \
            if motor_enable_timeout_s is not None else None
        #: the history of the iron, for benchmarks (None: not kept)
        self.log = TruthLog(truth_log) if truth_log else None
        #: (record wall time, run-on) of the record this world started from
        self._restored_from: tuple[float | None, float] = (None, 0.0)
        saved = self._load_truth()

        self.axes: dict[str, AxisPhysics] = {}
        for name in AXES:
            ax_caps, p = caps.axis(name), params.axis(name)
            pulse_res = ax_caps.sensor.resolution_deg if ax_caps.sensor.kind == "pulse" else None
            phys = AxisPhysics(
                p, start_deg=float(start_deg.get(name, ax_caps.park_deg)), dt_s=self.dt_s,
                wind_update_s=params.wind_update_s,
                wind_rng=random.Random(f"urc-sim:{self.seed}:{name}:wind"),
                wind_enabled=wind, relay_levels=ax_caps.drive_levels,
                pulse_res_deg=pulse_res)
            if saved is not None:
                self._restore(phys, saved[name], ax_caps.brake_engage_s)
            self.axes[name] = phys
        if saved is not None and self.log is not None:
            self._log_restore(saved)

        # Devices. Incremental sensors start counting from 0 now (power-on); on a fresh
        # rotator (no truth file) they start referenced to the true angle.
        self.sensors: dict[str, FaultySensor] = {}
        #: the compass board (magnetometer + accelerometer), which a hand can take off the
        #: boom (SARCNET calibration): ``world.board.point("+x", "field")``
        self.board = SensorBoard(params.axis("az").sensor)
        self.motors: dict[str, SimMotor] = {}
        self.brakes: dict[str, SimBrake | None] = {}
        self.limits: dict[str, tuple[SimLimitSwitch | None, SimLimitSwitch | None]] = {}
        for name in AXES:
            ax_caps, p, phys = caps.axis(name), params.axis(name), self.axes[name]
            self.motors[name] = SimMotor(phys, name, catch_up=self.catch_up, lock=self.lock)
            self.sensors[name] = make_sensor(
                name, ax_caps.sensor, phys, p.sensor,
                random.Random(f"urc-sim:{self.seed}:{name}:sensor"),
                noise=sensor_noise, referenced=saved is None, drive=self.motors[name], board=self.board,
                compass_accel_rng=None if caps.has_el or name != "az"
                else random.Random(f"urc-sim:{self.seed}:az:accel"))
            self.brakes[name] = SimBrake(self, name) if p.has_brake else None
            lo = hi = None
            if ax_caps.limit_switches and p.switch_min_deg is not None:
                lo = SimLimitSwitch(phys, "min", p.switch_min_deg)
            if ax_caps.limit_switches and p.switch_max_deg is not None:
                hi = SimLimitSwitch(phys, "max", p.switch_max_deg)
            self.limits[name] = (lo, hi)

        self._origin_s: float | None = None
        #: the clock time the last advance reached (a drive's catch-up mostly asks again)
        self._reached_s: float | None = None
        self._brake_events: dict[str, tuple[float, bool]] = {}
        #: what the brake relays ask for (the coil gets it only while motor power is on)
        self._brake_cmd: dict[str, bool] = {n: False for n in AXES}
        if self.enable is not None:
            self.enable.on_edge = self._heartbeat_edge
            for phys in self.axes.values():     # no heartbeat yet: the relay is out
                phys.powered = False
                phys._apply_drive()
        self._faults: dict[str, dict[str, dict[str, Any]]] = {n: {} for n in AXES}
        self._last_written: tuple | None = self._state_key() if saved is not None else None
        # in real time the truth file is written by a thread of its own (a write can wait
        # long for a busy disk, and the control tick advances the world); on a virtual
        # clock it is written at once, exactly repeatable
        self._truth_writer = _LatestWriter(self._write_truth) \
            if self.truth_path is not None and not isinstance(clock, VirtualClock) else None
        self._last_write_s = -math.inf
        self._last_write_wall_s = -math.inf
        self._closed = False

    # ------------------------------------------------------------------ time
    @property
    def time_s(self) -> float | None:
        """Clock time the physics has reached (None before the first ``advance_to``)."""
        if self._origin_s is None:
            return None
        return self._origin_s + self.axes["az"].tick * self.dt_s

    @_serialised
    def advance_to(self, now_s: float) -> None:
        """Integrate from the last time to ``now_s``; the first call only sets the time."""
        if self._origin_s is None:
            self._origin_s = float(now_s)
            return
        if now_s == self._reached_s and self.log is None:
            # reached already (each drive's catch-up right after the tick's poll): nothing
            # to step, and the iron is as the truth-file check just found it
            return
        target = math.floor((now_s - self._origin_s) / self.dt_s + 1e-9)
        cut_tick = self._cut_tick()
        for name, phys in self.axes.items():
            while target > phys.tick:
                # the next event inside this step: the brake moving, or the safety relay
                # dropping out (power cut at the heartbeat's timeout)
                ev = self._brake_events.get(name)
                ev_tick = math.inf if ev is None else \
                    max(phys.tick, math.ceil((ev[0] - self._origin_s) / self.dt_s - 1e-9))
                cut = max(cut_tick, phys.tick) if phys.powered and cut_tick is not None else math.inf
                nxt = min(ev_tick, cut, target)
                phys.step_n(int(nxt) - phys.tick)
                if nxt == cut:
                    self._power_off(name, phys, self._origin_s + cut * self.dt_s)
                elif nxt == ev_tick and ev is not None:
                    phys.brake_engaged = not ev[1]
                    del self._brake_events[name]
            self.sensors[name].after_advance()
        if self.log is not None:
            self.log.sample(time.time(), self._log_axes())
        if (self.truth_path is not None
                and now_s - self._last_write_s + 1e-6 >= self.truth_interval_s
                and time.monotonic() - self._last_write_wall_s >= self.truth_wall_interval_s):
            key = self._state_key()
            if key != self._last_written:
                if self._truth_writer is not None:
                    self._truth_writer.submit(self._truth_record())
                else:
                    self._write_truth()
                self._last_written = key
                self._last_write_s = now_s
                self._last_write_wall_s = time.monotonic()
        self._reached_s = now_s

    def catch_up(self) -> None:
        """Integrate up to the clock's present (before a command changes the drive)."""
        if self._origin_s is not None:
            now_s = self.clock.now_s()
            # (advance_to's own first test, before its lock and call: each drive asks
            # right after the tick's poll; _reached_s is set last, once a step is done)
            if now_s != self._reached_s or self.log is not None:
                self.advance_to(now_s)

    @_serialised
    def command_brake(self, name: str, released: bool) -> None:
        """Brake coil on (release) / off (engage); the brake moves after its delay."""
        phys = self.axes[name]
        if not phys.p.has_brake:
            return
        self._brake_cmd[name] = bool(released)
        if not phys.powered:
            released = False         # the safety relay has the coil's supply off
        self._schedule_brake(name, released, self.clock.now_s())

    def _schedule_brake(self, name: str, released: bool, at_s: float) -> None:
        phys = self.axes[name]
        pending = self._brake_events.get(name)
        if pending is not None:
            if pending[1] == released:
                return
            del self._brake_events[name]     # reversed before it moved: cancel
        if (not phys.brake_engaged) == released:
            return
        ax = self.caps.axis(name)
        delay_s = ax.brake_release_s if released else ax.brake_engage_s
        self._brake_events[name] = (at_s + delay_s, released)

    # ------------------------------------------------------------ safety chain
    def _cut_tick(self) -> int | None:
        """The substep at which the safety relay drops out (None: no part / no edge
        yet, the power is already off then)."""
        if self.enable is None or self._origin_s is None:
            return None
        cut_s = self.enable.cut_at_s()
        if not math.isfinite(cut_s):        # (no edge yet; or a chain that never cuts)
            return None
        return math.ceil((cut_s - self._origin_s) / self.dt_s - 1e-9)

    def _power_off(self, name: str, phys: AxisPhysics, at_s: float) -> None:
        """The relay dropped out: the motor supply opens (the motor coasts, terminals
        open) and the brake coil's supply with it (the brake engages after its delay)."""
        phys.powered = False
        phys._apply_drive()
        if name == "az" and self.enable is not None:
            self.enable.trips += 1
            if self.log is not None:  # (found late after a freeze: when it happened)
                self.log.event("cut", time.time() - (self.clock.now_s() - at_s))
            if self.enable.held_open():
                log.warning("simulator: the safety relay dropped with the heartbeat running (contact_open)")
            else:
                log.warning("simulator: no heartbeat edge for %.3f s: the safety relay cut motor power",
                            self.enable.timeout_s)
        if phys.p.has_brake:
            self._schedule_brake(name, False, at_s)

    @_serialised
    def _heartbeat_edge(self, now_s: float) -> None:
        """A rising heartbeat edge at ``now_s``: the world first runs to it under the old
        deadline, then the relay (re)closes: the motors get their drive back, and the
        brake coil what its relay asks for."""
        if self._origin_s is not None:
            self.advance_to(now_s)
        if self.enable is not None and self.enable.held_open():
            return                        # (the contact_open fault: the coil gets nothing)
        self._power_on(now_s)

    def _power_on(self, now_s: float) -> None:
        for name, phys in self.axes.items():
            if not phys.powered:
                phys.powered = True
                phys._apply_drive()
                if self._brake_cmd[name]:
                    self._schedule_brake(name, True, now_s)

    def _chain_changed(self) -> None:
        """A chain fault came or went: the power is what the chain now gives."""
        assert self.enable is not None
        now_s = self.clock.now_s()
        if self.enable.powered_at(now_s):
            self._power_on(now_s)
        else:
            for name, phys in self.axes.items():
                if phys.powered:
                    self._power_off(name, phys, now_s)

    def motor_power(self) -> bool:
        """Whether the motors have their supply (always, without the safety part)."""
        return all(phys.powered for phys in self.axes.values())

    # ------------------------------------------------------------------ truth
    @_serialised
    def truth(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for name, phys in self.axes.items():
            lo, hi = self.limits[name]
            out[name] = {
                "deg": phys.load_deg,
                "rate_deg_per_s": phys.load_deg_per_s,
                "gear_deg": phys.gear_deg,
                "gear_rate_deg_per_s": phys.gear_deg_per_s,
                "current_a": phys.current_a(),
                "brake_released": (not phys.brake_engaged) if phys.p.has_brake else None,
                "wind_nm": phys.wind_nm if phys.wind_enabled else 0.0,
                "limit_min": lo.is_active() if lo else None,
                "limit_max": hi.is_active() if hi else None,
                "faults": sorted(self._faults[name]),
            }
        return out

    def _state_key(self) -> tuple:
        return tuple((a.gear_deg, a.gear_deg_per_s, a.load_deg, a.load_deg_per_s,
                      a.brake_engaged) for a in self.axes.values())

    def _truth_record(self) -> dict[str, Any]:
        rec: dict[str, Any] = {"version": TRUTH_VERSION, "profile": self.caps.name, "axes": {
            name: {"gear_deg": a.gear_deg, "gear_deg_per_s": a.gear_deg_per_s,
                   "load_deg": a.load_deg, "load_deg_per_s": a.load_deg_per_s,
                   "brake_released": not a.brake_engaged, "drive": a.effective_duty()}
            for name, a in self.axes.items()}}
        if not isinstance(self.clock, VirtualClock):
            # a process killed now leaves the motors driving (its lines hold their
            # level): the next world runs them on from this wall time, until the safety
            # relay drops out when the part is wired, else until it opens
            rec["wall_s"] = time.time()
            cut_wall_s = self.enable.cut_at_wall_s() if self.enable is not None else None
            if self.enable is not None and (cut_wall_s is None or math.isfinite(cut_wall_s)):
                # (a chain that never cuts, stuck or welded, is as no part: no deadline)
                rec["power_cut_at_wall_s"] = cut_wall_s
        return rec

    def _write_truth(self, data: dict[str, Any] | None = None) -> None:
        assert self.truth_path is not None
        data = self._truth_record() if data is None else data
        try:
            self.truth_path.parent.mkdir(parents=True, exist_ok=True)
            tmp = self.truth_path.with_name(self.truth_path.name + ".tmp")
            with open(tmp, "w", encoding="utf-8") as f:
                json.dump(data, f)
            os.replace(tmp, self.truth_path)
        except OSError as exc:
            log.warning("simulator: cannot write truth file %s: %s", self.truth_path, exc)

    def _load_truth(self) -> dict[str, dict[str, float]] | None:
        path = self.truth_path
        if path is None or not path.exists():
            return None
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            if data.get("version") != TRUTH_VERSION:
                raise ValueError(f"version {data.get('version')!r}")
            if data.get("profile") != self.caps.name:
                log.warning("simulator: truth file %s is for profile %r, not %r; starting "
                            "from defaults", path, data.get("profile"), self.caps.name)
                return None
            out = {}
            for name in AXES:
                a = data["axes"][name]
                vals = {k: float(a[k]) for k in ("gear_deg", "gear_deg_per_s", "load_deg",
                                                 "load_deg_per_s")}
                if not all(math.isfinite(v) for v in vals.values()):
                    raise ValueError("non-finite value")
                vals["brake_released"] = bool(a.get("brake_released", False))
                vals["run_on_s"] = self._run_on_s(data) if math.isfinite(float(a.get("drive", 0.0))) else 0.0
                vals["drive"] = float(a.get("drive", 0.0)) if vals["run_on_s"] > 0 else 0.0
                out[name] = vals
            wall_s = data.get("wall_s")
            self._restored_from = (float(wall_s) if isinstance(wall_s, (int, float)) else None,
                                   max(v["run_on_s"] for v in out.values()))
            return out
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            log.warning("simulator: truth file %s is unusable (%s); starting from defaults",
                        path, exc)
            return None

    @staticmethod
    def _run_on_s(data: dict[str, Any]) -> float:
        """How long the motors kept their drive after the last record of a process that
        died (its lines held their last level, as on a Pi): until the safety relay dropped
        out (the record's heartbeat deadline; none yet: the power was off) when the part
        is wired; without it until now, when this world's process takes the lines over.
        0 for a record with no wall time (a virtual clock's)."""
        try:
            wall_s = data.get("wall_s")
            if wall_s is None:
                return 0.0
            end_s = time.time()
            if "power_cut_at_wall_s" in data:
                cut_s = data["power_cut_at_wall_s"]
                if cut_s is None:
                    return 0.0
                end_s = min(float(cut_s), end_s)
            run_s = end_s - float(wall_s)
        except (TypeError, ValueError):
            return 0.0
        return max(0.0, min(_MAX_RUN_ON_S, run_s)) if math.isfinite(run_s) else 0.0

    def _restore(self, phys: AxisPhysics, s: dict[str, float], brake_engage_s: float) -> None:
        """Put the saved state back; if it was moving, coast down with the power cut
        (after running on with its drive until the safety relay cut it, when one is
        wired: ``run_on_s``)."""
        phys.gear_deg, phys.gear_deg_per_s = s["gear_deg"], s["gear_deg_per_s"]
        phys.load_deg, phys.load_deg_per_s = s["load_deg"], s["load_deg_per_s"]
        if abs(phys.gear_deg - phys.load_deg) > phys.half_gap_deg:
            phys.gear_deg = phys.load_deg + math.copysign(phys.half_gap_deg,
                                                          phys.gear_deg - phys.load_deg)
        has_brake = phys.p.has_brake
        run_on_s = s.get("run_on_s", 0.0) if s.get("drive", 0.0) else 0.0
        if not phys.at_rest() or run_on_s > 0.0:
            wind = phys.wind_enabled
            phys.wind_enabled = False
            if run_on_s > 0.0:
                # the process died; its lines kept driving until the relay dropped out
                phys.brake_engaged = has_brake and not s["brake_released"]
                phys.set_command(s["drive"])
                phys.step_n(round(run_on_s / phys.dt_s))
                phys.set_command(0.0)
            phys.powered = False
            phys._apply_drive()
            phys.brake_engaged = has_brake and not s["brake_released"]
            if has_brake and not phys.brake_engaged:
                # the brake spring closes brake_engage_s after the power went
                phys.step_n(round(brake_engage_s / phys.dt_s))
                phys.brake_engaged = True
            chunk = max(1, round(0.01 / phys.dt_s))
            for _ in range(int(_MAX_COAST_S / (chunk * phys.dt_s))):
                if phys.at_rest() or phys.held:
                    break
                phys.step_n(chunk)
            phys.gear_deg_per_s = phys.load_deg_per_s = 0.0
            phys.wind_enabled = wind
            phys.powered = True
        phys.brake_engaged = has_brake       # a brake without voltage holds
        phys.tick = 0
        phys._apply_drive()
        phys.reset_pulse_counter()

    @_serialised
    def close(self) -> None:
        """Power down: save the truth (always) and stop driving."""
        if self._origin_s is not None and not self._closed:
            # a brake whose coil was just switched off engages after its delay, powered
            # or not: the truth saved is the iron after that, not before
            self.advance_to(max([self.clock.now_s(), *(ev[0] + self.dt_s for ev in self._brake_events.values())]))
        if not self._closed:
            # an orderly end lets go of the motors (only a process that dies holds them:
            # the next world runs on only what a record without this close left driving)
            for phys in self.axes.values():
                phys.set_command(0.0)
        if self._truth_writer is not None:
            self._truth_writer.close()
        if self.truth_path is not None:
            self._write_truth()
        if self.log is not None and not self._closed:
            self.log.sample(time.time(), self._log_axes())
            self.log.close()
        self._closed = True

    # ------------------------------------------------------------------ truth log
    def _log_axes(self) -> dict[str, dict[str, Any]]:
        return {name: {"deg": a.load_deg, "rate": a.load_deg_per_s, "drive": a.effective_duty(),
                       "powered": a.powered} for name, a in self.axes.items()}

    def _log_restore(self, saved: dict[str, dict[str, float]]) -> None:
        assert self.log is not None
        record_wall_s, run_on_s = self._restored_from
        self.log.event("restore", time.time(), record_wall_s=record_wall_s, run_on_s=run_on_s,
                       off_wall_s=None if record_wall_s is None else record_wall_s + run_on_s,
                       axes={name: {"from_deg": saved[name]["load_deg"], "drive": saved[name]["drive"],
                                    "to_deg": self.axes[name].load_deg} for name in self.axes})

    # ------------------------------------------------------------------ faults
    @_serialised
    def inject(self, axis: str, kind: str, **kw: Any) -> None:
        """Inject a fault on ``axis`` ("az" | "el").

        kinds: ``sensor_stuck`` (reading freezes), ``sensor_jump`` (deg=10: reading
        offset by deg), ``sensor_dead`` (read raises SensorError), ``jam`` (axis cannot
        move; the motor stalls), ``runaway`` (duty=1.0: the motor gets this duty whatever
        is commanded, e.g. a welded relay), ``limit_switch`` (which="max" | "min" |
        "both": switch forced active), ``reverse_wiring`` (motor turns the wrong way),
        ``slow_read`` (delay_s=0.7, reads=1: the next reads each block that long in wall
        time, a bus timing out: a stall inside the control tick; clears itself).

        The safety chain's faults go on ``axis="chain"`` (a world with the part):
        ``enable_stuck``, ``trigger_floating``, ``relay_dropout`` (delay_s=0.03),
        ``contact_welded``, ``contact_open`` (:mod:`.safety`).
        """
        if axis == CHAIN:
            self._chain_fault(kind, kw)
            return
        phys, sensor = self.axes[axis], self.sensors[axis]
        if kind == "sensor_stuck":
            sensor.freeze()
        elif kind == "sensor_jump":
            sensor.fault_jump_deg = float(kw.get("deg", 10.0))
        elif kind == "sensor_dead":
            sensor.fault_dead = True
        elif kind == "jam":
            phys.jammed = True
            phys.gear_deg_per_s = phys.load_deg_per_s = 0.0
        elif kind == "runaway":
            phys.runaway_duty = max(-1.0, min(1.0, float(kw.get("duty", 1.0))))
            phys._apply_drive()
        elif kind == "limit_switch":
            which = kw.get("which", "max")
            lo, hi = self.limits[axis]
            chosen = {"min": [lo], "max": [hi], "both": [lo, hi]}.get(which)
            if chosen is None or any(sw is None for sw in chosen):
                raise ValueError(f"{axis}: no {which!r} limit switch on {self.caps.name}")
            for sw in chosen:
                sw.forced = True  # type: ignore[union-attr]
        elif kind == "reverse_wiring":
            phys.reversed = True
            phys._apply_drive()
        elif kind == "slow_read":
            sensor.fault_slow_s = max(0.0, min(10.0, float(kw.get("delay_s", 0.7))))
            sensor.fault_slow_reads = max(0, int(kw.get("reads", 1)))
        else:
            raise ValueError(f"unknown fault {kind!r}; expected one of {', '.join(FAULT_KINDS)}")
        self._faults[axis][kind] = dict(kw)

    def _chain_fault(self, kind: str, kw: dict[str, Any]) -> None:
        if self.enable is None:
            raise ValueError("no safety chain modelled (motor_enable_timeout_s) to inject a fault into")
        if kind not in CHAIN_FAULT_KINDS:
            raise ValueError(f"unknown safety chain fault {kind!r}; expected one of {', '.join(CHAIN_FAULT_KINDS)}")
        self.catch_up()                  # (the iron until now ran on the old chain)
        self.enable.inject(kind, **kw)
        self._chain_changed()

    @_serialised
    def clear(self, axis: str, kind: str | None = None) -> None:
        """Clear one fault, or every fault on ``axis`` when ``kind`` is None."""
        if axis == CHAIN:
            if self.enable is not None:
                self.catch_up()
                self.enable.clear(kind)
                self._chain_changed()
            return
        kinds = list(self._faults[axis]) if kind is None else [kind]
        phys, sensor = self.axes[axis], self.sensors[axis]
        for k in kinds:
            self._faults[axis].pop(k, None)
            if k == "sensor_stuck":
                sensor.fault_stuck_deg = None
            elif k == "sensor_jump":
                sensor.fault_jump_deg = 0.0
            elif k == "sensor_dead":
                sensor.fault_dead = False
            elif k == "slow_read":
                sensor.fault_slow_reads = 0
            elif k == "jam":
                phys.jammed = False
            elif k == "runaway":
                phys.runaway_duty = None
                phys._apply_drive()
            elif k == "limit_switch":
                for sw in self.limits[axis]:
                    if sw is not None:
                        sw.forced = False
            elif k == "reverse_wiring":
                phys.reversed = False
                phys._apply_drive()

    def faults(self) -> dict[str, dict[str, dict[str, Any]]]:
        """Active faults: {axis: {kind: kwargs}} (and "chain": the safety chain's, when
        the part is modelled)."""
        out = {a: {k: dict(v) for k, v in f.items()} for a, f in self._faults.items()}
        if self.enable is not None:
            out[CHAIN] = {k: dict(v) for k, v in self.enable.faults.items()}
        return out

    def axis_faults(self, axis: str) -> Mapping[str, Mapping[str, Any]]:
        """The active faults of one axis, {kind: kwargs}, as they stand (not a copy: for
        the emulated parts, which look at them several times per tick; never changed
        through it)."""
        return self._faults[axis]

    @_serialised
    def set_wind(self, enabled: bool, mean_nm: float | None = None,
                 gust_nm: float | None = None, axis: str | None = None) -> None:
        """Switch the wind load on/off and optionally set its mean and gust (1-sigma)."""
        for name in ([axis] if axis else AXES):
            self.axes[name].set_wind(enabled, mean_nm, gust_nm)


class _LatestWriter:
    """Writes the newest of the records handed to it on a thread of its own (older ones
    still waiting are dropped: only the latest truth matters)."""

    def __init__(self, write: Any):
        self._write = write
        self._cv = threading.Condition()
        self._pending: dict[str, Any] | None = None
        self._closing = False
        self._thread = threading.Thread(target=self._run, name="sim-truth-writer", daemon=True)
        self._thread.start()

    def submit(self, record: dict[str, Any]) -> None:
        with self._cv:
            self._pending = record
            self._cv.notify()

    def close(self) -> None:
        """Stop after the record waiting, if any, is written."""
        with self._cv:
            self._closing = True
            self._cv.notify()
        self._thread.join(timeout=5.0)

    def _run(self) -> None:
        while True:
            with self._cv:
                while self._pending is None and not self._closing:
                    self._cv.wait()
                record, self._pending = self._pending, None
                closing = self._closing
            if record is not None:
                self._write(record)
            if closing:
                return
