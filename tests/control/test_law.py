"""The per-axis control law, tick by tick with synthetic measurements."""

import pytest

from urc.control.law import (KICK_WAIT_S, RELAY_REVERSE_PAUSE_S, AxisTuning, Setpoint, initial_state,
                              step)

PWM = AxisTuning(max_rate_deg_per_s=6.0, min_rate_deg_per_s=0.6, accel_deg_per_s2=12.0,
                 tolerance_deg=0.1, restart_deg=0.25)
BRAKED = AxisTuning(max_rate_deg_per_s=6.0, min_rate_deg_per_s=0.6, accel_deg_per_s2=12.0,
                    tolerance_deg=0.1, restart_deg=0.25, brake=True, brake_release_s=0.15)
RELAY = AxisTuning(max_rate_deg_per_s=6.0, min_rate_deg_per_s=1.5, accel_deg_per_s2=30.0,
                   tolerance_deg=0.9, restart_deg=1.8, drive="relay", drive_levels=(0.25, 1.0),
                   overshoot_deg=0.3)
DT = 0.02


def test_within_tolerance_holds_without_driving():
    st = initial_state(PWM, 10.0)
    st, out = step(st, Setpoint(10.05, seq=1), 10.0, 0.0, DT, PWM)
    assert st.mode == "holding" and out.duty == 0.0


def test_hysteresis_restart_only_beyond_restart_band():
    st = initial_state(PWM, 10.0)
    st, _ = step(st, Setpoint(10.0, seq=1), 10.0, 0.0, DT, PWM)
    for i, meas in enumerate([10.15, 9.8, 10.2]):  # drift inside the band: stay off
        st, out = step(st, Setpoint(10.0, seq=1), meas, (i + 1) * DT, DT, PWM)
        assert out.duty == 0.0 and st.mode == "holding"
    st, out = step(st, Setpoint(10.0, seq=1), 10.4, 1.0, DT, PWM)  # beyond: correct it
    assert st.mode == "driving" and out.duty < 0


def test_drives_towards_target_with_feed_forward_and_min_duty():
    st = initial_state(PWM, 0.0)
    st, out = step(st, Setpoint(50.0, seq=1), 0.0, 0.0, DT, PWM)
    assert out.duty > 0 and out.duty >= PWM.min_duty
    st2, out2 = step(initial_state(PWM, 0.0), Setpoint(-50.0, seq=1), 0.0, 0.0, DT, PWM)
    assert out2.duty < 0


def test_brake_released_before_the_motor_pulls():
    st = initial_state(BRAKED, 0.0)
    t = 0.0
    st, out = step(st, Setpoint(20.0, seq=1), 0.0, t, DT, BRAKED)
    assert out.brake_released and out.duty == 0.0 and st.mode == "releasing"
    while t < BRAKED.brake_release_s - 1e-9:
        t += DT
        st, out = step(st, Setpoint(20.0, seq=1), 0.0, t, DT, BRAKED)
    t += DT
    st, out = step(st, Setpoint(20.0, seq=1), 0.0, t, DT, BRAKED)
    assert out.duty > 0 and out.brake_released


def test_stiction_kick_grows_while_the_axis_stands_still():
    st = initial_state(PWM, 0.0)
    sp = Setpoint(0.5, seq=1)
    duties = []
    t = 0.0
    for _ in range(int(3 * KICK_WAIT_S / DT) + 5):
        st, out = step(st, sp, 0.0, t, DT, PWM)
        duties.append(out.duty)
        t += DT
    assert duties[-1] > duties[3] >= PWM.min_duty * 0.99


def test_relay_uses_levels_and_cuts_early_by_the_coast():
    st = initial_state(RELAY, 0.0)
    st, out = step(st, Setpoint(100.0, seq=1), 0.0, 0.0, DT, RELAY)
    assert out.duty == 1.0  # far: fast
    st, out = step(st, Setpoint(100.0, seq=1), 97.0, DT, DT, RELAY)
    assert out.duty == 0.25  # near: slow (pulsed) level
    st, out = step(st, Setpoint(100.0, seq=1), 99.9, 2 * DT, DT, RELAY)
    assert out.duty == 0.0 and st.mode == "holding"  # within coast + tolerance/2: cut


def test_relay_runs_a_slow_jog_at_its_slow_level_all_the_way():
    """G4JNT: a jog at speed < 1 (API, dashboard) ran at full speed, duty 1.0 (issue
    36.16); a relay has only its levels, so a slow request is the slow (pulsed) one."""
    for speed_frac, duty in ((0.3, 0.25), (0.9, 0.25), (1.0, 1.0)):
        cap = speed_frac * RELAY.max_rate_deg_per_s
        st = initial_state(RELAY, 0.0)
        st, out = step(st, Setpoint(300.0, seq=1, speed_cap_deg_per_s=cap), 0.0, 0.0, DT, RELAY)
        assert out.duty == duty, (speed_frac, out.duty)
        st, out = step(st, Setpoint(300.0, seq=1, speed_cap_deg_per_s=cap), 150.0, DT, DT, RELAY)
        assert out.duty == duty, (speed_frac, "half way", out.duty)


def test_relay_learns_its_coast():
    st = initial_state(RELAY, 0.0)
    before = st.coast_deg[0]
    st, _ = step(st, Setpoint(100.0, seq=1), 97.0, 0.0, DT, RELAY)
    st, out = step(st, Setpoint(100.0, seq=1), 99.55, DT, DT, RELAY)
    assert out.duty == 0.0 and st.cut_deg == pytest.approx(99.55)
    t = 2 * DT
    for meas in (99.8, 100.1, 100.2, 100.2, 100.2):  # it coasts 0.65 deg, then stands
        st, _ = step(st, Setpoint(100.0, seq=1), meas, t, DT, RELAY)
        t += 0.2
    assert st.cut_deg is None
    assert before < st.coast_deg[0] < 0.65


def test_relay_reverses_only_after_a_pause():
    """A command the other way while an AC motor runs: off first, reverse only after
    RELAY_REVERSE_PAUSE_S (plugging a running motor strains gears and contacts)."""
    st = initial_state(RELAY, 50.0)
    st, out = step(st, Setpoint(100.0, seq=1), 50.0, 0.0, DT, RELAY)
    assert out.duty == 1.0
    duties, t = [], DT
    while t < 1.5:
        st, out = step(st, Setpoint(0.0, seq=2), 50.5, t, DT, RELAY)
        duties.append((t, out.duty))
        t += DT
    first_back = next(tt for tt, d in duties if d < 0)
    assert all(d == 0.0 for tt, d in duties if tt < first_back)
    assert first_back - DT >= RELAY_REVERSE_PAUSE_S - 1e-9


def test_moving_setpoint_is_followed_not_held():
    st = initial_state(PWM, 0.0)
    sp = Setpoint(0.0, rate_deg_per_s=2.0, t_ref_s=0.0, seq=1)
    st, out = step(st, sp, 0.0, 0.0, DT, PWM)
    st, out = step(st, sp, 0.0, 0.5, DT, PWM)
    assert st.mode == "driving" and out.duty > 0


def test_none_setpoint_switches_off():
    st = initial_state(PWM, 0.0)
    st, out = step(st, Setpoint(50.0, seq=1), 0.0, 0.0, DT, PWM)
    st, out = step(st, None, 1.0, DT, DT, PWM)
    assert out.duty == 0.0 and not out.brake_released and st.mode == "idle"
