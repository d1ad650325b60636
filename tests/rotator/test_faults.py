"""One test per fault kind: the motor stops, the fault latches with a reason, shows in
status, refuses motion, and clears only on an explicit command."""

import pytest
from conftest import gpio_hardware

from urc.errors import CommandRejected

#: the sensor and mechanical faults injected into the simulator reach the gpio backend's
#: parts when it runs on emulated pins and chips (issue 8): the same tests run on both
BACKENDS = ["sim", "gpio"]


def on(bench, backend, profile, **config):
    if backend == "gpio":
        config["hardware"] = gpio_hardware(profile)
    b = bench(profile, **config)
    assert b.rot.hw.backend == backend
    return b


def start_moving(b, az=200.0, el=None):
    b.rot.goto(az, b.rot.status().el_deg if el is None else el)
    b.run(1.5)
    assert b.rot.status().moving


def assert_latched(b, kind, axis="az"):
    s = b.rot.status()
    kinds = [(f.kind, f.axis) for f in s.faults]
    assert (kind, axis) in kinds, f"expected {kind} on {axis}, got {s.faults}"
    assert all(f.reason for f in s.faults)
    # the motors are off and stay off
    assert s.az.duty == 0.0 and s.el.duty == 0.0
    with pytest.raises(CommandRejected, match="fault"):
        b.rot.goto(10.0, 10.0)
    return s


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("profile", ["tartu-urc", "berkeley", "bigras"])
def test_stall_when_jammed(bench, profile, backend):
    b = on(bench, backend, profile, faults={"overcurrent_a": 100.0})
    start_moving(b)
    b.world.inject("az", "jam")
    b.run(5.0)
    s = assert_latched(b, "stall")
    assert "without moving" in s.faults[0].reason


def test_overcurrent_when_jammed(bench):
    b = bench("berkeley", faults={"overcurrent_a": 2.0})
    start_moving(b)
    assert abs(b.rot.status().az.current_a) < 2.0, "running current must be below the threshold"
    b.world.inject("az", "jam")
    b.run(1.0)  # well before the stall detector would fire
    assert_latched(b, "overcurrent")


@pytest.mark.parametrize("backend", BACKENDS)
def test_runaway_with_motor_off(bench, backend):
    b = on(bench, backend, "berkeley")  # no brake to hold it (tartu's brake would)
    b.world.inject("az", "runaway", duty=0.6)  # a welded relay
    b.run(5.0)
    s = assert_latched(b, "runaway")
    assert "motor off" in s.faults[0].reason


@pytest.mark.parametrize("backend", BACKENDS)
def test_runaway_wrong_way(bench, backend):
    b = on(bench, backend, "berkeley")
    b.world.inject("az", "reverse_wiring")
    b.rot.goto(100.0, 0.0)
    b.run(5.0)
    s = assert_latched(b, "runaway")
    assert "wrong way" in s.faults[0].reason


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("profile", ["tartu-urc", "berkeley"])
def test_sensor_stuck_is_told_apart_from_a_stall_by_current(bench, profile, backend):
    b = on(bench, backend, profile, faults={"overcurrent_a": 100.0})
    start_moving(b)
    b.world.inject("az", "sensor_stuck")
    b.run(5.0)
    if backend == "gpio" and profile == "berkeley":
        # its PWM+DIR boards have no current sense: as on iron, a stuck AS5600 register
        # cannot be told from a jam (tartu-urc's VNH5019 CS pins are on an MCP3008)
        s = assert_latched(b, "stall")
        assert b.rot.hw.az.motor.read_current_a() == 0.0
        return
    s = assert_latched(b, "sensor_stuck")
    assert "running current" in s.faults[0].reason


@pytest.mark.parametrize("backend", BACKENDS)
def test_sensor_jump(bench, backend):
    b = on(bench, backend, "tartu-urc")
    start_moving(b)
    b.world.inject("az", "sensor_jump", deg=20.0)
    b.run(0.5)
    assert_latched(b, "sensor_jump")


@pytest.mark.parametrize("backend", BACKENDS)
def test_sensor_dead(bench, backend):
    b = on(bench, backend, "berkeley")
    b.world.inject("el", "sensor_dead")
    b.run(0.5)
    s = assert_latched(b, "sensor_dead", "el")
    assert "unreadable" in s.faults[0].reason


@pytest.mark.parametrize("backend", BACKENDS)
def test_sensor_out_of_range(bench, backend):
    b = on(bench, backend, "tartu-urc")
    b.world.inject("el", "sensor_jump", deg=-200.0)  # reads -110 deg: impossible
    b.run(0.5)
    kinds = {f.kind for f in b.rot.status().faults}
    assert kinds & {"sensor_range", "sensor_jump"}
    assert "sensor_range" in kinds or "sensor_jump" in kinds


@pytest.mark.parametrize("backend", BACKENDS)
def test_limit_switch(bench, backend):
    b = on(bench, backend, "bigras")
    start_moving(b)
    b.world.inject("az", "limit_switch", which="max")
    b.run(0.5)
    assert_latched(b, "limit_switch")
    b.rot.clear_faults()
    b.run(0.1)
    # still pressed: moving further towards it is refused, moving away is allowed
    with pytest.raises(CommandRejected, match="limit switch"):
        b.rot.move("az", +1, 1.0)
    b.rot.move("az", -1, 1.0)


def test_watchdog(bench):
    """Late ticks stop the motors; only stalls that keep happening latch (see test_loop)."""
    b = bench("tartu-urc")
    b.rot.note_lateness(0.01)
    b.run(0.1)
    assert not b.rot.status().faults and not b.rot.status().loop["stalls"]
    for _ in range(b.rot.timing.latch_stalls):
        b.rot.note_lateness(2.0)
    b.run(0.1)
    assert_latched(b, "watchdog", None)


@pytest.mark.parametrize("backend", BACKENDS)
def test_clear_faults_restores_control(bench, backend):
    b = on(bench, backend, "berkeley")
    b.world.inject("el", "sensor_dead")
    b.run(0.5)
    assert b.rot.status().faults
    b.world.clear("el")
    b.run(1.0)
    assert b.rot.status().faults, "faults must latch until cleared explicitly"
    b.rot.clear_faults()
    b.run(0.1)
    assert not b.rot.status().faults
    b.rot.goto(50.0, 20.0)
    s = b.settle()
    assert s.az_deg == pytest.approx(50.0, abs=0.3) and not s.faults


@pytest.mark.parametrize("profile", ["g4jnt", "g5500", "sarcnet-mini"])
def test_catch_up_ticks_keep_the_noisy_estimate_physical(bench, profile):
    """Issue 12.1: a late tick, then catch-up ticks microseconds apart. The estimate of a
    noisy sensor (pot, compass) stays with the antenna (it reached 1e3..1e6 deg), and
    nothing is driven from anything else."""
    b = bench(profile)
    start_moving(b, az=250.0)
    for _ in range(3):
        b.clock.advance(0.3)
        b.rot.tick()
        for _ in range(30):
            b.clock.advance(1e-6)
            s = b.rot.tick()
            for axis in ("az", "el"):
                ax = getattr(s, axis)
                assert abs(ax.pos_deg - b.truth(axis)) < 3.0, (axis, ax.pos_deg, b.truth(axis))
                assert abs(ax.rate_deg_per_s) < 2 * b.rot.caps.axis(axis).max_rate_deg_per_s
        b.run(0.5)
    assert not b.rot.status().faults


def test_an_implausible_estimate_is_a_sensor_fault(bench):
    """Whatever corrupts the estimate, the law never drives from it: sensor fault, motors off."""
    b = bench("g4jnt")
    start_moving(b, az=250.0)
    b.rot.axes["az"].meas_deg += 40.0  # the estimate far from any reading
    b.run(0.1)
    s = assert_latched(b, "sensor_range")
    assert "estimate" in s.faults[0].reason
    assert abs(s.az.pos_deg - b.truth("az")) < 3.0  # shows the reading, not the wild estimate
