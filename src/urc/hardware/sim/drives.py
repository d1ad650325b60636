"""Simulated motor, brake and limit switches (implement the Protocols in interfaces.py)."""

from __future__ import annotations

import math
from contextlib import AbstractContextManager, nullcontext
from typing import Callable, Literal, Mapping, Protocol

from ...errors import HardwareError
from ..drivers.motors import DirectionTracker
from .physics import AxisPhysics, quantise_relay


class BrakeWorld(Protocol):
    """What a brake needs of the world (SimWorld is one): its axes, and the command that
    starts the brake moving. Named here so drives need not import world, which builds them."""

    @property
    def axes(self) -> Mapping[str, AxisPhysics]: ...

    def command_brake(self, name: str, released: bool) -> None: ...


class SimMotor(DirectionTracker):
    """PWM H-bridge or relay pair. ``set_drive`` takes effect from the next substep.

    Relay drives switch to the nearest of ``AxisCaps.drive_levels`` (levels below 1 are
    made by pulsing the relay); the physics does the quantising so faults such as a
    welded relay (runaway) go through the same path.

    A new drive first brings the world up to the present (``catch_up``): if the
    controller froze, the iron kept turning all that time with the drive it last had,
    and a command given on waking acts only from then on.
    """

    def __init__(self, axis: AxisPhysics, name: str, catch_up: Callable[[], None] | None = None,
                 lock: AbstractContextManager | None = None):
        super().__init__()
        self._axis = axis
        self.name = name
        self._catch_up = catch_up
        #: the world's lock: catching up and the new drive are one step of the iron
        self._lock = lock if lock is not None else nullcontext()

    def set_drive(self, duty: float) -> None:
        duty = float(duty)
        if not math.isfinite(duty):
            raise HardwareError(f"{self.name} motor: drive must be finite, got {duty!r}")
        with self._lock:
            if self._catch_up is not None:
                self._catch_up()
            self._axis.set_command(duty)
            self._track(self._axis.cmd_duty)

    def read_current_a(self) -> float:
        return self._axis.current_a()

    @property
    def duty(self) -> float:
        """The commanded duty (after clamping to [-1, 1])."""
        return self._axis.cmd_duty

    def output_level(self) -> float:
        """What the drive stage really outputs: PWM duty, or the relay level."""
        if self._axis.relay:
            return quantise_relay(self._axis.effective_duty(), self._axis.relay_levels)
        return self._axis.effective_duty()


class SimBrake:
    """A brake that needs voltage to release; it moves after ``brake_release_s`` /
    ``brake_engage_s`` of clock time, and ``is_released`` reports the real state."""

    def __init__(self, world: BrakeWorld, name: str):
        self._world = world
        self.name = name

    def set_released(self, released: bool) -> None:
        self._world.command_brake(self.name, bool(released))

    def is_released(self) -> bool:
        return not self._world.axes[self.name].brake_engaged


class SimLimitSwitch:
    """Active while the antenna is beyond the switch position (or when forced)."""

    def __init__(self, axis: AxisPhysics, side: Literal["min", "max"], switch_deg: float):
        self._axis = axis
        self.side = side
        self.switch_deg = switch_deg
        self.forced = False

    def is_active(self) -> bool:
        if self.forced:
            return True
        x = self._axis.load_deg
        return x <= self.switch_deg if self.side == "min" else x >= self.switch_deg
