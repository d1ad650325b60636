"""The pointing model fitted to several scans by linear least squares (the model is
linear in its terms: :func:`urc.pointing.model.design`).

Each scan gives, at the mechanical pose where the beam was on the source, the measured
offset mechanical minus beam across elevation (dx = dA cos E) and in elevation (dy),
each with its standard uncertainty. The fit weights each by 1/uncertainty^2 (dx and dy
on the sky, so an azimuth error at high elevation is not overweighted), gives each term
with its standard uncertainty (from the weighted covariance, scaled by the reduced
chi-square when that exceeds 1: the scatter, not only the stated errors) and the
residual RMS on the sky. Terms the scans cannot tell apart (all at one elevation: IA,
CA and NPAE are then one number) are refused by name rather than given as noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ..errors import CalibrationError
from .model import TERMS, PointingModel, design


@dataclass(frozen=True)
class ScanResult:
    """One scan's pointing offset: at mechanical (az_m, el_m), mech minus beam."""

    az_m_deg: float
    el_m_deg: float
    dx_deg: float
    dy_deg: float
    dx_err_deg: float
    dy_err_deg: float


@dataclass(frozen=True)
class ModelFit:
    model: PointingModel
    terms: tuple[str, ...]                 # the terms fitted (others held at 0)
    errors_deg: dict[str, float]           # standard uncertainty of each fitted term
    residual_rms_deg: float                # on the sky, per scan
    chi2_reduced: float
    scans: int


def fit_model(scans: Sequence[ScanResult], terms: Sequence[str] = TERMS, *,
              max_condition: float = 1e4) -> ModelFit:
    """Fit ``terms`` (a subset of :data:`TERMS`) to ``scans``. ``max_condition``: of
    the weighted design with unit columns; scans all at one elevation (their fitted
    peaks a few hundredths of a degree apart, so not exactly singular) gave 1.4e5 and
    an IA of 11 deg, two elevations 1.3e3, 18 positions over the sky 39."""
    terms = tuple(t.lower() for t in terms)
    unknown = [t for t in terms if t not in TERMS]
    if unknown:
        raise CalibrationError(f"pointing fit: unknown term(s) {', '.join(unknown)}; expected {', '.join(TERMS)}")
    cols = [TERMS.index(t) for t in terms]
    n_obs = 2 * len(scans)
    if n_obs <= len(terms):
        raise CalibrationError(f"pointing fit: {len(scans)} scan(s) give {n_obs} offsets for {len(terms)} terms; "
                               f"scan at least {len(terms) // 2 + 1} positions")
    az = np.array([s.az_m_deg for s in scans])
    el = np.array([s.el_m_deg for s in scans])
    ja, je = design(az, el)
    ce = np.cos(np.radians(el))[:, None]
    a = np.vstack([ja[:, cols] * ce, je[:, cols]])          # on the sky: dx = dA cos E
    b = np.concatenate([[s.dx_deg for s in scans], [s.dy_deg for s in scans]])
    sig = np.concatenate([[s.dx_err_deg for s in scans], [s.dy_err_deg for s in scans]])
    if not np.all(np.isfinite(sig)) or np.any(sig <= 0):
        raise CalibrationError("pointing fit: every scan needs a finite, positive uncertainty")
    w = 1.0 / sig
    aw, bw = a * w[:, None], b * w
    # a term the scans cannot separate from the others: the normal matrix is singular
    norm = np.linalg.norm(aw, axis=0)
    if np.any(norm == 0):
        raise CalibrationError("pointing fit: no scan constrains "
                               + ", ".join(t.upper() for t, nn in zip(terms, norm) if nn == 0))
    cond = np.linalg.cond(aw / norm)
    if not cond < max_condition:
        raise CalibrationError(f"pointing fit: the scans cannot tell {', '.join(t.upper() for t in terms)} apart "
                               f"(condition {cond:.2g}): scan over a wider range of azimuth and elevation, or fit fewer terms")
    x, *_ = np.linalg.lstsq(aw, bw, rcond=None)
    resid_w = bw - aw @ x
    dof = n_obs - len(terms)
    chi2r = float(resid_w @ resid_w) / dof
    cov = np.linalg.inv(aw.T @ aw) * max(1.0, chi2r)
    full = np.zeros(len(TERMS))
    full[cols] = x
    resid = b - a @ x
    rms = math.sqrt(float(np.mean(resid[: len(scans)] ** 2 + resid[len(scans):] ** 2)))
    return ModelFit(PointingModel.from_vector(full), terms,
                    {t: float(math.sqrt(cov[i, i])) for i, t in enumerate(terms)}, rms, chi2r, len(scans))


def scan_result(az_m_deg: float, el_m_deg: float, fit: Any) -> ScanResult:
    """A :class:`ScanResult` from a :class:`urc.pointing.fit.CrossFit` flown with the
    mechanical pose (az_m, el_m) at the scan's centre."""
    return ScanResult(az_m_deg, el_m_deg, fit.dx_deg, fit.dy_deg, fit.dx_err_deg, fit.dy_err_deg)


def from_record(rec: dict[str, Any], offsets_now: dict[str, float] | None = None) -> ScanResult:
    """A stored scan (:mod:`urc.pointing.store`) as a :class:`ScanResult`, moved to the
    [offsets] in force now if it was flown under others: the boresight's reported frame
    turns by their difference, the beam does not."""
    then = rec.get("offsets") or {}
    d_az = d_el = 0.0
    if offsets_now is not None:
        d_az = float(offsets_now.get("az_deg", 0.0)) - float(then.get("az_deg", 0.0))
        d_el = float(offsets_now.get("el_deg", 0.0)) - float(then.get("el_deg", 0.0))
    el = float(rec["el_deg"]) + d_el
    return ScanResult((float(rec["az_deg"]) + d_az) % 360.0, el,
                      float(rec["dx_deg"]) + d_az * math.cos(math.radians(el)), float(rec["dy_deg"]) + d_el,
                      float(rec["dx_err_deg"]), float(rec["dy_err_deg"]))


def fit_records(records: Sequence[dict[str, Any]], offsets_now: dict[str, float] | None = None,
                terms: Sequence[str] = TERMS, source: str = "") -> dict[str, Any]:
    """Fit ``terms`` to stored scans: the model in its stored form (store.model_doc)."""
    from .store import model_doc

    if not records:
        raise CalibrationError("pointing fit: no scans: run `urc calibrate sun` (or moon, beacon) at several "
                               "positions first, or give a scan file")
    try:
        fit = fit_model([from_record(r, offsets_now) for r in records], terms)
    except ValueError as exc:  # (a term beyond the first-order model's +-10 deg)
        raise CalibrationError(f"pointing fit: {exc}") from None
    values = fit.model.as_dict()
    return model_doc({t: (values[f"{t}_deg"], fit.errors_deg.get(t)) for t in TERMS}, fitted=fit.terms,
                     residual_rms_deg=fit.residual_rms_deg, chi2_reduced=fit.chi2_reduced,
                     scans=list(records), source=source)
