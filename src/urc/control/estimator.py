"""Position estimate for a noisy sensor (a pot, a compass): an alpha-beta filter that is
safe for any tick interval.

Pure: ``alpha_beta(estimate, reading, dt_s, limits) -> estimate``. It smooths without
the lag at constant speed that a plain moving average adds. Hand-written (three lines of
arithmetic) because the library filters assume a fixed interval, and the interval here
is whatever the loop really took: a late tick, then ticks microseconds apart, or a
stall of seconds. The textbook form divides the residual by the interval to correct the
speed, so ticks microseconds apart turn sensor noise into 10^3..10^6 deg estimates.
"""

from __future__ import annotations

from dataclasses import dataclass

from .evolve import construct

#: gains: position share of the residual, speed share (per nominal period)
FILTER_ALPHA = 0.3
FILTER_BETA = 0.03
#: the speed estimate may exceed the axis' top speed by this factor (noise, gusts),
#: never more: a faster estimate is no physical motion
RATE_SLACK = 1.5
#: after a gap this many nominal periods long the prediction is no longer trusted:
#: the estimate restarts at the reading
RESTART_PERIODS = 10


@dataclass(frozen=True)
class FilterLimits:
    period_s: float             # the loop's nominal tick interval
    max_rate_deg_per_s: float   # the axis' top speed


@dataclass(frozen=True)
class Estimate:
    pos_deg: float
    rate_deg_per_s: float = 0.0


def alpha_beta(est: Estimate, reading_deg: float, dt_s: float, lim: FilterLimits) -> Estimate:
    """One filter update with the reading taken ``dt_s`` after the previous one."""
    if not dt_s > 0.0:
        # no time has passed: the reading is one more sample of the same position;
        # it says nothing about speed
        return Estimate(est.pos_deg + FILTER_ALPHA * (reading_deg - est.pos_deg), est.rate_deg_per_s)
    if dt_s > RESTART_PERIODS * lim.period_s:
        # a long gap (a stalled host): extrapolating the speed over it is a guess
        return Estimate(reading_deg, 0.0)
    pred = est.pos_deg + est.rate_deg_per_s * dt_s
    resid = reading_deg - pred
    # the speed correction is scaled to the nominal period, never to a shorter interval:
    # over microseconds the residual is sensor noise, not speed
    rate = est.rate_deg_per_s + FILTER_BETA * resid / max(dt_s, lim.period_s)
    cap = RATE_SLACK * lim.max_rate_deg_per_s
    # (construct: every tick of a noisy sensor, see urc.control.evolve)
    return construct(Estimate, pos_deg=pred + FILTER_ALPHA * resid, rate_deg_per_s=min(max(rate, -cap), cap))
