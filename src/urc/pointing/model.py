"""The pointing error model: where the beam truly points for a mechanical (encoder)
az/el, and the mechanical pose that puts the beam on a sky direction.

The terms are the seven geometric terms of an alt-azimuth mount as the radio and optical
telescope pointing literature names them after P. T. Wallace's TPOINT (TPOINT manual,
"The pointing terms"; the same eight-term set as pytelpoint's ``azel_model``; J. Mangum,
"A telescope pointing algorithm for ALMA", ALMA Memo 366, 2001):

======  ==============================================  ==================================
term    what                                            mech - beam (deg)
======  ==============================================  ==================================
IA      azimuth encoder zero                            dA = IA
IE      elevation encoder zero                          dE = IE
CA      collimation: beam left/right of the boresight   dA = CA / cos E
        square to the elevation axis
NPAE    az/el axis non-perpendicularity                 dA = NPAE tan E
AN      azimuth axis tilted toward north                dA = AN sin A tan E, dE = AN cos A
AW      azimuth axis tilted toward west                 dA = AW cos A tan E, dE = -AW sin A
TF      gravitational sag (tube flexure)                dE = TF cos E
======  ==============================================  ==================================

with A, E the mechanical azimuth (compass: 0 north, 90 east) and elevation, and
dA, dE = mechanical minus beam. The functional forms are TPOINT's; the signs are urc's
own, stated physically: IA > 0 means the encoder reads IA more than the beam's azimuth;
TF > 0 means the boom droops (the beam is below the encoder's elevation, most at the
horizon); an axis whose top leans ``tilt`` toward compass azimuth P gives
AN = tilt cos P, AW = -tilt sin P (:meth:`PointingModel.with_tilt`): the beam is low
looking toward the lean; CA > 0 puts the beam anticlockwise (seen from above) of the
boresight. TPOINT itself measures azimuth from south and calls a correction positive to
the left, so compare its coefficients term by term after that conversion.

First order in the terms (a few degrees at most), like TPOINT's own; tan E and sec E grow
without bound at the zenith, so they are taken at E = 85 deg above it, and the model is for E up to ~85 deg and for unflipped poses
(elevation axis not over the top). Inputs may be numpy arrays (vectorised).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np

from ..control.geometry import MODEL_MAX_EL_DEG, POINTING_TERMS

TERMS = POINTING_TERMS


@dataclass(frozen=True)
class PointingModel:
    """The terms in degrees (0: a perfect mount)."""

    ia_deg: float = 0.0
    ie_deg: float = 0.0
    ca_deg: float = 0.0
    npae_deg: float = 0.0
    an_deg: float = 0.0
    aw_deg: float = 0.0
    tf_deg: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and abs(v) <= 10.0):
                raise ValueError(f"pointing model: {f.name} must be a finite number of degrees "
                                 f"within +-10 (a first-order model), found {v!r}")

    @classmethod
    def with_tilt(cls, tilt_deg: float, toward_az_deg: float, **terms: float) -> "PointingModel":
        """The azimuth axis leaning ``tilt_deg`` toward compass azimuth ``toward_az_deg``."""
        p = math.radians(toward_az_deg)
        return cls(an_deg=tilt_deg * math.cos(p), aw_deg=-tilt_deg * math.sin(p), **terms)

    @property
    def tilt(self) -> tuple[float, float]:
        """(tilt_deg, toward_az_deg) of the azimuth axis."""
        return math.hypot(self.an_deg, self.aw_deg), math.degrees(math.atan2(-self.aw_deg, self.an_deg)) % 360.0

    def as_vector(self) -> np.ndarray:
        return np.array([getattr(self, f"{t}_deg") for t in TERMS])

    @classmethod
    def from_vector(cls, v: Any) -> "PointingModel":
        return cls(**{f"{t}_deg": float(x) for t, x in zip(TERMS, v)})

    @classmethod
    def from_dict(cls, d: dict[str, float]) -> "PointingModel":
        """From ``{"ia_deg": .., ...}`` (or the bare term names); unknown keys refused."""
        out = {}
        for k, v in d.items():
            key = k if k.endswith("_deg") else f"{k.lower()}_deg"
            if key[:-4] not in TERMS:
                raise ValueError(f"pointing model: unknown term {k!r}; expected one of "
                                 f"{', '.join(t.upper() for t in TERMS)}")
            out[key] = float(v)
        return cls(**out)

    def as_dict(self) -> dict[str, float]:
        return asdict(self)

    def as_terms(self) -> tuple[float, ...]:
        """The terms as :class:`urc.control.geometry.Geometry` carries them."""
        return tuple(float(v) for v in self.as_vector())

    # -------------------------------------------------------------- the model
    def offsets_deg(self, az_m_deg: Any, el_m_deg: Any) -> tuple[Any, Any]:
        """(dA, dE) = mechanical minus beam, in degrees, at mechanical pose (A, E)."""
        return _apply(design(az_m_deg, el_m_deg), self.as_vector())

    def beam_from_mech(self, az_m_deg: Any, el_m_deg: Any) -> tuple[Any, Any]:
        """Where the beam truly points with the axes at mechanical (az, el)."""
        da, de = self.offsets_deg(az_m_deg, el_m_deg)
        return np.mod(np.asarray(az_m_deg) - da, 360.0), np.asarray(el_m_deg) - de

    def mech_from_beam(self, az_deg: Any, el_deg: Any, *, tol_deg: float = 1e-10,
                       max_iter: int = 50) -> tuple[Any, Any]:
        """The mechanical pose whose beam points at sky (az, el): the fixed point of
        m = beam + offsets(m), which converges at once for terms of a few degrees."""
        az, el = np.asarray(az_deg, dtype=float), np.asarray(el_deg, dtype=float)
        am, em = az, el
        for _ in range(max_iter):
            da, de = self.offsets_deg(am, em)
            am_new, em_new = az + da, el + de
            done = max(np.max(np.abs(am_new - am)), np.max(np.abs(em_new - em))) < tol_deg
            am, em = am_new, em_new
            if done:
                break
        return np.mod(am, 360.0), em


def design(az_m_deg: Any, el_m_deg: Any) -> tuple[np.ndarray, np.ndarray]:
    """The partial derivatives of (dA, dE) by each term at mechanical poses: two arrays
    of shape (..., len(TERMS)); (dA, dE) = (Ja @ terms, Je @ terms). The model is linear
    in its terms, so these are its whole definition, and a fit is linear least squares."""
    a = np.radians(np.asarray(az_m_deg, dtype=float))
    # (the tan E, sec E terms bounded as the control loop bounds them: geometry.model_offsets_deg)
    e = np.radians(np.clip(np.asarray(el_m_deg, dtype=float), -MODEL_MAX_EL_DEG, MODEL_MAX_EL_DEG))
    sa, ca, te, ce = np.sin(a), np.cos(a), np.tan(e), np.cos(e)
    one, zero = np.ones_like(a), np.zeros_like(a)
    #            IA   IE    CA       NPAE  AN         AW         TF
    ja = np.stack([one, zero, 1.0 / ce, te, sa * te, ca * te, zero], axis=-1)
    je = np.stack([zero, one, zero, zero, ca, -sa, ce], axis=-1)
    return ja, je


def _apply(j: tuple[np.ndarray, np.ndarray], v: np.ndarray) -> tuple[Any, Any]:
    da, de = j[0] @ v, j[1] @ v
    if np.ndim(da) == 0:
        return float(da), float(de)
    return da, de
