"""Motion profile: acceleration limit, top speed, minimum speed, arrival without ringing."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from urc.control.profile import ProfileLimits, advance

LIM = ProfileLimits(max_rate_deg_per_s=6.0, min_rate_deg_per_s=0.5, accel_deg_per_s2=12.0)
DT = 0.02


def run(start, target, target_rate=0.0, lim=LIM, cap=None, n=20000):
    ref, rate, path = start, 0.0, []
    for i in range(n):
        ref, rate, arrived = advance(ref, rate, target + target_rate * i * DT, target_rate, lim, DT, cap)
        path.append((ref, rate, arrived))
        if arrived and target_rate == 0.0:
            break
    return path


@pytest.mark.parametrize("dist", [0.05, 1.0, 10.0, 90.0, -180.0])
def test_reaches_static_target_without_overshoot(dist):
    path = run(0.0, dist)
    assert path[-1][2], "never arrived"
    assert path[-1][0] == pytest.approx(dist)
    sign = 1 if dist > 0 else -1
    assert all(p[0] * sign <= abs(dist) + 1e-9 for p in path), "reference overshot the target"


def test_speed_and_acceleration_limits():
    path = run(0.0, 100.0)
    rates = [0.0] + [p[1] for p in path]
    assert max(abs(r) for r in rates) <= LIM.max_rate_deg_per_s + 1e-9
    steps = [abs(b - a) for a, b in zip(rates, rates[1:])]
    # the first step may jump to the minimum speed ("minimal turn"), then ramps at accel
    assert steps[0] <= LIM.min_rate_deg_per_s + LIM.accel_deg_per_s2 * DT + 1e-9
    assert max(steps[1:-1]) <= LIM.accel_deg_per_s2 * DT + 1e-9


def test_never_crawls_below_min_speed_before_arrival():
    path = run(0.0, 30.0)
    moving = [abs(p[1]) for p in path[:-1]]
    assert min(moving) >= LIM.min_rate_deg_per_s - 1e-9


def test_speed_cap():
    path = run(0.0, 50.0, cap=2.0)
    assert max(abs(p[1]) for p in path) <= 2.0 + 1e-9


def test_locks_onto_moving_target():
    path = run(0.0, 5.0, target_rate=1.0, n=1500)
    ref, rate, _ = path[-1]
    assert rate == pytest.approx(1.0, abs=1e-6)
    assert ref == pytest.approx(5.0 + 1.0 * 1499 * DT + 1.0 * DT, abs=0.05)


@settings(max_examples=200, deadline=None)
@given(st.floats(-400, 400), st.floats(-400, 400))
def test_property_arrives_within_limits(start, target):
    path = run(start, target)
    assert path[-1][2]
    lo, hi = min(start, target), max(start, target)
    assert all(lo - 1e-9 <= p[0] <= hi + 1e-9 for p in path)
