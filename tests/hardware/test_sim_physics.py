"""Mechanics of the simulated axes, for every profile (wind off unless stated)."""

from __future__ import annotations

import pytest

from urc.hardware.sim import physics_for
from urc.hardware.sim.params import breakaway_duty
from urc.profiles import PROFILES

from sim_rig import rig  # noqa: F401  (fixture)

# (a stepper profile's axes are driven through its step/dir stage, whose mechanics are
# the stepper model's: tests/hardware/test_sim_stepper.py)
PROFILE_NAMES = [p for p in sorted(PROFILES) if physics_for(p).az.stepper is None]
AXIS_CASES = [(p, a) for p in PROFILE_NAMES for a in ("az", "el")]

SPEED_TOL = 0.05       # relative, full-duty speed vs caps max rate


def _start_opts(axis: str, deg: float) -> dict:
    return {f"start_{axis}_deg": deg}


@pytest.mark.parametrize("profile,axis", AXIS_CASES)
def test_full_duty_speed_matches_max_rate(rig, profile, axis):
    ax = rig(profile).caps.axis(axis)
    r = rig(profile, **_start_opts(axis, ax.min_deg + 1.0))
    r.release_brake(axis)
    r.hw.axis(axis).motor.set_drive(1.0)
    r.run(1.0)
    x0 = r.truth(axis)["deg"]
    span_s = min(4.0, 0.6 * ax.span_deg / ax.max_rate_deg_per_s)
    r.run(span_s)
    rate = (r.truth(axis)["deg"] - x0) / span_s
    assert rate == pytest.approx(ax.max_rate_deg_per_s, rel=SPEED_TOL)
    # and backwards
    r.hw.axis(axis).motor.set_drive(-1.0)
    r.run(1.0)
    x0 = r.truth(axis)["deg"]
    r.run(span_s / 2)
    rate = (r.truth(axis)["deg"] - x0) / (span_s / 2)
    assert rate == pytest.approx(-ax.max_rate_deg_per_s, rel=SPEED_TOL)


@pytest.mark.parametrize("profile,axis", AXIS_CASES)
def test_acceleration_exceeds_caps(rig, profile, axis):
    ax = rig(profile).caps.axis(axis)
    r = rig(profile, **_start_opts(axis, ax.min_deg + 1.0))
    r.release_brake(axis)
    r.hw.axis(axis).motor.set_drive(1.0)
    need_s = 0.9 * ax.max_rate_deg_per_s / ax.accel_deg_per_s2   # at the caps' accel
    t = 0.0
    # (the gear's rate: the antenna only follows once the play is taken up)
    while r.truth(axis)["gear_rate_deg_per_s"] < 0.9 * ax.max_rate_deg_per_s:
        r.run(0.001, 0.001)
        t += 0.001
        assert t < need_s
    assert t < 0.6 * need_s


@pytest.mark.parametrize("profile,axis", AXIS_CASES)
def test_stiction(rig, profile, axis):
    """PWM: no motion well below the breakaway duty, motion at it. Relay: below half
    the smallest level the relay stays off; at the smallest level it moves."""
    ax = rig(profile).caps.axis(axis)
    r = rig(profile, **_start_opts(axis, (ax.min_deg + ax.max_deg) / 2))
    r.release_brake(axis)
    motor = r.hw.axis(axis).motor
    if ax.drive == "pwm":
        d = breakaway_duty(ax)
        low, ok = 0.5 * d, d
    else:
        low, ok = 0.45 * min(ax.drive_levels), min(ax.drive_levels)
    # stir the gears first (play taken up the other way) so history does not matter
    motor.set_drive(-1.0)
    r.run(0.5)
    motor.set_drive(0.0)
    r.run(1.0)
    for sign in (1, -1):
        x0 = r.truth(axis)["deg"]
        motor.set_drive(sign * low)
        r.run(3.0)
        assert r.truth(axis)["deg"] == pytest.approx(x0, abs=1e-9)
        play_deg = physics_for(profile).axis(axis).backlash_deg
        assert r.truth(axis)["gear_deg"] == pytest.approx(x0, abs=play_deg)
    motor.set_drive(ok)
    r.run(3.0)
    moved_deg = r.truth(axis)["deg"] - x0
    assert moved_deg > 0.05
    # (the gear first crosses the play, then carries the antenna)
    backlash_deg = physics_for(profile).axis(axis).backlash_deg
    assert moved_deg + backlash_deg > 0.2 * 3.0 * ax.min_rate_deg_per_s


@pytest.mark.parametrize("profile,axis", AXIS_CASES)
def test_coast_and_currents(rig, profile, axis):
    ax = rig(profile).caps.axis(axis)
    p = physics_for(profile).axis(axis)
    r = rig(profile, **_start_opts(axis, ax.min_deg + 1.0))
    r.release_brake(axis)
    motor = r.hw.axis(axis).motor
    motor.set_drive(1.0)
    r.run(2.0)
    running_a = motor.read_current_a()
    x0, g0 = r.truth(axis)["deg"], r.truth(axis)["gear_deg"]
    motor.set_drive(0.0)
    r.run(3.0)
    t = r.truth(axis)
    assert t["rate_deg_per_s"] == 0.0 and t["gear_rate_deg_per_s"] == 0.0
    coast_deg = t["deg"] - x0
    gear_coast_deg = t["gear_deg"] - g0
    assert 0.0 <= gear_coast_deg < p.backlash_deg + 0.5 * ax.max_rate_deg_per_s
    if ax.drive == "pwm":
        assert gear_coast_deg < 1.0                       # DC gearmotor: fraction of a degree
        assert coast_deg < gear_coast_deg + p.backlash_deg + 1e-9
    else:                                                 # AC on a relay: ~ overshoot_deg
        assert coast_deg == pytest.approx(ax.overshoot_deg, rel=0.5)
    assert motor.read_current_a() == 0.0 or ax.drive == "pwm"
    # a jam stalls the motor: current well above running current
    r.world.inject(axis, "jam")
    motor.set_drive(1.0)
    r.run(0.1)
    assert motor.read_current_a() == pytest.approx(p.stall_current_a)
    assert motor.read_current_a() > 2.0 * running_a


@pytest.mark.parametrize("profile,axis", AXIS_CASES)
def test_end_stop_clamps_and_current_rises(rig, profile, axis):
    ax = rig(profile).caps.axis(axis)
    p = physics_for(profile).axis(axis)
    r = rig(profile, **_start_opts(axis, ax.max_deg - max(2.0, ax.max_rate_deg_per_s)))
    r.release_brake(axis)
    motor = r.hw.axis(axis).motor
    motor.set_drive(1.0)
    r.run(0.5)
    running_a = motor.read_current_a()
    r.run(3.0 + 10.0 / ax.max_rate_deg_per_s)
    t = r.truth(axis)
    if p.hard_max_deg is None:            # free-spinning azimuth (SARCNET)
        assert t["deg"] > ax.max_deg + 5.0
        assert t["rate_deg_per_s"] > 0.9 * ax.max_rate_deg_per_s
        return
    assert t["deg"] == p.hard_max_deg
    assert t["rate_deg_per_s"] == 0.0
    assert t["gear_deg"] <= p.hard_max_deg + p.backlash_deg / 2 + 1e-12
    assert t["current_a"] == pytest.approx(p.stall_current_a)
    assert t["current_a"] > 2.0 * running_a
    motor.set_drive(-1.0)                 # and it backs out
    r.run(1.0)
    assert r.truth(axis)["deg"] < p.hard_max_deg - 0.3 * ax.max_rate_deg_per_s


def test_brake_holds_until_released(rig):
    r = rig("tartu-urc", start_az_deg=100.0)
    ax = r.caps.az
    brake, motor = r.hw.az.brake, r.hw.az.motor
    assert brake is not None and not brake.is_released()
    motor.set_drive(1.0)
    r.run(1.0)
    assert r.truth("az")["deg"] == 100.0
    assert r.truth("az")["current_a"] == pytest.approx(physics_for("tartu-urc").az.stall_current_a)
    brake.set_released(True)
    r.run(ax.brake_release_s - 0.04)
    assert not brake.is_released() and r.truth("az")["deg"] == 100.0
    r.run(0.1)
    assert brake.is_released()
    r.run(1.0)
    assert r.truth("az")["deg"] > 103.0
    brake.set_released(False)            # engaging while driving: it stops dead
    r.run(ax.brake_engage_s + 0.02)
    x = r.truth("az")["deg"]
    assert not brake.is_released()
    r.run(1.0)
    assert r.truth("az")["deg"] == x and r.truth("az")["rate_deg_per_s"] == 0.0


@pytest.mark.parametrize("profile", PROFILE_NAMES)
def test_backlash_load_lags_on_reversal(rig, profile):
    ax = rig(profile).caps.az
    p = physics_for(profile).az
    r = rig(profile, start_az_deg=(ax.min_deg + ax.max_deg) / 2)
    r.release_brake("az")
    motor = r.hw.az.motor
    # DC: the slowest duty that moves; relay: full (slow levels pulse, the load runs on)
    slow = breakaway_duty(ax) if ax.drive == "pwm" else 1.0
    motor.set_drive(slow)                 # slowly forward: gear pushes the load
    r.run(2.0)
    t = r.truth("az")
    assert t["gear_deg"] - t["deg"] == pytest.approx(p.backlash_deg / 2, abs=1e-6)
    motor.set_drive(0.0)
    r.run(1.0)
    motor.set_drive(-slow)                # reverse: the gear crosses the gap first
    g0, l0 = r.truth("az")["gear_deg"], r.truth("az")["deg"]
    while abs(r.truth("az")["deg"] - l0) < 1e-6:
        r.run(0.001, 0.001)
        assert g0 - r.truth("az")["gear_deg"] < p.backlash_deg + 0.05
    gear_travel = g0 - r.truth("az")["gear_deg"]
    assert gear_travel == pytest.approx((g0 - l0) + p.backlash_deg / 2, abs=0.02)
    assert gear_travel > 0.4 * p.backlash_deg
    r.run(2.0)
    t = r.truth("az")
    assert t["deg"] - t["gear_deg"] == pytest.approx(p.backlash_deg / 2, abs=1e-6)


def test_relay_quantisation(rig):
    g4 = rig("g4jnt")
    m = g4.hw.az.motor
    for duty, level in [(0.0, 0.0), (0.12, 0.0), (0.13, 0.25), (0.3, 0.25), (-0.5, -0.25),
                        (0.7, 1.0), (-1.0, -1.0)]:
        m.set_drive(duty)
        assert m.output_level() == level, duty
    y = rig("g5500")
    m = y.hw.el.motor
    for duty, level in [(0.49, 0.0), (0.5, 1.0), (-0.2, 0.0), (-0.9, -1.0)]:
        m.set_drive(duty)
        assert m.output_level() == level, duty


def test_relay_slow_level_is_pulsed(rig):
    r = rig("g4jnt", start_az_deg=100.0)
    ax = r.caps.az
    r.hw.az.motor.set_drive(0.25)
    rates, currents = [], []
    x0 = r.truth("az")["deg"]
    for _ in range(400):                  # 4 s at 10 ms
        r.run(0.01, 0.01)
        rates.append(r.truth("az")["rate_deg_per_s"])
        currents.append(r.hw.az.motor.read_current_a())
    mean_rate = (r.truth("az")["deg"] - x0) / 4.0
    assert 0.8 * ax.min_rate_deg_per_s < mean_rate < 0.5 * ax.max_rate_deg_per_s
    assert max(rates) > 0.8 * ax.max_rate_deg_per_s        # jerky: full-speed bursts ...
    assert sum(1 for v in rates if v == 0.0) > 100           # ... and standstills
    on_share = sum(1 for c in currents if c > 0) / len(currents)
    assert on_share == pytest.approx(0.25, abs=0.05)


def _trajectory(rig, seed: int, step_s: float, profile: str = "berkeley"):
    r = rig(profile, seed=seed, wind=True, start_az_deg=100.0, start_el_deg=40.0)
    out = []
    for i in range(60):
        duty = [0.6, -0.3, 0.05, 0.0, -1.0][i % 5]
        r.hw.az.motor.set_drive(duty)
        r.hw.el.motor.set_drive(-duty)
        r.run(0.2, step_s)
        out.append((r.world.truth(), r.hw.az.sensor.read_deg(), r.hw.el.sensor.read_deg()))
    return out


def test_deterministic_for_a_seed(rig):
    a = _trajectory(rig, 7, 0.02)
    assert a == _trajectory(rig, 7, 0.02)              # bit-identical
    assert a != _trajectory(rig, 8, 0.02)              # wind and noise follow the seed


def test_result_does_not_depend_on_poll_rate(rig):
    a = [t for t, _, _ in _trajectory(rig, 3, 0.02)]
    b = [t for t, _, _ in _trajectory(rig, 3, 0.1)]
    assert a == b


def test_wind_pushes_antenna_within_the_play_only(rig):
    r = rig("berkeley", start_az_deg=100.0)
    p = physics_for("berkeley").az
    r.world.set_wind(True, mean_nm=2 * p.load_static_nm, gust_nm=0.0)
    r.run(2.0)
    t = r.truth("az")
    # the antenna swings across the play; its impact may nudge the gears a little,
    # then the gearbox holds
    assert t["gear_deg"] == pytest.approx(100.0, abs=0.1)
    assert t["deg"] - t["gear_deg"] == pytest.approx(p.backlash_deg / 2)
    x = t["deg"]
    r.run(2.0)
    assert r.truth("az")["deg"] == x
    r.world.set_wind(False)
    r.hw.az.motor.set_drive(0.5)                          # wind off: the gap closes again
    r.run(1.0)
    t = r.truth("az")
    assert t["gear_deg"] - t["deg"] == pytest.approx(p.backlash_deg / 2, abs=1e-6)


def test_ten_minutes_with_wind_in_long_steps_run_on(rig):
    # (how fast the simulator runs is bench/control_bench.py's to say, not a timed test's:
    # a CPU-time bound here failed on a loaded machine)
    r = rig("tartu-urc", wind=True, start_az_deg=10.0, start_el_deg=10.0)
    r.release_brake("az")
    r.release_brake("el")
    r.hw.az.motor.set_drive(0.3)
    r.hw.el.motor.set_drive(0.2)
    r.run(600.0, 1.0)
    assert r.truth("az")["deg"] > 300.0
