"""Per-instance settings of a rotator: caps narrowed and extended by configuration."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from ..caps import AxisCaps, RotatorCaps
from ..control.faults import FaultLimits
from ..control.geometry import Geometry, KeepOut
from ..control.law import AxisTuning


#: the elevation of a single-axis rotator's beam (a turntable, an HF beam): the horizon
FIXED_EL_DEG = 0.0


def default_tuning(ax: AxisCaps) -> AxisTuning:
    return AxisTuning(
        max_rate_deg_per_s=ax.max_rate_deg_per_s, min_rate_deg_per_s=ax.min_rate_deg_per_s,
        accel_deg_per_s2=ax.accel_deg_per_s2, tolerance_deg=ax.tolerance_deg,
        restart_deg=ax.restart_deg, drive=ax.drive, drive_levels=ax.drive_levels,
        brake=ax.brake, brake_release_s=ax.brake_release_s, overshoot_deg=ax.overshoot_deg,
        creep_lead_deg=ax.effective_creep_lead_deg, backlash_deg=ax.backlash_deg)


def default_fault_limits(ax: AxisCaps, lo: float, hi: float) -> FaultLimits:
    return FaultLimits(axis=ax.name, min_deg=lo, max_deg=hi,
                       max_rate_deg_per_s=ax.max_rate_deg_per_s,
                       min_rate_deg_per_s=ax.min_rate_deg_per_s,
                       resolution_deg=ax.sensor.resolution_deg, noise_deg=ax.sensor.noise_deg)


def _axis_name(axis: str) -> str:
    if axis not in ("az", "el"):
        raise ValueError(f"no axis {axis!r}: expected 'az' or 'el'")
    return axis


@dataclass(frozen=True)
class RotatorSettings:
    caps: RotatorCaps
    az_limits_deg: tuple[float, float]
    el_limits_deg: tuple[float, float]
    park_az_deg: float
    park_el_deg: float
    az_offset_deg: float = 0.0
    el_offset_deg: float = 0.0
    #: gotos of sky directions may fly over the top ([rotator] flip = true)
    flip: bool = False
    #: passes may be flown over the top (flip = true or "auto" on a profile that can)
    pass_flip: bool = False
    zones: tuple[KeepOut, ...] = field(default_factory=tuple)
    #: the fitted pointing model's terms (Geometry.pointing_deg; () = none), from the
    #: state directory (urc.pointing.store), not the configuration
    pointing_deg: tuple[float, ...] = ()
    idle_park_s: float = 0.0
    az_tuning: AxisTuning | None = None
    el_tuning: AxisTuning | None = None
    az_faults: FaultLimits | None = None
    el_faults: FaultLimits | None = None
    #: the time horizon of a state record while moving (see position_record)
    save_interval_s: float = 1.0
    watchdog_s: float = 0.5
    #: the stall rule (see :class:`urc.rotator.timing.LoopTiming`)
    watchdog_recover_s: float = 2.0
    watchdog_latch_stalls: int = 3
    watchdog_latch_window_s: float = 60.0

    @classmethod
    def from_caps(cls, caps: RotatorCaps, **overrides) -> "RotatorSettings":
        base = cls(caps=caps, az_limits_deg=(caps.az.min_deg, caps.az.max_deg),
                   el_limits_deg=(caps.el.min_deg, caps.el.max_deg),
                   park_az_deg=caps.az.park_deg, park_el_deg=caps.el.park_deg)
        return replace(base, **overrides).completed()

    def completed(self) -> "RotatorSettings":
        """Fill tuning and fault limits left as None from the caps. A single-axis rotator
        (``caps.axes == ("az",)``) has its beam fixed at the horizon: elevation pinned to
        0 (the pose keep-out zones are checked at), never flipped."""
        c = self.caps
        fixed: dict[str, Any] = {} if c.has_el else dict(el_limits_deg=(FIXED_EL_DEG, FIXED_EL_DEG), park_el_deg=FIXED_EL_DEG,
                                                         el_offset_deg=0.0, flip=False, pass_flip=False)
        self = replace(self, **fixed)
        if not c.has_el:  # (the model needs the elevation a scan measures it at)
            self = replace(self, pointing_deg=())
        return replace(
            self,
            az_tuning=self.az_tuning or default_tuning(c.az),
            el_tuning=self.el_tuning or default_tuning(c.el),
            az_faults=self.az_faults or default_fault_limits(c.az, *self.az_limits_deg),
            el_faults=self.el_faults or default_fault_limits(c.el, *self.el_limits_deg))

    def tuning(self, axis: str) -> AxisTuning:
        return self.az_tuning if _axis_name(axis) == "az" else self.el_tuning  # type: ignore[return-value]

    def fault_limits(self, axis: str) -> FaultLimits:
        return self.az_faults if _axis_name(axis) == "az" else self.el_faults  # type: ignore[return-value]

    def limits(self, axis: str) -> tuple[float, float]:
        return self.az_limits_deg if _axis_name(axis) == "az" else self.el_limits_deg

    def geometry(self) -> Geometry:
        zone_margin = max(self.caps.az.tolerance_deg, self.caps.el.tolerance_deg) + \
            2 * max(self.caps.az.sensor.resolution_deg, self.caps.el.sensor.resolution_deg)
        return Geometry(*self.az_limits_deg, *self.el_limits_deg,
                        az_offset_deg=self.az_offset_deg, el_offset_deg=self.el_offset_deg,
                        flip=self.flip, pass_flip=self.pass_flip, flip_sensed=self.caps.senses_flipped_pose,
                        zones=self.zones, zone_margin_deg=zone_margin, pointing_deg=self.pointing_deg)
