"""Calibrating a station on the Sun, flown on the simulated rotator (issue 38's "time to
a calibrated station"): cross scans of the Sun through the world's pointing error, on a
virtual clock, each taking the time the rotator takes to slew there and fly it.

:class:`SunCalibrator` keeps one rotator for a whole day: :meth:`SunCalibrator.scan` sets
the sky to a moment (the antenna stays where the last scan left it: the wait between
scans is not flown) and flies one scan from there. For tests and benchmarks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..angles import great_circle_deg
from ..clock import VirtualClock
from ..pointing.fit import CrossFit, ScanRefused, fit_cross
from ..pointing.model import PointingModel
from ..pointing.scan import cross_scan, offset_pose
from .scan_flight import fly_scan

#: a cross scan's legs (+-half width in elevation) must stay between these elevations
EL_FLOOR_DEG, EL_CEIL_DEG = 1.0, 89.0


@dataclass
class SunScan:
    t_unix_s: float                   # the sky's time at the command
    duration_s: float                 # rotator time from the command to the last sample
    sun_az_deg: float                 # the Sun at the command
    sun_el_deg: float
    mid_az_deg: float                 # the Sun halfway through the flight (a model's scan position)
    mid_el_deg: float
    half_width_fwhm: float
    fit: CrossFit | None = None
    refused: str = ""                 # why the fit was refused (fit None)
    samples_refused: dict[str, int] = field(default_factory=dict)


def scan_half_width_fwhm(sun_el_deg: float, fwhm_deg: float, widest: float = 1.5) -> float:
    """The widest cross scan (in beamwidths, at most ``widest``) whose elevation leg stays
    within [EL_FLOOR_DEG, EL_CEIL_DEG] around the Sun."""
    room_deg = min(sun_el_deg - EL_FLOOR_DEG, EL_CEIL_DEG - sun_el_deg)
    return max(0.0, min(widest, room_deg / fwhm_deg))


class SunCalibrator:
    """A simulated rotator (``profile``) whose beam is off by ``error``, a simulated Sun
    of ``snr_db`` through a Gaussian beam of ``fwhm_deg`` at ``station``."""

    def __init__(self, station: Any, error: PointingModel | None, *, fwhm_deg: float, snr_db: float,
                 state_dir: Path, seed: int = 1, samples_per_point: int = 3, settle_s: float = 1.0,
                 dwell_s: float = 1.0, profile: str = "tartu-urc"):
        from ..assembly import build_rotator
        from ..config import Config
        from ..peaking.simsource import SimulatedPower, SkySource, world_beam

        cfg = Config.from_dict({"rotator": {"profile": profile}, "hardware": {"sim": {"wind": False}}})
        self.clock = VirtualClock(0.0)
        self.rot = build_rotator(cfg, self.clock, state_dir, fast_virtual=True)
        world = self.rot.hw.world
        if world is None:
            raise RuntimeError(f"{profile}: the simulated rotator has no world to point through")
        world.pointing_error = error  # type: ignore[attr-defined]  # (read by world_beam with getattr)
        self.fwhm_deg, self.samples_per_point = float(fwhm_deg), samples_per_point
        self.settle_s, self.dwell_s = settle_s, dwell_s
        self.sky = SkySource.sun(station)
        self._u0 = 0.0  # the sky's unix time at clock 0
        self.power = SimulatedPower(self.sky, fwhm_deg=fwhm_deg, snr_db=snr_db, seed=seed,
                                    beam_at=world_beam(world, self.unix_at))

    def unix_at(self, now_s: float) -> float:
        return self._u0 + now_s

    def sun(self, t_unix_s: float) -> tuple[float, float]:
        return self.sky.position(t_unix_s)

    def scan(self, t_unix_s: float, min_half_width_fwhm: float = 1.0) -> SunScan | None:
        """Fly one cross scan of the Sun commanded at ``t_unix_s``; None when the Sun
        leaves no room for a scan at least ``min_half_width_fwhm`` wide."""
        self._u0 = t_unix_s - self.clock.now_s()
        az, el = self.sun(t_unix_s)
        hw = scan_half_width_fwhm(el, self.fwhm_deg)
        if hw < min_half_width_fwhm:
            return None
        plan = cross_scan(self.fwhm_deg, half_width_fwhm=hw, settle_s=self.settle_s, dwell_s=self.dwell_s)
        start_s = self.clock.now_s()
        data = fly_scan(self.rot, self.clock, plan, self.sky, self.power, self.unix_at,
                        samples_per_point=self.samples_per_point)
        dur_s = self.clock.now_s() - start_s
        out = SunScan(t_unix_s, dur_s, az, el, *self.sun(t_unix_s + dur_s / 2), hw, samples_refused=dict(data.refused))
        dx, dy, v, legs = data.arrays()
        try:
            out.fit = fit_cross(dx, dy, v, data.unit, legs, fwhm_deg=self.fwhm_deg, half_width_deg=plan.half_width_deg,
                                saturated=data.refused.get("saturated", 0))
        except ScanRefused as exc:
            out.refused = exc.reason
        return out


def corrected_error_deg(error: PointingModel | None, az_deg: Any, el_deg: Any, *, offset: tuple[float, float] | None = None,
                        model: PointingModel | None = None) -> np.ndarray:
    """The true beam's angle from sky (az, el) commanded through a correction: a fitted
    cross-scan ``offset`` (dx, dy: the pose minus the target with the beam on it; the
    [offsets] urc calibrate offers), or a fitted pointing ``model``, or nothing."""
    az, el = np.asarray(az_deg, dtype=float), np.asarray(el_deg, dtype=float)
    if model is not None:
        am, em = model.mech_from_beam(az, el)
    elif offset is not None:
        el_m = el + offset[1]
        am, em = (az + offset[0] / np.maximum(np.cos(np.radians(el_m)), 1e-3)) % 360.0, el_m
    else:
        am, em = az, el
    ba, be = (am, em) if error is None else error.beam_from_mech(am, em)
    return np.asarray(great_circle_deg(ba, be, az, el))


def mech_pose(s: SunScan) -> tuple[float, float]:
    """The mechanical pose with the beam on the Sun (for a pointing-model fit)."""
    assert s.fit is not None
    return offset_pose(s.mid_az_deg, s.mid_el_deg, s.fit.dx_deg, s.fit.dy_deg)


def sky_rms_deg(error: PointingModel | None, positions: tuple[np.ndarray, np.ndarray], **correction: Any) -> float:
    return float(math.sqrt(np.mean(corrected_error_deg(error, *positions, **correction) ** 2)))
