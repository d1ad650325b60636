"""Angles between sky directions: the one great-circle formula every part of urc uses
(the tracker's plan, the pass evaluation, the dashboard's pointing error)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np


def great_circle_deg(az1_deg, el1_deg, az2_deg, el2_deg) -> np.ndarray:
    """Angle between (az1, el1) and (az2, el2), elementwise over arrays or on scalars.
    The haversine form: accurate for the small angles that matter here."""
    import numpy as np  # (lazy: the dashboard's one-pair error, great_circle_1_deg, needs none)

    a1, e1, a2, e2 = (np.radians(np.asarray(x, dtype=float)) for x in (az1_deg, el1_deg, az2_deg, el2_deg))
    h = np.sin((e2 - e1) / 2) ** 2 + np.cos(e1) * np.cos(e2) * np.sin((a2 - a1) / 2) ** 2
    return np.degrees(2 * np.arcsin(np.sqrt(np.clip(h, 0.0, 1.0))))


def great_circle_1_deg(az1_deg: float, el1_deg: float, az2_deg: float, el2_deg: float) -> float:
    """:func:`great_circle_deg` of one pair, in plain floats: the same operations in the
    same order (the same result), without numpy (the dashboard's pointing error: the I/O
    process of a ``urc run`` that does not track never imports numpy)."""
    a1, e1, a2, e2 = (math.radians(float(x)) for x in (az1_deg, el1_deg, az2_deg, el2_deg))
    s, t = math.sin((e2 - e1) / 2), math.sin((a2 - a1) / 2)
    h = s * s + math.cos(e1) * math.cos(e2) * (t * t)
    return math.degrees(2 * math.asin(math.sqrt(min(max(h, 0.0), 1.0))))


def wrap180_deg(x):
    """An angle or a difference of azimuths (deg) folded into [-180, 180): a float or a
    numpy array alike, elementwise."""
    return (x + 180.0) % 360.0 - 180.0
