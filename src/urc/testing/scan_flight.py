"""A scan flown on a simulated rotator: step to each point of a :class:`ScanPlan`, wait
until the antenna stands there, read the power source while it dwells. For tests and
benchmarks (urc itself flies nothing from here).

Each sample is tagged with where the controller *reported* the antenna (its sensors'
view, the frame a pointing offset is measured in) and where the target was at that
instant: the offsets fitted are the reported pose minus the target.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..clock import VirtualClock
from ..pointing.scan import ScanPlan, offset_pose, pose_offset
from ..pointing.sources import SignalRefused
from ..rotator.loop import run_virtual
from ..angles import wrap180_deg


@dataclass
class ScanData:
    t_unix_s: list[float] = field(default_factory=list)
    dx_deg: list[float] = field(default_factory=list)
    dy_deg: list[float] = field(default_factory=list)
    value: list[float] = field(default_factory=list)
    leg: list[str] = field(default_factory=list)
    unit: str = ""
    #: samples the source refused, by reason
    refused: dict[str, int] = field(default_factory=dict)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return (np.array(self.dx_deg), np.array(self.dy_deg), np.array(self.value), np.array(self.leg))


def fly_scan(rot: Any, clock: VirtualClock, plan: ScanPlan, target: Any, source: Any,
             unix_at: Callable[[float], float], *, samples_per_point: int = 5,
             arrive_tol_deg: float | None = None, max_slew_s: float = 120.0) -> ScanData:
    """Fly ``plan`` around ``target`` reading ``source`` ``samples_per_point`` times per
    point, spread over the plan's dwell."""
    data = ScanData()
    period_s = 1.0 / rot.caps.loop_hz
    tol = arrive_tol_deg if arrive_tol_deg is not None else max(0.05, 2 * rot.caps.az.sensor.resolution_deg)
    every = max(1, round(plan.dwell_s / period_s / samples_per_point))
    for p in plan.points:
        taz, tel = target.position(unix_at(clock.now_s()))
        az, el = offset_pose(taz, tel, p.dx_deg, p.dy_deg)
        rot.goto(az, el)

        def there(s: Any, az: float = az, el: float = el) -> bool:
            daz = abs(wrap180_deg(s.az_deg - az))
            return not s.moving and daz <= tol and abs(s.el_deg - el) <= tol
        run_virtual(rot, clock, max_slew_s, until=there)
        for _ in range(samples_per_point):
            status = run_virtual(rot, clock, every * period_s)
            u = unix_at(clock.now_s())
            try:
                sample = source.read()
            except SignalRefused as exc:
                data.refused[exc.reason] = data.refused.get(exc.reason, 0) + 1
                continue
            taz, tel = target.position(u)
            dx, dy = pose_offset(status.az_deg, status.el_deg, taz, tel)
            data.t_unix_s.append(u)
            data.dx_deg.append(float(dx))
            data.dy_deg.append(float(dy))
            data.value.append(sample.value)
            data.leg.append(p.leg)
            data.unit = sample.unit
    return data
