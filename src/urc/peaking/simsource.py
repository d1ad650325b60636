"""A simulated received power: a source in the sky seen through a Gaussian beam, over a
noise floor with radiometer noise. Off unless built: nothing in the simulator makes one.

Power (linear, the noise floor = 1) at a beam direction ``d`` from the source centre:

    P = 1 + S * g(d),   g = (s_b^2 / s^2) exp(-d^2 / (2 s^2)),   s^2 = s_b^2 + r^2 / 4

with s_b = FWHM / sqrt(8 ln 2) the beam's and r the source's angular radius: a uniform
disc (the Sun, 0.27 deg; the Moon, 0.26 deg) convolved with the beam, approximated by the
Gaussian of the same second moment (exact for a point source; the disc's own variance is
r^2/4 per axis). Each sample has radiometer noise (the radiometer equation): a standard
deviation ``noise_frac`` = 1/sqrt(bandwidth x integration) of the total power, so the
noise grows on the source. ``snr_db`` sets the peak: S = 10^(snr_db/10) x noise_frac,
the source's peak over the floor's noise. Reported in dB (10 log10 P), as rtl_power or
an S-meter would; ``ceiling_db`` clips like a receiver that saturates. ``horizon_deg``
(None: no horizon) hides a source below that elevation: the Earth blocks a satellite
before its AOS (a step-track measures its noise floor then).
"""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from ..angles import great_circle_deg
from ..pointing.sources import Sample, judge

#: mean angular radii (the Sun 959.6"/Moon 932.6" at mean distance: the Astronomical
#: Almanac's semidiameters)
SUN_RADIUS_DEG = 959.6 / 3600.0
MOON_RADIUS_DEG = 932.6 / 3600.0


class SkySource:
    """What the antenna looks for: a ``target`` (anything with ``position(t_unix_s)``,
    :mod:`urc.tracking.targets`) and its angular radius (0: a point: a beacon, a
    satellite)."""

    def __init__(self, target: Any, radius_deg: float = 0.0, name: str = ""):
        self.target, self.radius_deg = target, float(radius_deg)
        self.name = name or getattr(target, "name", "source")

    @classmethod
    def sun(cls, station: Any) -> "SkySource":
        from ..tracking.targets import SunTarget
        return cls(SunTarget(station), SUN_RADIUS_DEG)

    @classmethod
    def moon(cls, station: Any) -> "SkySource":
        from ..tracking.targets import MoonTarget
        return cls(MoonTarget(station), MOON_RADIUS_DEG)

    @classmethod
    def beacon(cls, az_deg: float, el_deg: float) -> "SkySource":
        from ..tracking.targets import FixedTarget
        return cls(FixedTarget(az_deg, el_deg, "beacon"))

    @classmethod
    def satellite(cls, elements: Any, station: Any) -> "SkySource":
        from ..tracking.targets import SatelliteTarget
        return cls(SatelliteTarget(elements, station))

    def position(self, t_unix_s: float) -> tuple[float, float]:
        return self.target.position(t_unix_s)


def beam_gain(offset_deg: Any, fwhm_deg: float, radius_deg: float = 0.0) -> Any:
    """The response (1 at the centre of a point source) at ``offset_deg`` from the source."""
    sb2 = fwhm_deg ** 2 / (8.0 * math.log(2.0))
    s2 = sb2 + radius_deg ** 2 / 4.0
    return (sb2 / s2) * np.exp(-np.asarray(offset_deg) ** 2 / (2.0 * s2))


class SimulatedPower:
    """A :class:`~urc.pointing.sources.PowerSource` on the simulator.

    ``beam_at()`` -> (t_unix_s, az_deg, el_deg): where the beam truly points now
    (:func:`world_beam`). ``measure`` does the same for arrays, without a world."""

    def __init__(self, source: SkySource, *, fwhm_deg: float, snr_db: float,
                 beam_at: Callable[[], tuple[float, float, float]] | None = None,
                 noise_frac: float = 0.01, ceiling_db: float | None = None, seed: int = 1,
                 name: str = "simulated power", horizon_deg: float | None = None):
        if not (fwhm_deg > 0 and math.isfinite(snr_db) and 0 < noise_frac < 1):
            raise ValueError(f"simulated power: expected fwhm_deg > 0, a finite snr_db and 0 < noise_frac < 1, "
                             f"found {fwhm_deg!r}, {snr_db!r}, {noise_frac!r}")
        self.source, self.fwhm_deg, self.snr_db = source, float(fwhm_deg), float(snr_db)
        self.noise_frac, self.ceiling_db = float(noise_frac), ceiling_db
        self.peak = 10.0 ** (snr_db / 10.0) * noise_frac
        self.beam_at, self.horizon_deg = beam_at, horizon_deg
        self.rng = np.random.default_rng(seed)
        self.name = name

    def true_power(self, t_unix_s: Any, az_deg: Any, el_deg: Any) -> Any:
        """Noise-free linear power (floor 1) with the beam at (az, el)."""
        t = np.atleast_1d(np.asarray(t_unix_s, dtype=float))
        pos = np.array([self.source.position(float(u)) for u in t])
        d = great_circle_deg(np.asarray(az_deg), np.asarray(el_deg), pos[:, 0], pos[:, 1])
        p = 1.0 + self.peak * beam_gain(d, self.fwhm_deg, self.source.radius_deg)
        if self.horizon_deg is not None:
            p = np.where(pos[:, 1] < self.horizon_deg, 1.0, p)
        return p if np.ndim(az_deg) else float(np.ravel(p)[0])

    def measure(self, t_unix_s: Any, az_deg: Any, el_deg: Any) -> np.ndarray:
        """Noisy readings in dB (clipped at ``ceiling_db``) with the beam at (az, el)."""
        p = np.atleast_1d(self.true_power(t_unix_s, az_deg, el_deg))
        p = p + self.rng.normal(0.0, 1.0, p.shape) * self.noise_frac * p
        db = 10.0 * np.log10(np.maximum(p, 1e-6))
        return np.minimum(db, self.ceiling_db) if self.ceiling_db is not None else db

    def read(self) -> Sample:
        if self.beam_at is None:
            raise RuntimeError("simulated power: no beam_at: use measure() or give one")
        t, az, el = self.beam_at()
        value = float(self.measure(t, az, el)[0])
        return judge(t, value, "dB", now_s=t, max_age_s=None, ceiling=self.ceiling_db, what=self.name)


def true_beam(model: Any, az_m_deg: float, el_m_deg: float, az_zero_deg: float = 0.0) -> tuple[float, float]:
    """Where the simulated beam truly points with the axes at (az_m, el_m) of the
    simulator's truth: the boresight's sky direction (``az_zero_deg``: the mechanical
    zero's compass bearing, 180 on a south-zero rotator; over the top, the other side),
    then the world's pointing error ``model`` (None: the beam is the boresight).

    Nothing the controller believes enters: its [offsets] and its fitted pointing model
    are what a calibration measures, not where the iron points."""
    az, el = az_m_deg + az_zero_deg, el_m_deg
    if el > 90.0:  # over the top
        az, el = az + 180.0, 180.0 - el
    if model is not None:
        az, el = model.beam_from_mech(az % 360.0, el)
    return float(az) % 360.0, float(el)


def world_beam(world: Any, unix_at: Callable[[float], float],
               az_zero_deg: float = 0.0) -> Callable[[], tuple[float, float, float]]:
    """``beam_at`` for a simulated rotator: its true axes through the world's pointing
    error model (``world.pointing_error``) to the sky (:func:`true_beam`)."""
    def beam_at() -> tuple[float, float, float]:
        truth = world.truth()
        az, el = true_beam(getattr(world, "pointing_error", None), truth["az"]["deg"], truth["el"]["deg"],
                           az_zero_deg)
        return unix_at(world.clock.now_s()), az, el
    return beam_at
