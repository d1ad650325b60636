"""The contracts every hardware backend implements.

Devices never touch hardware directly; a backend (the physics simulator, Linux
GPIO/I2C parts, a bridge to an existing controller) is chosen by name from config
through :mod:`urc.hardware.factory` — gpiozero's pin-factory idea. The control code
only sees these protocols, so a real driver plugs in without touching it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any, Callable, Protocol, runtime_checkable

from ..caps import SensorCaps

# This module names no backend, not even for the type checker: every backend imports it,
# so a name of one here (under TYPE_CHECKING too) closes an import cycle (issue 34).
# What a backend builds besides the axes is typed by the small protocol of what urc
# outside that backend asks of it, or is the backend's own record (``object``) that only
# its tools and tests read, knowing its type.

log = logging.getLogger(__name__)


@runtime_checkable
class Motor(Protocol):
    def set_drive(self, duty: float) -> None:
        """Drive in [-1, 1]; the sign is the direction (+ = increasing angle).

        PWM drives use the magnitude as duty cycle. Relay drives switch to the nearest
        of their levels (``AxisCaps.drive_levels``, e.g. slow/fast) and coast at 0.
        """

    def read_current_a(self) -> float:
        """Motor current, amperes (0 when the drive cannot measure it)."""


def motor_off(motor: Motor) -> None:
    """Motor off from any thread: the driver's ``force_safe`` where it has one (the gpio
    drivers: written without waiting for a tick stuck in the driver, past every cache),
    else ``set_drive(0)``."""
    force_safe = getattr(motor, "force_safe", None)
    if force_safe is not None:
        force_safe()
    else:
        motor.set_drive(0.0)


def brake_on(brake: Brake) -> None:
    """Brake engaged from any thread (``force_safe`` where the driver has one)."""
    force_safe = getattr(brake, "force_safe", None)
    if force_safe is not None:
        force_safe()
    else:
        brake.set_released(False)


@runtime_checkable
class Brake(Protocol):
    def set_released(self, released: bool) -> None:
        """Release (True) or engage (False). A powerless brake is engaged."""

    def is_released(self) -> bool: ...


@runtime_checkable
class PositionSensor(Protocol):
    caps: SensorCaps

    def read_deg(self) -> float:
        """The axis angle in degrees, calibrated.

        Incremental sensors (encoder, pulse) return counts x resolution + reference.
        Sensors with ``caps.modulo_deg`` return a value in [0, modulo). Raises
        :class:`urc.errors.SensorError` when no usable reading exists.
        """

    def set_reference_deg(self, angle_deg: float) -> None:
        """Declare that the current reading is ``angle_deg`` (re-reference, Tartu WRAZ)."""

    def calibration(self) -> dict[str, Any]:
        """Calibration constants worth persisting (pot M/C/Z, hard-iron, reference...)."""

    def load_calibration(self, values: dict[str, Any]) -> None: ...


@runtime_checkable
class LimitSwitch(Protocol):
    def is_active(self) -> bool: ...


@runtime_checkable
class Positioner(Protocol):
    """An axis whose inner loop an existing controller closes (the bridge backend).

    urc posts targets instead of a motor duty; the position still comes from the axis'
    ``sensor`` (the controller's latest report). Both calls only record what is wanted
    and return at once: the link to the controller is served off the control tick.
    """

    #: the smallest target change the controller can express (GS-232: 1 deg)
    resolution_deg: float

    def goto(self, target_deg: float) -> None:
        """Go to ``target_deg`` (the axis' mechanical frame) at the controller's speed."""

    def stop(self) -> None:
        """Stop this axis (the controller decelerates and holds)."""

    def move(self, end_deg: float, speed_frac: float, rate_deg_per_s: float) -> None:
        """A jog towards ``end_deg`` (the soft limit or a zone's edge, never passed) at
        ``speed_frac`` of the top speed (``rate_deg_per_s``): the controller's own move
        where it has one, a goto to ``end_deg`` otherwise."""

    def latency_s(self) -> float:
        """Measured time from posting a target to the controller having it: moving
        targets are sent this far ahead."""

    def sample_interval_s(self) -> float:
        """How old a position report can be (the link's poll period)."""


@runtime_checkable
class DigitalOutput(Protocol):
    def write(self, value: bool) -> None:
        """Drive the output high (True) or low (False)."""


@runtime_checkable
class EnableSense(Protocol):
    """The safety chain's read-back: ``read()`` is True while the chain gives the motors
    power. ``point``: what it is wired to, "contact" (the relay's) or "q" (the
    monostable's output: a welded contact or a shorted Q1 does not show there)."""

    point: str

    def read(self) -> bool: ...


class SimulatedPhysics(Protocol):
    """The physics under the sim backend and the emulated gpio backend
    (``urc.hardware.sim.world.SimWorld``): the control process injects faults into it."""

    def inject(self, axis: str, kind: str, **kw: Any) -> None: ...

    def clear(self, axis: str, kind: str | None = None) -> None: ...


class PowerFailSense(Protocol):
    """A supply monitor's power-fail line (the gpio backend's ``PowerFailInput``): the
    composition root sets ``on_fail`` (at once, on the falling edge) and ``save`` (then,
    on a thread of its own)."""

    on_fail: Any
    save: Any

    def supply_ok(self) -> bool: ...


@dataclass
class AxisHardware:
    motor: Motor
    sensor: PositionSensor
    brake: Brake | None = None
    limit_min: LimitSwitch | None = None
    limit_max: LimitSwitch | None = None
    #: set for an axis an external controller closes: targets go here, ``motor`` is unused
    positioner: Positioner | None = None


@dataclass
class Hardware:
    """Both axes of one rotator plus backend-wide hooks."""

    backend: str
    az: AxisHardware
    #: None on a single-axis rotator (``RotatorCaps.axes == ("az",)``)
    el: AxisHardware | None
    #: backends that simulate physics advance it here, before sensors are read.
    poll_hook: Any = None
    #: simulator only: returns the true mechanical state; None for real iron.
    truth_hook: Any = None
    close_hook: Any = None
    #: toggled by every control tick (a square wave) for an external watchdog or charge
    #: pump that removes motor power when urc dies or hangs; None = not wired
    heartbeat: DigitalOutput | None = None
    #: the safety chain's timeout (the monostable's period) as configured; None = no
    #: chain declared
    motor_enable_timeout_s: float | None = None
    #: the safety chain's read-back input (:class:`EnableSense`); None = not wired: the
    #: start-up self-test (:mod:`urc.hardware.safety_test`) cannot measure the chain
    enable_sense: EnableSense | None = None
    #: the physics simulator under the sim backend and the emulated gpio backend (fault
    #: injection, truth); None on real iron and the bridge
    world: SimulatedPhysics | None = None
    #: per axis, the trip a motor driver's over-current detection would be set to, used
    #: when ``faults.overcurrent_a = 0``; None = the backend has no figure
    overcurrent_a: dict[str, float] | None = None
    #: (label, part) for ``urc hw check`` to identify, in wiring order
    parts: list[tuple[str, Any]] = field(default_factory=list)
    #: the backend keeps the position state itself (the gpio backend's FRAM: StateStore's
    #: interface, not derived from it); None = the state file
    state_store: object | None = None
    #: the supply monitor's power-fail input (gpio ``power_fail_pin``); None = not wired
    power_fail: PowerFailSense | None = None
    #: the gpio backend's pin factory, buses and emulated parts (``urc.hardware.gpio.GpioParts``)
    gpio: object | None = None
    #: the bridge backend's client and link to the controller (``urc.hardware.bridge.BridgeLink``)
    bridge: object | None = None
    #: the read-back watched on every tick (``urc.hardware.supply_watch.SupplyWatch``): made
    #: on first use where there is a chain (``motor_enable_timeout_s``) and a read-back
    supply_watch: Any = None

    def axis(self, name: str) -> AxisHardware:
        if name == "az":
            return self.az
        if name == "el" and self.el is not None:
            return self.el
        if name == "el":
            raise ValueError("no elevation axis: this rotator is azimuth only")
        raise ValueError(f"no axis {name!r}: expected 'az' or 'el'")

    def drive_safe(self) -> None:
        """Every output to its safe state: motors off (positioners stopped), brakes
        engaged, heartbeat low. Each write is tried even when another fails (start-up
        and every exit path). Called without the rotator's lock from other threads than
        the tick's (the tick watch, the power-fail callback, a shutdown past a hung
        tick): the drivers' ``force_safe`` (:func:`motor_off`, :func:`brake_on`)."""
        writes: list[tuple[str, Callable[[], Any]]] = []
        for name, ax in (("az", self.az), ("el", self.el)):
            if ax is None:
                continue
            writes.append((f"{name} motor off", lambda ax=ax: motor_off(ax.motor)))
            if ax.positioner is not None:  # an external controller's axis: told to stop
                writes.append((f"{name} positioner stop", lambda ax=ax: ax.positioner.stop()))
            if ax.brake is not None:
                writes.append((f"{name} brake on", lambda ax=ax: brake_on(ax.brake)))
        if self.heartbeat is not None:
            writes.append(("heartbeat low", lambda: self.heartbeat.write(False)))
        for what, write in writes:
            try:
                write()
            except Exception:
                log.exception("safe state: %s failed", what)

    def poll(self, now_s: float) -> None:
        if self.poll_hook is not None:
            self.poll_hook(now_s)

    def beat(self, level: bool, now_s: float) -> None:
        """The tick's heartbeat write, then one read of the safety chain's read-back
        (:mod:`.supply_watch`: motor power lost while the heartbeat runs is a fault).
        A failed write is logged only: the external chain sees it."""
        if self.heartbeat is None:
            return
        try:
            self.heartbeat.write(level)
        except Exception as exc:
            log.debug("heartbeat write failed: %s", exc)
        watch = self.watch()
        if watch is not None:   # (after a failed write too: meant, and the chain drops on it)
            watch.beat(level, now_s)

    def watch(self) -> Any:
        """The read-back's watch, or None without a chain and a read-back."""
        if self.supply_watch is None and self.enable_sense is not None and self.motor_enable_timeout_s is not None:
            from .supply_watch import SupplyWatch
            self.supply_watch = SupplyWatch(self.enable_sense, self.motor_enable_timeout_s, self._motors)
        return self.supply_watch

    def _motors(self) -> list[Motor]:
        return [ax.motor for ax in (self.az, self.el) if ax is not None]

    def note_enable(self, on: bool) -> None:
        """A reading of the read-back taken elsewhere (the start-up self-test)."""
        watch = self.watch()
        if watch is not None:
            watch.observe(on)

    def motor_power_fault(self) -> str:
        """Why the motors lost their supply while urc drives ('' if they did not): the
        guard latches it as a ``motor_power`` fault."""
        return self.supply_watch.take_fault() if self.supply_watch is not None else ""

    def sim_truth(self) -> dict[str, Any] | None:
        return self.truth_hook() if self.truth_hook is not None else None

    def close(self) -> None:
        if self.close_hook is not None:
            self.close_hook()
