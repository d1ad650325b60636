"""The BTS7960 current sense against Infineon's data sheet (Rev. 1.1, §4.4.6-4.4.9),
with the IBT-2's IS pins tied (two 1 kOhm: 500 Ohm) as docs/hardware.md wires them.

The expected values are worked out here from the data sheet's numbers, typed in this
file, not taken from urc's table:
  k_ILIS (x 10^3, min/typ/max): 5 A 3/8.5/14, 15 A 5/8.5/12, 30 A 6/8.5/11
  I_IS(lim) 4/4.5/7 mA; I_ISL <= 1 uA (IN low); I_ISH <= 200 uA (high side on, 0 A)
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from urc.assembly import build_rotator
from urc.cli import with_emulation
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.hardware.drivers.bts7960_sense import Bts7960Sense
from urc.hardware.gpio.emulate_bts7960 import EmulatedBts7960Is
from urc.rotator.loop import run_virtual

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
NODE_OHMS = 1000.0 / 2          # R_IS and L_IS tied


class Pwm:
    def __init__(self, duty=0.0):
        self.duty = duty

    def read_back(self):
        return self.duty


def part(load_a=0.0, r=0.0, back=0.0, **kw):
    """The emulated IS with RPWM at ``r`` and LPWM at ``back``."""
    rp, lp = Pwm(r), Pwm(back)
    load = {"a": load_a}
    return EmulatedBts7960Is(rp, lp, lambda: load["a"], **kw), rp, lp, load


@pytest.mark.parametrize("load_a, grade, k", [
    (5.0, "min", 3000), (5.0, "typ", 8500), (5.0, "max", 14000),
    (15.0, "min", 5000), (15.0, "typ", 8500), (15.0, "max", 12000),
    (30.0, "min", 6000), (30.0, "typ", 8500), (30.0, "max", 11000),
])
def test_the_emulated_is_gives_the_load_current_over_k_ilis_of_table_4_4_6(load_a, grade, k):
    for duties in ((1.0, 0.0), (0.0, 1.0)):   # whichever side drives, its IS flows through both resistors
        p, *_ = part(load_a, *duties, grade=grade, lim_grade="max")
        assert p.volts() == pytest.approx(load_a / k * NODE_OHMS, rel=1e-9)


def test_the_emulated_is_follows_the_rest_of_the_table():
    # 4.4.7: the sense current never exceeds I_IS(lim): 60 A on a low-k chip would be 10 mA
    p, *_ = part(60.0, r=1.0, grade="min")
    assert p.volts() == pytest.approx(4.5e-3 * NODE_OHMS)
    # 4.4.7 in a fault: I_IS(lim) whatever the load, per column
    for lim_grade, ma in (("min", 4.0), ("typ", 4.5), ("max", 7.0)):
        p, *_ = part(0.5, r=1.0, lim_grade=lim_grade)
        p.fault = True
        assert p.volts() == pytest.approx(ma * 1e-3 * NODE_OHMS)      # 2.0 / 2.25 / 3.5 V
    # 4.4.9: 200 uA with the high side on at no load
    p, *_ = part(0.0, r=1.0, offset_a=200e-6)
    assert p.volts() == pytest.approx(0.1)
    # 4.4.8: both INs low, 1 uA leakage from each half
    p, *_ = part(3.0, leak_a=1e-6)
    assert p.volts() == pytest.approx(2 * 1e-6 * NODE_OHMS)
    with pytest.raises(ValueError):
        part(0.0, offset_a=300e-6)        # more than 4.4.9 allows


def test_the_emulated_is_senses_only_during_the_on_time():
    """IS senses the driven high side while it conducts: the filtered node reads the
    duty times the on-time value (the fault too: a fixed 3 V threshold never saw it)."""
    p, rp, _, _ = part(5.0, r=0.3)
    assert p.volts() == pytest.approx(0.3 * 5.0 / 8500 * NODE_OHMS)
    p.fault = True
    assert p.volts() == pytest.approx(0.3 * 4.5e-3 * NODE_OHMS)           # 0.675 V
    assert p.volts() < 3.0


class Clock:
    t = 0.0

    def now_s(self):
        return self.t


def sensed(p, clock):
    return Bts7960Sense(type("V", (), {"read_volts": lambda self: p.volts()})(), 500 / 8500, clock.now_s)


def read_every(cs, clock, seconds, tick_s=0.02):
    """Read as the loop does, once per tick; the readings."""
    out = []
    for _ in range(round(seconds / tick_s)):
        clock.t += tick_s
        out.append(cs.read_current_a())
    return out


@pytest.mark.parametrize("duty", [0.1, 0.3, 0.5, 0.66, 1.0])
def test_the_driver_sees_the_fault_and_the_current_at_any_duty(duty):
    clock = Clock()
    # the least favourable chip for a false fault: k_ILIS min, I_ISH max, 5 A
    p, rp, _, _ = part(5.0, grade="min", offset_a=200e-6)
    cs = sensed(p, clock)
    rp.duty = duty
    cs.note_duty(duty)
    clock.t = 1.0
    amps = cs.read_current_a()
    assert cs.fault is None
    assert amps == pytest.approx((5.0 / 3000 + 200e-6) * 8500)   # the same at every duty
    # the least favourable chip for a missed fault: I_IS(lim) min, 4 mA
    p.lim_a, p.fault = 4e-3, True
    read_every(cs, clock, 0.24)
    assert cs.fault is None                       # not yet: it must last 0.25 s
    read_every(cs, clock, 0.02)
    assert cs.fault and "signals a fault" in cs.fault
    # a typical chip at 5 A reads 5 A
    p2, rp2, _, _ = part(5.0, r=duty)
    cs2 = sensed(p2, clock)
    cs2.note_duty(duty)
    clock.t = 2.0
    assert cs2.read_current_a() == pytest.approx(5.0)


def test_below_the_duty_floor_the_current_is_unknown_and_no_fault_is_called():
    """At 5 % duty the reading is 5 % of the on-time value: an offset of a few mV the
    zero missed would read as amperes. The current is NaN (unknown), and a fault level
    neither counts towards a fault nor drains the count."""
    clock = Clock()
    p, rp, _, _ = part(5.0, grade="min", offset_a=200e-6, lim_grade="min")
    cs = sensed(p, clock)
    rp.duty = 1.0
    cs.note_duty(1.0)
    cs.read_current_a()
    p.fault = True
    read_every(cs, clock, 0.2)                 # 0.2 s of the 0.25 s at fault level
    assert cs.fault is None and cs.fault_count_s == pytest.approx(0.2)
    rp.duty = 0.05
    cs.note_duty(0.05)
    readings = read_every(cs, clock, 1.0)
    assert all(math.isnan(a) for a in readings[2:]) and cs.fault is None
    # the first reading after the fall is divided by the filter's memory of 100 %: low,
    # it drains one tick; the 49 unknown ones after it leave the count alone
    assert cs.fault_count_s == pytest.approx(0.18)
    rp.duty = 1.0
    cs.note_duty(1.0)
    read_every(cs, clock, 0.06)
    assert cs.fault is None
    read_every(cs, clock, 0.02)
    assert cs.fault and "signals a fault" in cs.fault


def test_a_fixed_offset_is_zeroed_while_nothing_is_driven_not_divided_by_the_duty():
    """16 mV at the ADC input whatever the drive (ADC offset, clamp leakage, I_ISL):
    divided by 1 % duty it read 1.6 V, a fault and 27 A. urc learns it with both sides
    off and takes it off every reading."""
    clock = Clock()
    state = {"on_a": 3.0 / 8500, "duty": 0.0}           # 3 A on a typical chip

    class Input:
        def read_volts(self):
            return 0.016 + state["duty"] * state["on_a"] * NODE_OHMS
    cs = Bts7960Sense(Input(), 500 / 8500, clock.now_s)
    cs.note_duty(0.0)
    assert read_every(cs, clock, 0.6)[-1] == 0.0          # nothing driven: 0 A
    for duty in (0.12, 0.3, 1.0):
        state["duty"] = duty
        cs.note_duty(duty)
        assert read_every(cs, clock, 0.3)[-1] == pytest.approx(3.0, rel=2e-3)
    state["duty"] = 0.01
    cs.note_duty(0.01)
    readings = read_every(cs, clock, 0.5)
    assert math.isnan(readings[-1]) and cs.fault is None
    assert cs.zero_v == pytest.approx(0.016, rel=1e-2)


def test_a_falling_duty_is_not_read_through_the_filters_memory():
    """The RC filter (10.5 kOhm, 1 uF) still holds the last duty's reading for several
    time constants after the duty falls; dividing it by the new duty would read up to
    ten times the current (a false fault or overcurrent). The divisor is the filtered
    duty modelled at both ends of the filter's tolerance, the larger: whichever end the
    real filter sits at, the reading is never high, and right once it settles."""
    for tau_s in (0.75 * 10.5e-3, 1.25 * 10.5e-3):
        clock = Clock()
        on_v = 20.0 / 8500 * NODE_OHMS                  # 20 A at full duty: 1.18 V, no fault
        filt = {"v": 0.0, "duty": 0.0, "t": 0.0}

        class Filtered:
            def read_volts(self):
                dt = clock.t - filt["t"]
                filt["v"] += (filt["duty"] * on_v - filt["v"]) * (1.0 - math.exp(-dt / tau_s))
                filt["t"] = clock.t
                return filt["v"]
        cs = Bts7960Sense(Filtered(), 500 / 8500, clock.now_s)
        readings = []
        for duty in (1.0, 0.1, 0.7, 0.12, 1.0):
            cs.read_current_a()                      # the filter's input held until now
            filt["duty"] = duty
            cs.note_duty(duty)
            got = read_every(cs, clock, 0.2, tick_s=0.002)
            readings += got
            assert got[-1] == pytest.approx(20.0, rel=1e-3)
        assert max(readings) <= 20.0 * (1 + 1e-9) and cs.fault is None
    filt["duty"] = 0.0
    cs.note_duty(0.0)
    assert read_every(cs, clock, 0.2)[-1] == 0.0 and cs.fault is None   # nothing driven: no current
    cs.volts = type("Stuck", (), {"read_volts": lambda self: 2.5})()     # fault level, no IN high
    read_every(cs, clock, 0.24)
    assert cs.fault is None
    read_every(cs, clock, 0.02)
    assert cs.fault and "IS wiring" in cs.fault


def test_a_starting_current_passes_but_a_held_fault_level_does_not():
    """BIG-RAS motors draw up to 10 A starting: 10 A / 3000 + 200 uA = 3.5 mA on the
    least favourable chip, above the 3.2 mA fault level, for a moment. A fault holds
    IS at I_IS(lim) for as long as it lasts."""
    clock = Clock()
    p, rp, _, load = part(10.0, r=1.0, grade="min", offset_a=200e-6)
    p.grade = "min"
    cs = sensed(p, clock)
    cs.note_duty(1.0)
    for k in range(10):                               # 10 A for 0.2 s, read every 20 ms
        clock.t = 1.0 + 0.02 * k
        cs.read_current_a()
        assert cs.fault is None
    load["a"] = 3.0                                   # running: the count drains
    read_every(cs, clock, 0.2)
    assert cs.fault is None and cs.fault_count_s == 0.0
    p.fault = True                                    # overtemperature from now on
    for k in range(14):
        clock.t += 0.02
        cs.read_current_a()
        assert (cs.fault is not None) == (0.02 * (k + 1) >= 0.25)


class WholePercentPwm(Pwm):
    """gpiozero 2.0.1's LGPIOPin: lgpio gets int(duty x 100), and reads that back."""

    def write_duty(self, duty):
        self.duty = int(duty * 100) / 100


def test_the_sense_divides_by_the_duty_the_pwm_really_makes():
    """On software PWM a 15.9 % drive runs at 15 %; divided by 15.9 % the current would
    read 6 % low (and a fault nearer its level). At 1.9 % (runs at 1 %) it is unknown."""
    from urc.hardware.drivers import Bts7960Motor
    clock = Clock()
    rp, lp = WholePercentPwm(), WholePercentPwm()
    p = EmulatedBts7960Is(rp, lp, lambda: 3.0, lim_grade="min")
    cs = sensed(p, clock)
    motor = Bts7960Motor("az", rp, lp, current=cs)
    motor.set_drive(0.159)
    assert rp.duty == 0.15
    clock.t = 1.0
    assert motor.read_current_a() == pytest.approx(3.0)
    p.fault = True
    read_every(motor, clock, 0.26)
    assert "signals a fault" in motor.driver_fault()
    motor.set_drive(0.019)
    assert rp.duty == 0.01
    read_every(motor, clock, 0.1)
    assert math.isnan(motor.read_current_a())


def test_the_emulated_filter_lags_and_a_duty_drop_is_not_read_as_a_current_spike():
    """The emulated RC (10 ms) still holds most of a full-duty reading 5 ms after the
    duty drops to 10 %; the driver divides by the window's largest duty, so the current
    it reads never jumps to about nine times the truth (which a stall or overcurrent
    verdict would see)."""
    from urc.hardware.drivers import Bts7960Motor
    clock = Clock()
    rp, lp = WholePercentPwm(), WholePercentPwm()
    p = EmulatedBts7960Is(rp, lp, lambda: 3.0, now_s=clock.now_s)
    motor = Bts7960Motor("az", rp, lp, current=sensed(p, clock))
    motor.set_drive(1.0)
    for k in range(20):
        clock.t = 0.01 * k
        motor.read_current_a()
    assert p.volts() == pytest.approx(3.0 / 8500 * NODE_OHMS, rel=1e-3)      # settled
    motor.set_drive(0.1)
    clock.t = 0.195
    assert p.volts() == pytest.approx(3.0 / 8500 * NODE_OHMS * (0.1 + 0.9 * 2.718281828 ** -0.5), rel=1e-3)
    readings = []
    for k in range(15):
        clock.t = 0.2 + 0.01 * k
        readings.append(motor.read_current_a())
    assert max(readings) <= 3.0 * 1.001                       # low for a while, never high
    assert readings[-1] == pytest.approx(3.0, rel=0.001)       # past the window: the truth again


def emulated_bigras(tmp_path: Path):
    data = with_emulation(load_config(EXAMPLES / "bigras.toml")).to_dict()
    data["hardware"]["sim"] = {"wind": False}
    data["hardware"]["gpio"]["az"]["current_sense_channel"] = 0
    data["hardware"]["gpio"]["el"]["current_sense_channel"] = 1     # the same ADS1115
    # no overcurrent rule in reach (as on iron with faults.overcurrent_a unset): the fault
    # signal alone must stop the axes (emulated, the rule would trip at 80 % of stall)
    data.setdefault("faults", {})["overcurrent_a"] = 1000.0
    clock = VirtualClock(1000.0)
    return build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False, fast_virtual=True), clock


def test_emulated_bigras_reads_its_is_and_stops_on_the_fault_signal_at_low_duty(tmp_path):
    rot, clock = emulated_bigras(tmp_path)
    is_part = rot.hw.gpio.emulation["az current sense"]
    motor = rot.hw.az.motor
    motor.set_drive(0.3)
    for k in range(10):
        clock.advance(0.02)
        rot.hw.heartbeat.write(k % 2 == 0)       # the safety relay keeps the bridge powered
        rot.hw.poll(clock.now_s())
    truth_a = rot.hw.world.axes["az"].current_a()
    assert truth_a > 0.1
    assert motor.read_current_a() == pytest.approx(truth_a, rel=0.02)   # typical chip, no offset
    assert motor.driver_fault() is None
    is_part.fault = True                                   # overtemperature, at 30 % duty
    for _ in range(20):                                    # read as the loop does, 0.4 s
        clock.advance(0.02)
        motor.read_current_a()
    assert "signals a fault" in motor.driver_fault()
    motor.set_drive(0.0)
    is_part.fault = False
    # and through the loop: a move, then the fault signal latches a driver fault
    rot.goto_az(rot.status().az_deg + 40.0)
    run_virtual(rot, clock, 2.0)
    assert not rot.status().faults
    is_part.fault = True
    s = run_virtual(rot, clock, 0.5)
    assert [f.axis for f in s.faults if f.kind == "driver"] == ["az"]


def test_least_favourable_chips_fly_a_whole_goto_without_a_false_fault(tmp_path):
    """k_ILIS at its minimum and I_ISH at its maximum on both axes (the highest IS for a
    given current), through starts, reversals and stops of the real loop."""
    rot, clock = emulated_bigras(tmp_path)
    for axis in ("az", "el"):
        is_part = rot.hw.gpio.emulation[f"{axis} current sense"]
        is_part.grade, is_part.offset_a = "min", 200e-6
    rot.goto(60.0, 40.0)
    s = run_virtual(rot, clock, 120.0, until=lambda s: not s.moving)
    assert not s.faults
    assert abs(s.sim_truth["az"]["deg"] - 60.0) < 1.0 and abs(s.sim_truth["el"]["deg"] - 40.0) < 1.0
    rot.goto(10.0, 5.0)                                  # and back: the other side of each bridge
    s = run_virtual(rot, clock, 120.0, until=lambda s: not s.moving)
    assert not s.faults and abs(s.sim_truth["az"]["deg"] - 10.0) < 1.0


def drive_emulated(duty_at, seconds, *, tick_s=0.02, fault=True, load_a=3.0, **kw):
    """The emulated part (filter lag on) behind a Bts7960Motor, the drive set each tick
    to ``duty_at(t)`` and the current read once per tick, as the loop does. Returns the
    sense, the readings and the time of the first fault (None: never)."""
    from urc.hardware.drivers import Bts7960Motor
    clock = Clock()
    rp, lp = WholePercentPwm(), WholePercentPwm()
    p = EmulatedBts7960Is(rp, lp, lambda: load_a, now_s=clock.now_s, **kw)
    p.fault = fault
    cs = sensed(p, clock)
    motor = Bts7960Motor("az", rp, lp, current=cs)
    readings, first_fault_s = [], None
    for k in range(round(seconds / tick_s)):
        clock.t = k * tick_s
        readings.append(motor.read_current_a())
        if cs.fault and first_fault_s is None:
            first_fault_s = clock.t
        motor.set_drive(duty_at(clock.t))
    return cs, readings, first_fault_s


def test_a_fault_in_short_drive_bursts_is_called():
    """0.2 s bursts at 23 % duty, 0.3 s off: each burst holds IS at I_IS(lim) (4 mA, the
    lowest) for less than the 0.25 s hold, and the gaps must not wipe what was seen."""
    _, _, first = drive_emulated(lambda t: 0.23 if (t % 0.5) < 0.2 else 0.0, 10.0, lim_grade="min")
    assert first is not None and first < 2.0
    # and the same bursts without a fault, on the chip that reads highest: none
    cs, readings, first = drive_emulated(lambda t: 0.23 if (t % 0.5) < 0.2 else 0.0, 10.0,
                                         fault=False, load_a=5.0, grade="min", offset_a=200e-6)
    assert first is None and max(r for r in readings if r == r) < 5.0 / 3000 * 8500 * 1.2


def test_a_fault_under_a_jittering_duty_is_called():
    """The duty alternating 50 % / 38 % every tick: the filter follows within a tick,
    so the window's largest duty as the divisor read the fault below its level."""
    _, _, first = drive_emulated(lambda t: 0.5 if round(t / 0.02) % 2 else 0.38, 3.0, lim_grade="min")
    assert first is not None and first < 0.5
    cs, readings, first = drive_emulated(lambda t: 0.5 if round(t / 0.02) % 2 else 0.38, 3.0,
                                         fault=False, load_a=3.0)
    assert first is None
    assert max(readings[10:]) <= 3.0 * 1.001 and min(readings[10:]) > 3.0 * 0.9    # never high, near the truth


def test_an_unknown_current_neither_starts_nor_clears_the_overcurrent_hold():
    """NaN (a BTS7960 below its duty floor) is not a low, safe reading: the overcurrent
    rule keeps its hold across it, and the running current learnt is not poisoned."""
    from urc.control.faults import OVERCURRENT_HOLD_S, FaultLimits, MonitorInputs, MonitorState, check
    lim = FaultLimits("az", 0.0, 360.0, 6.0, 1.0, 0.1, 0.01, overcurrent_a=5.0)
    st, t = MonitorState(), 0.0
    for amps in [10.0] + [math.nan] * 13 + [10.0]:
        st, fault = check(st, MonitorInputs(t, 100.0 + 2.0 * t, duty=0.5, current_a=amps), lim)
        t += 0.02
    assert t - 0.02 >= OVERCURRENT_HOLD_S            # the last reading: 0.28 s after the first
    assert fault is not None and fault.kind == "overcurrent"
    st, t = MonitorState(), 0.0
    for amps in [10.0] + [3.0] + [10.0] * 10:          # a known low reading does clear it
        st, fault = check(st, MonitorInputs(t, 100.0 + 2.0 * t, duty=0.5, current_a=amps), lim)
        assert fault is None
        t += 0.02
    assert st.running_a is not None and not math.isnan(st.running_a)


def test_the_emulated_is_does_not_sense_a_reverse_current():
    """IS senses the driven high side's forward current only: a motor generating
    (back-EMF above the applied voltage) pushes current back through it, which IS
    does not show, on either side."""
    for duties, load_a in (((0.4, 0.0), -3.0), ((0.0, 0.4), -3.0)):
        p, *_ = part(load_a, *duties, grade="min", offset_a=200e-6)
        assert p.volts() == pytest.approx(0.4 * 200e-6 * NODE_OHMS)     # I_ISH alone


def test_a_decelerating_bigras_motor_generates_and_its_is_reads_no_current(tmp_path):
    """Just after the drive drops the motor still turns faster than the new duty
    drives it: its current flows back through the driven high side (the simulator's
    signed current); the emulated IS reads none of it (it read its magnitude)."""
    rot, clock = emulated_bigras(tmp_path)
    phys, is_part, motor = rot.hw.world.axes["az"], rot.hw.gpio.emulation["az current sense"], rot.hw.az.motor

    def run(seconds, step_s=0.02):
        for k in range(round(seconds / step_s)):
            clock.advance(step_s)
            rot.hw.heartbeat.write(k % 2 == 0)
            rot.hw.poll(clock.now_s())
    for duty in (0.9, -0.9):                 # RPWM's side, then LPWM's
        motor.set_drive(duty)
        run(1.0)
        assert phys.driven_side_current_a() > 0.0 and is_part.node_volts() > 0.0
        motor.set_drive(duty / 4.5)          # the motor still turns at 90 % speed
        run(0.002, step_s=0.001)
        assert phys.driven_side_current_a() < -0.5 and phys.current_a() > 0.5
        assert is_part.node_volts() == 0.0


def test_a_current_sense_that_cannot_be_read_stops_the_axis(tmp_path):
    """The IS input is the BTS7960's only fault channel and the overcurrent rule's
    input: an ADC that fails every read must not leave them blind (it read 0 A)."""
    rot, clock = emulated_bigras(tmp_path)
    rot.goto_az(rot.status().az_deg + 40.0)
    run_virtual(rot, clock, 1.0)
    assert rot.status().moving and not rot.status().faults

    class DeadAdc:
        def read_volts(self):
            raise OSError("I2C NACK")
    rot.hw.az.motor._current.volts = DeadAdc()
    s = run_virtual(rot, clock, 0.5)
    assert [(f.kind, f.axis) for f in s.faults] == [("driver", "az")]
    assert "current sense unreadable" in s.faults[0].reason and "I2C NACK" in s.faults[0].reason
    assert s.az.duty == 0.0 and s.az.target_deg is None          # stopped, the goto abandoned
