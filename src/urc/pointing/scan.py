"""Scans around a target, sized from the beamwidth: a planned motion of time-tagged
offsets, flown step and dwell (the antenna stands still on each point while the power is
read: a rotator's motion is too coarse to read power on the fly).

Offsets are on the sky: ``dx_deg`` across elevation (an azimuth step of dx / cos el),
``dy_deg`` in elevation, both from the target's position at the moment the point is
flown (a moving Sun or satellite is followed). The scan's times assume the rotator's
slew rate; a flight takes the points in order and reads where the antenna really was.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from ..angles import wrap180_deg


@dataclass(frozen=True)
class ScanPoint:
    t_s: float            # when the dwell on this point starts, from the scan's start
    dx_deg: float         # cross-elevation offset from the target
    dy_deg: float         # elevation offset from the target
    leg: Literal["az", "el", "raster"]


@dataclass(frozen=True)
class ScanPlan:
    kind: Literal["cross", "raster"]
    fwhm_deg: float
    half_width_deg: float
    dwell_s: float
    points: tuple[ScanPoint, ...]

    @property
    def duration_s(self) -> float:
        return self.points[-1].t_s + self.dwell_s if self.points else 0.0

    def poses(self, target: Any, t0_unix_s: float) -> list[tuple[float, float, float]]:
        """(t_unix_s, az_deg, el_deg) to command at each point, the target taken at that
        point's planned time."""
        out = []
        for p in self.points:
            u = t0_unix_s + p.t_s
            az, el = target.position(u)
            out.append((u, *offset_pose(az, el, p.dx_deg, p.dy_deg)))
        return out


def offset_pose(az_deg: float, el_deg: float, dx_deg: float, dy_deg: float) -> tuple[float, float]:
    """The pose ``dx`` across and ``dy`` up from (az, el)."""
    el = el_deg + dy_deg
    return (az_deg + dx_deg / max(math.cos(math.radians(el)), 1e-3)) % 360.0, el


def pose_offset(az_deg: Any, el_deg: Any, target_az_deg: Any, target_el_deg: Any) -> tuple[Any, Any]:
    """(dx, dy) of poses from the target: :func:`offset_pose` inverted."""
    daz = wrap180_deg(np.asarray(az_deg) - np.asarray(target_az_deg))
    return daz * np.cos(np.radians(np.asarray(el_deg))), np.asarray(el_deg) - np.asarray(target_el_deg)


def _timed(offsets: list[tuple[float, float, str]], rate_deg_per_s: float, settle_s: float,
           dwell_s: float) -> tuple[ScanPoint, ...]:
    pts, t_s, prev = [], 0.0, (0.0, 0.0)
    for i, (dx, dy, leg) in enumerate(offsets):
        step_deg = max(abs(dx - prev[0]), abs(dy - prev[1]))  # both axes move at once
        t_s += (step_deg / rate_deg_per_s + settle_s) if i else 0.0
        pts.append(ScanPoint(round(t_s, 6), dx, dy, leg))  # type: ignore[arg-type]
        t_s += dwell_s
        prev = (dx, dy)
    return tuple(pts)


def _check(fwhm_deg: float, half_width_fwhm: float, step_fwhm: float) -> None:
    if not (0 < fwhm_deg <= 90 and 0 < half_width_fwhm <= 5 and 0 < step_fwhm <= half_width_fwhm):
        raise ValueError(f"scan: expected 0 < fwhm_deg <= 90, 0 < half_width_fwhm <= 5 and "
                         f"0 < step_fwhm <= half_width_fwhm, found {fwhm_deg!r}, {half_width_fwhm!r}, {step_fwhm!r}")


def _axis(half_deg: float, step_deg: float) -> np.ndarray:
    n = max(2, math.ceil(half_deg / step_deg - 1e-9))
    return np.linspace(-half_deg, half_deg, 2 * n + 1)


def cross_scan(fwhm_deg: float, *, half_width_fwhm: float = 1.5, step_fwhm: float = 0.2,
               rate_deg_per_s: float = 3.0, settle_s: float = 1.0, dwell_s: float = 1.0) -> ScanPlan:
    """Across the target in azimuth (dy = 0), then in elevation (dx = 0), each leg
    +-``half_width_fwhm`` beamwidths in steps of ``step_fwhm`` beamwidths (a Gaussian's
    centre is best found on its flanks, where the power changes fastest)."""
    _check(fwhm_deg, half_width_fwhm, step_fwhm)
    xs = _axis(half_width_fwhm * fwhm_deg, step_fwhm * fwhm_deg)
    offs = [(float(x), 0.0, "az") for x in xs] + [(0.0, float(y), "el") for y in xs]
    return ScanPlan("cross", fwhm_deg, half_width_fwhm * fwhm_deg, dwell_s,
                    _timed(offs, rate_deg_per_s, settle_s, dwell_s))


def raster_scan(fwhm_deg: float, *, half_width_fwhm: float = 1.5, step_fwhm: float = 0.33,
                rate_deg_per_s: float = 3.0, settle_s: float = 1.0, dwell_s: float = 1.0) -> ScanPlan:
    """A square grid +-``half_width_fwhm`` beamwidths on a side, rows in elevation flown
    back and forth (serpentine: no return slew)."""
    _check(fwhm_deg, half_width_fwhm, step_fwhm)
    xs = _axis(half_width_fwhm * fwhm_deg, step_fwhm * fwhm_deg)
    offs = []
    for i, y in enumerate(xs):
        row = xs if i % 2 == 0 else xs[::-1]
        offs += [(float(x), float(y), "raster") for x in row]
    return ScanPlan("raster", fwhm_deg, half_width_fwhm * fwhm_deg, dwell_s,
                    _timed(offs, rate_deg_per_s, settle_s, dwell_s))
