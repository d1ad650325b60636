"""Frozen capabilities: what the controller knows about a rotator model.

One value per profile (docs/ARCHITECTURE.md, convention 4). A variant is a new caps value, never an
``if model ==`` branch. Per-instance overrides (offsets, user limits, keep-out zones)
live in the rotator's state/settings, never here.

The physical truth a simulator needs (motor constants, inertia, friction ...) is not
caps: the controller must work without knowing it. It lives in ``urc.hardware.sim``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

#: "controller": the position reports of an external controller (the bridge backend)
SensorKind = Literal["encoder", "pulse", "pot", "as5600", "magnetometer", "controller"]
DriveKind = Literal["pwm", "relay"]


@dataclass(frozen=True)
class SensorCaps:
    kind: SensorKind
    #: size of one sensor count (q) at the axis, degrees; for a pot, the coarsest step.
    resolution_deg: float
    #: False for encoders and pulse counters: position must be persisted or re-referenced.
    absolute: bool
    #: absolute sensors that only know the angle modulo 360 (AS5600, compass) set 360.
    modulo_deg: float | None = None
    #: readings that fold at this angle: a reading r may also be 2 * fold - r (a
    #: controller reporting the sky direction, el 0..90, for an antenna over the top)
    fold_deg: float | None = None
    #: expected 1-sigma reading noise, degrees (0 for clean digital sensors).
    noise_deg: float = 0.0
    #: the sensor rides on the elevation boom and reads the boom's heading, not its
    #: axis's angle (SARCNET's tilt-compensated compass): past the zenith the heading is
    #: the mechanical azimuth + 180, so a flipped pose is misread.
    heading_on_boom: bool = False


@dataclass(frozen=True)
class AxisCaps:
    name: Literal["az", "el"]
    min_deg: float
    max_deg: float
    park_deg: float
    max_rate_deg_per_s: float
    #: slowest speed at which the motor still turns reliably (BIG-RAS "minimal turn").
    min_rate_deg_per_s: float
    accel_deg_per_s2: float
    sensor: SensorCaps
    drive: DriveKind = "pwm"
    #: relay drives only: the |duty| levels the drive can produce besides 0 (slow, fast).
    drive_levels: tuple[float, ...] = ()
    #: settle band: the axis is "there" within this error and does not restart below
    #: ``restart_deg`` (hysteresis, so relays do not chatter).
    tolerance_deg: float = 0.1
    restart_deg: float = 0.25
    brake: bool = False
    brake_release_s: float = 0.0
    brake_engage_s: float = 0.0
    limit_switches: bool = False
    #: on/off drives: stop this far before the target to absorb coasting (Tartu OVRA).
    overshoot_deg: float = 0.0
    #: gear play between the motor and the sensor (a sensor on the antenna side): the
    #: motor turns this far, reversing, before the sensor sees any motion.
    backlash_deg: float = 0.0
    #: a target slower than ``min_rate_deg_per_s`` is followed in bursts, each of which
    #: overtakes it by this much, so the error swings evenly around zero. About one
    #: sensor count (the default, None) plus what coast and gear play add; tuned per
    #: machine like the overshoot.
    creep_lead_deg: float | None = None

    @property
    def effective_creep_lead_deg(self) -> float:
        return self.sensor.resolution_deg if self.creep_lead_deg is None else self.creep_lead_deg

    @property
    def span_deg(self) -> float:
        return self.max_deg - self.min_deg


@dataclass(frozen=True)
class RotatorCaps:
    name: str
    description: str
    az: AxisCaps
    el: AxisCaps
    loop_hz: float = 50.0
    #: named sets of commands the original controller supports, for protocol servers.
    command_sets: tuple[str, ...] = field(default_factory=tuple)
    #: the axes this rotator has: ("az",) for a single-axis one (a turntable, an HF beam,
    #: BIG-RAS with "Elevation: OFF"). ``el`` then only describes what an elevation axis
    #: would be; nothing drives, senses or reports it (README "Single-axis rotators").
    axes: tuple[str, ...] = ("az", "el")

    @property
    def has_el(self) -> bool:
        return "el" in self.axes

    @property
    def el_past_zenith(self) -> bool:
        """The elevation range reaches past 90: a controller reporting sky directions
        (el 0..90) cannot tell which side of the zenith the antenna is on."""
        return self.el.max_deg > 90.0

    @property
    def can_flip(self) -> bool:
        """Elevation reaches past the zenith, so a pass can be flown 'over the top'."""
        return self.has_el and self.el.max_deg >= 180.0 - 1e-9

    @property
    def senses_flipped_pose(self) -> bool:
        """Its sensors read a flipped pose as such: no heading read on the boom, no
        reading that folds at the zenith (a controller reporting sky directions)."""
        sensors = (self.az.sensor, self.el.sensor)
        return self.can_flip and not any(s.heading_on_boom for s in sensors) and \
            not any(s.fold_deg is not None and self.el.min_deg < s.fold_deg < self.el.max_deg for s in sensors)

    def single_axis(self) -> "RotatorCaps":
        """This rotator without its elevation axis (a variant: a new caps value)."""
        return replace(self, axes=("az",), description=self.description + " (azimuth only)")

    def axis(self, name: str) -> AxisCaps:
        if name == "az":
            return self.az
        if name == "el":
            return self.el
        raise KeyError(name)
