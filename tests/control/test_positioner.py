"""The positioner step: a target instead of a duty, with the law's contract."""

from __future__ import annotations

import pytest

from urc.control import positioner
from urc.control.law import AxisState, AxisTuning, Setpoint

TUN = AxisTuning(max_rate_deg_per_s=6.0, min_rate_deg_per_s=1.0, accel_deg_per_s2=10.0,
                 tolerance_deg=0.3, restart_deg=1.0)
KW = dict(lead_s=0.5, band_deg=1.0, still_rate_deg_per_s=0.5, limits_deg=(0.0, 450.0))


def test_a_static_target_is_posted_and_driven_until_within_the_band():
    st, out, target = positioner.step(AxisState(), Setpoint(100.0, seq=1), 50.0, 0.0, 0.0, TUN, **KW)
    assert target == 100.0 and out.duty == 1.0 and st.mode == "driving"
    st, out, target = positioner.step(st, Setpoint(100.0, seq=1), 99.4, 0.0, 1.0, TUN, **KW)
    assert target == 100.0 and out.duty == 0.0 and st.mode == "holding" and st.seq == 1


def test_a_moving_target_is_aimed_ahead_by_the_latency_and_clamped_to_the_limits():
    sp = Setpoint(100.0, 2.0, t_ref_s=0.0, seq=3)
    _st, _out, target = positioner.step(AxisState(), sp, 100.0, 2.0, 1.0, TUN, **KW)
    # 102 now + 0.5 s x 2 deg/s, and the creep lead (0.1) so the error swings round zero
    assert target == pytest.approx(103.1)
    _st, _out, target = positioner.step(AxisState(), Setpoint(449.0, 5.0, seq=4), 449.0, 5.0, 1.0, TUN, **KW)
    assert target == 450.0


def test_no_setpoint_means_stop_and_driven_while_it_still_turns():
    st, out, target = positioner.step(AxisState(mode="driving"), None, 100.0, -3.0, 0.0, TUN, **KW)
    assert target is None and out.duty == -1.0 and st.mode == "driving"
    st, out, target = positioner.step(st, None, 99.0, 0.0, 1.0, TUN, **KW)
    assert target is None and out.duty == 0.0 and st.mode == "idle"


def test_standing_within_the_controllers_own_deadband_has_arrived():
    """A controller stops near its target, not on it (a relay G-5500 within ~1 deg)."""
    st, out, _ = positioner.step(AxisState(), Setpoint(100.0, seq=1), 98.9, 0.0, 0.0, TUN, **KW)
    assert st.mode == "holding" and out.duty == 0.0
    st, out, _ = positioner.step(AxisState(), Setpoint(100.0, seq=1), 98.9, 4.0, 0.0, TUN, **KW)
    assert st.mode == "driving" and out.duty == 1.0   # still on its way: not yet
