"""Point by the signal (issue 38): received-power sources, the pointing error model,
scans around a source and the fits that turn them into offsets.

Nothing here moves the antenna or runs in the control process: a scan is a plan of
poses that a caller flies (:mod:`urc.testing.scan_flight` on the simulator), and the
sources block on their own I/O (run them in a worker thread).
"""

from .fit import CrossFit, GaussFit, ScanRefused, fit_cross, fit_gauss_1d, fit_gauss_2d
from .model import TERMS, PointingModel
from .scan import ScanPlan, ScanPoint, cross_scan, offset_pose, pose_offset, raster_scan
from .sources import PowerSource, Sample, SignalRefused

__all__ = ["CrossFit", "GaussFit", "PointingModel", "PowerSource", "Sample", "ScanPlan", "ScanPoint",
           "ScanRefused", "SignalRefused", "TERMS", "cross_scan", "fit_cross", "fit_gauss_1d",
           "fit_gauss_2d", "offset_pose", "pose_offset", "raster_scan"]
