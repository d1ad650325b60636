"""The alpha-beta estimate for noisy sensors stays physical for any tick interval."""

import random

import pytest

from urc.control.estimator import Estimate, FilterLimits, alpha_beta

LIM = FilterLimits(period_s=0.02, max_rate_deg_per_s=6.0)


def run(intervals_s, noise_deg=0.2, rate_deg_per_s=3.0, seed=1):
    rng = random.Random(seed)
    est, t, worst = Estimate(0.0), 0.0, 0.0
    for dt in intervals_s:
        t += dt
        truth = rate_deg_per_s * t
        est = alpha_beta(est, truth + rng.gauss(0.0, noise_deg), dt, LIM)
        worst = max(worst, abs(est.pos_deg - truth))
        assert abs(est.rate_deg_per_s) <= 1.5 * LIM.max_rate_deg_per_s
    return worst


@pytest.mark.parametrize("burst_dt_s", [0.0, 1e-9, 1e-6, 1e-4])
def test_catch_up_ticks_microseconds_apart_stay_within_the_noise(burst_dt_s):
    """A late tick then 25 catch-up ticks microseconds apart (the loop after a stall):
    the textbook filter divides the residual by dt and reaches 1e3..1e6 deg."""
    intervals = [0.02] * 200 + [0.5] + [burst_dt_s] * 25 + [0.02] * 200
    assert run(intervals) < 1.5


def test_long_gaps_restart_at_the_reading():
    """After seconds without a reading the estimate does not extrapolate a stale speed."""
    intervals = [0.02] * 100 + [5.0] + [0.02] * 5 + [30.0] + [0.02] * 50
    assert run(intervals) < 1.5


def test_random_intervals_never_leave_the_physical_range():
    rng = random.Random(7)
    intervals = [rng.choice([0.0, 1e-7, 1e-3, 0.02, 0.02, 0.02, 0.1, 0.4, 3.0]) for _ in range(3000)]
    assert run(intervals, rate_deg_per_s=1.0) < 2.0
