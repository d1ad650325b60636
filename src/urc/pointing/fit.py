"""The beam fitted to a scan's power: a Gaussian over a baseline, by least squares
(Levenberg-Marquardt in numpy: scipy is not a dependency of urc), with each parameter's
standard uncertainty from the covariance scaled by the residual variance (what
``scipy.optimize.curve_fit`` reports with ``absolute_sigma=False``).

A cross scan is two 1-D fits (the azimuth leg across elevation, the elevation leg); a
raster one 2-D fit. The offsets found are where the beam's peak lay in the commanded
offsets: the pointing error, mechanical minus beam (:mod:`.model`): a positive ``dx``
means the antenna had to be turned dx further clockwise (across the sky) than the target
to look at it.

A scan is refused (:class:`ScanRefused`, with a reason) rather than fitted into a wrong
answer: ``saturated`` (a sample at the receiver's ceiling, or the source said so),
``noise`` (no peak significantly above the noise), ``width`` (a peak far narrower or
wider than the beam: a spike or a drift, not the source), ``off_scan`` (the peak's centre
outside the scanned span: recentre and scan again), ``few`` (too few good samples).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Literal

import numpy as np

from ..errors import UrcError
from .sources import to_linear

FWHM_PER_SIGMA = math.sqrt(8.0 * math.log(2.0))
#: a peak is significant at this many standard uncertainties of its own amplitude
MIN_SIGNIFICANCE = 5.0
#: the fitted width must lie within these factors of the configured beamwidth
WIDTH_RANGE = (0.33, 3.0)

Refusal = Literal["saturated", "noise", "width", "off_scan", "few"]


class ScanRefused(UrcError):
    def __init__(self, reason: Refusal, message: str):
        self.reason = reason
        super().__init__(f"{reason}: {message}")


@dataclass(frozen=True)
class GaussFit:
    """One fitted peak: centre ``offset_deg`` (per axis for 2-D), ``fwhm_deg``, ``peak``
    over ``baseline`` (linear power units), each with its standard uncertainty; the
    residual RMS and the peak's significance (peak / its uncertainty)."""

    offset_deg: tuple[float, ...]
    offset_err_deg: tuple[float, ...]
    fwhm_deg: tuple[float, ...]
    fwhm_err_deg: tuple[float, ...]
    peak: float
    peak_err: float
    baseline: float
    residual_rms: float
    samples: int

    @property
    def significance(self) -> float:
        return self.peak / self.peak_err if self.peak_err > 0 else math.inf

    @property
    def snr_db(self) -> float:
        """The peak over the residual noise, in dB (as the simulator's ``snr_db``)."""
        return 10.0 * math.log10(self.peak / self.residual_rms) if self.peak > 0 and self.residual_rms > 0 else math.nan


@dataclass(frozen=True)
class CrossFit:
    az: GaussFit      # the azimuth leg: offset across elevation
    el: GaussFit      # the elevation leg

    @property
    def dx_deg(self) -> float:
        return self.az.offset_deg[0]

    @property
    def dy_deg(self) -> float:
        return self.el.offset_deg[0]

    @property
    def dx_err_deg(self) -> float:
        return self.az.offset_err_deg[0]

    @property
    def dy_err_deg(self) -> float:
        return self.el.offset_err_deg[0]


def _lm(fun: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], p0: np.ndarray,
        max_iter: int = 200) -> tuple[np.ndarray, np.ndarray, float]:
    """Levenberg-Marquardt: ``fun(p)`` -> (residuals, Jacobian). Returns (p, covariance
    scaled by the residual variance, residual sum of squares)."""
    p = np.asarray(p0, dtype=float)
    r, jac = fun(p)
    cost, lam = float(r @ r), 1e-3
    for _ in range(max_iter):
        a, g = jac.T @ jac, jac.T @ r
        try:
            step = np.linalg.solve(a + lam * np.diag(np.diag(a) + 1e-12), -g)
        except np.linalg.LinAlgError:
            break
        p_new = p + step
        r_new, jac_new = fun(p_new)
        c_new = float(r_new @ r_new)
        if np.isfinite(c_new) and c_new <= cost:
            done = cost - c_new <= 1e-12 * max(cost, 1e-300) and np.all(np.abs(step) <= 1e-10 * (np.abs(p) + 1e-10))
            p, r, jac, cost, lam = p_new, r_new, jac_new, c_new, max(lam / 3.0, 1e-12)
            if done:
                break
        else:
            lam *= 4.0
            if lam > 1e12:
                break
    dof = max(1, len(r) - len(p))
    try:
        cov = np.linalg.inv(jac.T @ jac) * cost / dof
    except np.linalg.LinAlgError:
        cov = np.full((len(p), len(p)), np.inf)
    return p, cov, cost


def _linear(values: Any, unit: str) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    return 10.0 ** (v / 10.0) if unit in ("dB", "dBm") else v


def _guard(x: np.ndarray, y: np.ndarray, *, min_samples: int, ceiling: float | None, values: Any,
           saturated: int) -> None:
    if saturated:
        raise ScanRefused("saturated", f"{saturated} sample(s) refused as saturated by the source: "
                          "add attenuation (or scan a weaker source) and scan again")
    if ceiling is not None and np.any(np.asarray(values, dtype=float) >= ceiling):
        raise ScanRefused("saturated", f"{int(np.sum(np.asarray(values) >= ceiling))} sample(s) at the "
                          f"ceiling {ceiling:g}: the peak's true power is unknown")
    if len(y) < min_samples or not np.all(np.isfinite(y)) or not np.all(np.isfinite(x)):
        raise ScanRefused("few", f"{len(y)} finite samples, at least {min_samples} needed")


def _judge(fit: GaussFit, fwhm_deg: float, half_width_deg: float) -> GaussFit:
    if not (fit.peak > 0 and fit.significance >= MIN_SIGNIFICANCE):
        raise ScanRefused("noise", f"no significant peak: {fit.peak:.3g} +- {fit.peak_err:.2g} "
                          f"({fit.significance:.1f} sigma, {MIN_SIGNIFICANCE:g} needed)")
    lo, hi = WIDTH_RANGE
    for w in fit.fwhm_deg:
        if not lo * fwhm_deg <= w <= hi * fwhm_deg:
            raise ScanRefused("width", f"fitted width {w:.3g} deg, expected {lo * fwhm_deg:.3g}..{hi * fwhm_deg:.3g} "
                              f"(beamwidth {fwhm_deg:g} deg): not the beam on the source")
    for off in fit.offset_deg:
        if abs(off) > half_width_deg:
            raise ScanRefused("off_scan", f"peak at {off:+.3g} deg, outside the scan's +-{half_width_deg:g} deg: "
                              "recentre on it and scan again")
    return fit


def fit_gauss_1d(x_deg: Any, values: Any, unit: str, *, fwhm_deg: float, half_width_deg: float | None = None,
                 ceiling: float | None = None, saturated: int = 0) -> GaussFit:
    """A Gaussian over a constant, in linear power, along one leg."""
    x = np.asarray(x_deg, dtype=float)
    y = _linear(values, unit)
    _guard(x, y, min_samples=7, ceiling=ceiling, values=values, saturated=saturated)
    base0 = float(np.median(np.sort(y)[: max(2, len(y) // 3)]))
    i = int(np.argmax(np.convolve(y, np.ones(3) / 3, mode="same")))
    p0 = np.array([base0, max(float(y[i]) - base0, 1e-12), float(x[i]), fwhm_deg / FWHM_PER_SIGMA])

    def fun(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        b, a, x0, s = p
        u = (x - x0) / s
        g = np.exp(-0.5 * u * u)
        jac = np.stack([np.ones_like(x), g, a * g * u / s, a * g * u * u / s], axis=1)
        return b + a * g - y, jac
    p, cov, rss = _lm(fun, p0)
    err = np.sqrt(np.abs(np.diag(cov)))
    fit = GaussFit((float(p[2]),), (float(err[2]),), (abs(float(p[3])) * FWHM_PER_SIGMA,),
                   (float(err[3]) * FWHM_PER_SIGMA,), float(p[1]), float(err[1]), float(p[0]),
                   math.sqrt(rss / max(1, len(y) - 4)), len(y))
    half = half_width_deg if half_width_deg is not None else float(np.max(np.abs(x)))
    return _judge(fit, fwhm_deg, half)


def fit_cross(dx_deg: Any, dy_deg: Any, values: Any, unit: str, legs: Any, *, fwhm_deg: float,
              half_width_deg: float | None = None, ceiling: float | None = None, saturated: int = 0) -> CrossFit:
    """Both legs of a cross scan: ``legs`` names each sample's leg ("az" or "el")."""
    legs = np.asarray(legs)
    vals = np.asarray(values, dtype=float)
    if saturated:
        _guard(np.zeros(1), np.zeros(1), min_samples=0, ceiling=None, values=[], saturated=saturated)
    az = legs == "az"
    el = legs == "el"
    kw = dict(fwhm_deg=fwhm_deg, half_width_deg=half_width_deg, ceiling=ceiling)
    return CrossFit(fit_gauss_1d(np.asarray(dx_deg)[az], vals[az], unit, **kw),  # type: ignore[arg-type]
                    fit_gauss_1d(np.asarray(dy_deg)[el], vals[el], unit, **kw))  # type: ignore[arg-type]


def fit_gauss_2d(dx_deg: Any, dy_deg: Any, values: Any, unit: str, *, fwhm_deg: float,
                 half_width_deg: float | None = None, ceiling: float | None = None, saturated: int = 0) -> GaussFit:
    """An elliptical (axis-aligned) Gaussian over a constant, for a raster scan."""
    x, yy = np.asarray(dx_deg, dtype=float), np.asarray(dy_deg, dtype=float)
    z = _linear(values, unit)
    _guard(np.concatenate([x, yy]), z, min_samples=9, ceiling=ceiling, values=values, saturated=saturated)
    base0 = float(np.median(np.sort(z)[: max(2, len(z) // 3)]))
    i = int(np.argmax(z))
    s0 = fwhm_deg / FWHM_PER_SIGMA
    p0 = np.array([base0, max(float(z[i]) - base0, 1e-12), float(x[i]), float(yy[i]), s0, s0])

    def fun(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        b, a, x0, y0, sx, sy = p
        u, v = (x - x0) / sx, (yy - y0) / sy
        g = np.exp(-0.5 * (u * u + v * v))
        jac = np.stack([np.ones_like(x), g, a * g * u / sx, a * g * v / sy, a * g * u * u / sx,
                        a * g * v * v / sy], axis=1)
        return b + a * g - z, jac
    p, cov, rss = _lm(fun, p0)
    err = np.sqrt(np.abs(np.diag(cov)))
    fit = GaussFit((float(p[2]), float(p[3])), (float(err[2]), float(err[3])),
                   (abs(float(p[4])) * FWHM_PER_SIGMA, abs(float(p[5])) * FWHM_PER_SIGMA),
                   (float(err[4]) * FWHM_PER_SIGMA, float(err[5]) * FWHM_PER_SIGMA),
                   float(p[1]), float(err[1]), float(p[0]), math.sqrt(rss / max(1, len(z) - 6)), len(z))
    half = half_width_deg if half_width_deg is not None else float(max(np.max(np.abs(x)), np.max(np.abs(yy))))
    return _judge(fit, fwhm_deg, half)


__all__ = ["CrossFit", "GaussFit", "ScanRefused", "fit_cross", "fit_gauss_1d", "fit_gauss_2d", "to_linear"]
