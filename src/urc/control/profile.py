"""Motion profile: an acceleration-limited reference that never crawls below min speed.

The reference (``ref_deg``, ``ref_rate_deg_per_s``) is what the position controller
follows. It starts at the motor's minimum reliable speed (the BIG-RAS "minimal turn"),
ramps up at ``accel``, cruises at ``max_rate``, and brakes so as to arrive at the target
with the target's own rate (moving setpoints), never slower than ``min_rate`` until it
is there. Pure functions: no clock, no state besides what is passed in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol


@dataclass(frozen=True)
class ProfileLimits:
    max_rate_deg_per_s: float
    min_rate_deg_per_s: float
    accel_deg_per_s2: float


class RateLimits(Protocol):
    """What :func:`advance` reads of its limits: a ProfileLimits, or an axis' tuning
    (``law.AxisTuning``), which has the same three (the law passes it as it is, not a
    ProfileLimits made every tick)."""

    @property
    def max_rate_deg_per_s(self) -> float: ...

    @property
    def min_rate_deg_per_s(self) -> float: ...

    @property
    def accel_deg_per_s2(self) -> float: ...


def _braking_speed(dist_deg: float, accel: float, dt_s: float) -> float:
    """Highest speed from which a discrete-time ramp at ``accel`` stops within dist.

    The ``accel*dt/2`` term corrects the continuous formula sqrt(2ad) for the one-tick
    lag of a sampled ramp; without it the reference overshoots and rings at the target.
    """
    half_step = 0.5 * accel * dt_s
    return math.sqrt(2.0 * accel * dist_deg + half_step * half_step) - half_step


def advance(ref_deg: float, ref_rate: float, target_deg: float, target_rate: float,
            limits: RateLimits, dt_s: float, speed_cap: float | None = None
            ) -> tuple[float, float, bool]:
    """One tick of the reference. Returns (ref_deg, ref_rate, arrived)."""
    accel = limits.accel_deg_per_s2
    v_max = limits.max_rate_deg_per_s if speed_cap is None else min(speed_cap, limits.max_rate_deg_per_s)
    error = target_deg - ref_deg
    direction = 1.0 if error > 0 else -1.0
    # Desired speed relative to the (moving) target, limited by braking distance.
    rel = min(v_max, _braking_speed(abs(error), accel, dt_s))
    want = target_rate + direction * rel
    if want > v_max:
        want = v_max
    elif want < -v_max:
        want = -v_max
    # Never crawl below the minimum reliable speed while there is still a way to go
    # (with a static target); at arrival the reference simply stops.
    if abs(target_rate) < 1e-12 and abs(want) < limits.min_rate_deg_per_s:
        want = direction * min(limits.min_rate_deg_per_s, v_max)
    max_dv = accel * dt_s
    dv = want - ref_rate
    if dv > max_dv:
        dv = max_dv
    elif dv < -max_dv:
        dv = -max_dv
    new_rate = ref_rate + dv
    # "Minimal turn": a standing axis may start directly at the minimum speed.
    if abs(ref_rate) < 1e-12 and abs(new_rate) < limits.min_rate_deg_per_s and abs(want) > 0:
        new_rate = math.copysign(min(limits.min_rate_deg_per_s, abs(want)), want)
    new_ref = ref_deg + new_rate * dt_s
    new_target = target_deg + target_rate * dt_s
    # Arrival: the step would reach or cross the target and the speeds match closely
    # enough to stop (or lock on) within one tick of acceleration.
    crossed = (new_target - new_ref) * direction <= 0.0 or abs(new_target - new_ref) <= 1e-9
    if crossed and abs(new_rate - target_rate) <= max(max_dv, limits.min_rate_deg_per_s) + 1e-9:
        return new_target, target_rate, True
    return new_ref, new_rate, False


def stopping_distance_deg(rate_deg_per_s: float, accel_deg_per_s2: float) -> float:
    return rate_deg_per_s * rate_deg_per_s / (2.0 * accel_deg_per_s2)
