"""The per-axis step for an axis whose inner loop an external controller closes.

The bridge backend drives a controller the station already owns (GS-232, Easycomm,
SPID, rotctld): urc does not switch its motors, it posts targets. This step replaces
:func:`urc.control.law.step` for such an axis and keeps the same contract, so the rotator
service treats it like any other axis (routes, holding, faults, the guard):

* ``target_deg``: where the controller is told to go: the setpoint's target, aimed
  ahead by the command latency while it moves (a track) plus the axis' creep lead (at
  most half the band: the controller rounds to its resolution and holds within its own
  deadband, so a target a little ahead makes the error swing round zero instead of
  lagging; GS-232 pass 0.63 -> 0.42 deg RMS, bench/bridge_bench.py), clamped to the
  limits.
* ``duty``: a notional drive direction (+-1 while the axis is on its way or still
  turning, 0 when it holds), so the guard and the fault monitor see "driven" exactly
  when the controller behind is moving the antenna.

Pure: state in, state out.
"""

from __future__ import annotations

import math

from .evolve import evolve
from .law import OFF, AxisOutput, AxisState, AxisTuning, Setpoint


def step(st: AxisState, sp: Setpoint | None, meas_deg: float, rate_deg_per_s: float, now_s: float,
         tun: AxisTuning, *, lead_s: float, band_deg: float, still_rate_deg_per_s: float,
         limits_deg: tuple[float, float]) -> tuple[AxisState, AxisOutput, float | None]:
    """One tick: (state, output, target to post or None = stop).

    ``band_deg``: arrived within this error (the tolerance, at least the controller's
    resolution: a GS-232 reports whole degrees). ``lead_s``: how far ahead a moving
    target is aimed (the link's measured command latency).
    """
    turning = abs(rate_deg_per_s) > still_rate_deg_per_s
    if sp is None:
        # told to stop: it still counts as driven while the controller brings it to rest
        duty = math.copysign(1.0, rate_deg_per_s) if turning else 0.0
        st = evolve(st, mode="driving" if turning else "idle", ref_deg=meas_deg,
                     ref_rate_deg_per_s=rate_deg_per_s, arrived=False)
        return st, (AxisOutput(duty, False, True) if duty else OFF), None
    lo, hi = limits_deg
    now_target = min(max(sp.target_at(now_s), lo), hi)
    aim = now_target if sp.rate_deg_per_s == 0.0 else \
        sp.target_at(now_s + lead_s) + math.copysign(min(tun.creep_lead_deg, 0.5 * band_deg), sp.rate_deg_per_s)
    aim = min(max(aim, lo), hi)
    error_deg = now_target - meas_deg
    # within the band the controller's own loop finishes the move (and its overshoot);
    # standing still, its own deadband counts too (it stops near its target, not on it)
    settle_band_deg = max(tun.restart_deg, band_deg + 2.0 * (band_deg - tun.tolerance_deg))
    there = abs(error_deg) <= (band_deg if turning else max(band_deg, settle_band_deg))
    if st.seq != sp.seq:
        st = evolve(st, seq=sp.seq, arrived=False, hold_since_s=now_s)
    if there and sp.rate_deg_per_s == 0.0:
        if st.mode != "holding":
            st = evolve(st, hold_since_s=now_s)
        st = evolve(st, mode="holding", arrived=True, ref_deg=meas_deg, ref_rate_deg_per_s=0.0)
        return st, OFF, aim
    direction = rate_deg_per_s if turning else (error_deg or sp.rate_deg_per_s)
    st = evolve(st, mode="driving", ref_deg=meas_deg, ref_rate_deg_per_s=rate_deg_per_s)
    if there:  # following a moving target within the band: on its way, not pushing
        return st, AxisOutput(math.copysign(1.0, direction) if turning else 0.0, False, turning), aim
    return st, AxisOutput(math.copysign(1.0, direction) if direction else 0.0, False, True), aim
