"""Calibration maths (pure: numbers in, numbers out; testable without a rotator): the
G4JNT two-point pot line, the SARCNET hard-iron circle and soft-iron ellipse fits, the
ellipsoid fit of the hand-held 12-direction calibration, and the errors all calibrations
raise (:mod:`urc.procedures.calibration` re-exports every name)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

# (defined with the other errors: the I/O process maps them to replies without numpy)
from ..errors import CalibrationError, NoSuchConstant  # noqa: F401 (re-exported)


# =========================================================================== maths
def two_point_pot(bearing1_deg: float, p1: float, bearing2_deg: float, p2: float) -> tuple[float, float]:
    """G4JNT: angle = M*P + C through two known (angle, P) points. Returns (M, C)."""
    if not all(math.isfinite(v) for v in (bearing1_deg, p1, bearing2_deg, p2)):
        raise CalibrationError("two-point calibration needs finite bearings and pot readings")
    if abs(p2 - p1) < 1e-9:
        raise CalibrationError(f"both points read the same pot value P={p1:g}: move further apart")
    if abs(bearing2_deg - bearing1_deg) < 1e-9:
        raise CalibrationError("both points have the same bearing: use two different directions")
    m = (bearing2_deg - bearing1_deg) / (p2 - p1)
    return m, bearing1_deg - m * p1


@dataclass(frozen=True)
class HardIronFit:
    x: float
    y: float
    radius: float
    #: RMS distance of the samples from the fitted circle, in units of the radius
    rms_rel: float
    #: largest angular gap between samples around the centre, degrees
    max_gap_deg: float


def fit_hard_iron(samples: Sequence[tuple[float, float]]) -> HardIronFit:
    """Centre of the circle the horizontal field draws as the antenna turns (Kasa fit).

    Solves x^2 + y^2 = 2a x + 2b y + c by least squares; (a, b) is the hard-iron offset.
    """
    pts = np.asarray(samples, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
        raise CalibrationError("the hard-iron fit needs at least 3 field samples (bx, by)")
    if not np.all(np.isfinite(pts)):
        raise CalibrationError("field samples must be finite")
    x, y = pts[:, 0], pts[:, 1]
    design = np.column_stack([2 * x, 2 * y, np.ones_like(x)])
    sol, *_ = np.linalg.lstsq(design, x * x + y * y, rcond=None)
    a, b, c = (float(v) for v in sol)
    r2 = c + a * a + b * b
    if not r2 > 0:
        raise CalibrationError("field samples do not lie on a circle (all in one direction?)")
    radius = math.sqrt(r2)
    dist = np.hypot(x - a, y - b)
    rms_rel = float(np.sqrt(np.mean((dist - radius) ** 2)) / radius)
    ang = np.sort(np.degrees(np.arctan2(y - b, x - a)) % 360.0)
    gaps = np.diff(np.concatenate([ang, [ang[0] + 360.0]]))
    return HardIronFit(a, b, radius, rms_rel, float(gaps.max()))


@dataclass(frozen=True)
class SoftIronFit:
    x: float
    y: float
    #: row-major 2x2 matrix that turns the centred ellipse into a circle (same area)
    matrix: tuple[float, float, float, float]
    #: long axis / short axis of the ellipse (1 = no soft iron)
    axis_ratio: float
    #: RMS distance of the corrected samples from their circle, in units of its radius
    rms_rel: float


@dataclass(frozen=True)
class EllipsoidFit:
    """An ellipse (2-D) or ellipsoid (3-D) fitted to field samples."""
    centre: tuple[float, ...]
    #: symmetric matrix (row-major) that maps the centred ellipsoid onto the unit sphere
    to_sphere: tuple[float, ...]
    #: half extent along each sensor axis ((max - min)/2 of that component on the surface)
    half_extent: tuple[float, ...]
    #: longest / shortest axis (1 = a sphere: no soft iron)
    axis_ratio: float
    #: RMS distance of the corrected samples from their sphere, in units of its radius
    rms_rel: float

    @property
    def dim(self) -> int:
        return len(self.centre)


def fit_ellipsoid(samples: Sequence[Sequence[float]] | np.ndarray) -> EllipsoidFit:
    """Hard and soft iron together: the ellipse (x, y) or ellipsoid (x, y, z) the field
    draws as the sensor turns.

    Least squares on the general quadric sum(Q_ij x_i x_j) + sum(d_i x_i) = 1; its centre is
    the hard iron, and the symmetric square root of the shape matrix normalised at the
    centre maps the ellipsoid onto the unit sphere: that is the soft-iron correction.
    """
    pts = np.asarray(samples, dtype=float)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise CalibrationError("field samples must be (x, y) or (x, y, z) vectors")
    n = pts.shape[1]
    pairs = [(i, j) for i in range(n) for j in range(i, n)]
    if len(pts) < len(pairs) + n:
        raise CalibrationError(f"the {'ellipse' if n == 2 else 'ellipsoid'} fit needs at least "
                               f"{len(pairs) + n} field samples, got {len(pts)}")
    if not np.all(np.isfinite(pts)):
        raise CalibrationError("field samples must be finite")
    design = np.column_stack([pts[:, i] * pts[:, j] for i, j in pairs] + [pts[:, i] for i in range(n)])
    sol, _, rank, _ = np.linalg.lstsq(design, np.ones(len(pts)), rcond=None)
    if rank < design.shape[1]:
        raise CalibrationError("field samples do not span an ellipsoid (too few distinct directions)")
    q = np.zeros((n, n))
    for (i, j), v in zip(pairs, sol[:len(pairs)]):
        q[i, j] = q[j, i] = v if i == j else v / 2
    try:
        centre = np.linalg.solve(2 * q, -sol[len(pairs):])
    except np.linalg.LinAlgError:
        raise CalibrationError("field samples do not lie on an ellipsoid") from None
    k = 1.0 + centre @ q @ centre
    qn = q / k
    w, v = np.linalg.eigh(qn)
    if not (w > 0).all():
        raise CalibrationError("field samples do not lie on an ellipsoid (all in one direction?)")
    sq = v @ np.diag(np.sqrt(w)) @ v.T
    r = np.linalg.norm((pts - centre) @ sq.T, axis=1)
    return EllipsoidFit(tuple(float(c) for c in centre), tuple(float(t) for t in sq.ravel()),
                        tuple(float(math.sqrt(d)) for d in np.diag(np.linalg.inv(qn))),
                        float(math.sqrt(w.max() / w.min())), float(np.std(r) / np.mean(r)))


def fit_soft_iron(samples: Sequence[tuple[float, float]]) -> SoftIronFit:
    """The horizontal field's ellipse (:func:`fit_ellipsoid` in 2-D), its correction
    scaled to keep the area (the compass driver's 2x2 ``soft_iron``)."""
    pts = np.asarray(samples, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 5:
        raise CalibrationError("the soft-iron fit needs at least 5 field samples (bx, by)")
    fit = fit_ellipsoid(pts)
    sq = np.asarray(fit.to_sphere).reshape(2, 2)
    m = sq / math.sqrt(abs(np.linalg.det(sq)))
    m00, m01, m10, m11 = (float(t) for t in m.ravel())
    return SoftIronFit(fit.centre[0], fit.centre[1], (m00, m01, m10, m11), fit.axis_ratio, fit.rms_rel)


def circular_mean_deg(values: Sequence[float]) -> float:
    rad = np.radians(np.asarray(values, dtype=float))
    return float(np.degrees(np.arctan2(np.sin(rad).mean(), np.cos(rad).mean())) % 360.0)
