"""Point by the signal (issue 38): received-power sources, the pointing error model,
scans around a source and the fits that turn them into offsets.

Nothing here moves the antenna or runs in the control process: a scan is a plan of
poses that a caller flies (:mod:`urc.testing.scan_flight` on the simulator), and the
sources block on their own I/O (run them in a worker thread). The names below load on
first use: the stored model (:mod:`.store`) is read at every start, without numpy.
"""

from __future__ import annotations

import importlib
from typing import Any

_WHERE = {
    "CrossFit": "fit", "GaussFit": "fit", "ScanRefused": "fit", "fit_cross": "fit", "fit_gauss_1d": "fit",
    "fit_gauss_2d": "fit", "TERMS": "model", "PointingModel": "model", "ScanPlan": "scan", "ScanPoint": "scan",
    "cross_scan": "scan", "offset_pose": "scan", "pose_offset": "scan", "raster_scan": "scan",
    "PowerSource": "sources", "Sample": "sources", "SignalRefused": "sources",
}
__all__ = sorted(_WHERE)


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)
