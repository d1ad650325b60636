"""Angles between sky directions: the one great-circle formula every part of urc uses
(the tracker's plan, the pass evaluation, the dashboard's pointing error)."""

from __future__ import annotations

import numpy as np


def great_circle_deg(az1_deg, el1_deg, az2_deg, el2_deg) -> np.ndarray:
    """Angle between (az1, el1) and (az2, el2), elementwise over arrays or on scalars.
    The haversine form: accurate for the small angles that matter here."""
    a1, e1, a2, e2 = (np.radians(np.asarray(x, dtype=float)) for x in (az1_deg, el1_deg, az2_deg, el2_deg))
    h = np.sin((e2 - e1) / 2) ** 2 + np.cos(e1) * np.cos(e2) * np.sin((a2 - a1) / 2) ** 2
    return np.degrees(2 * np.arcsin(np.sqrt(np.clip(h, 0.0, 1.0))))
