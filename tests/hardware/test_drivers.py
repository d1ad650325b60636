"""Drivers on recorded fake parts: what they write to pins, how they convert readings."""

from __future__ import annotations

import math

import pytest

from urc.caps import SensorCaps
from urc.clock import VirtualClock
from urc.errors import SensorError
from urc.hardware.drivers import (As5600Sensor, Bts7960Motor, CompassSensor, LimitSwitchInput,
                                  Lmd18200Motor, PotSensor, QuadratureEncoder, RelayBrake,
                                  RelayMotor, SpidPulseSensor, TiltSensor, Vnh5019Motor)
from urc.hardware.drivers.motors import DirectionTracker, lmd18200_state, vnh5019_state
from urc.hardware.drivers.sensors import chip_horizontal, tilt_compensate
from urc.hardware.parts import MagnetStatus


class Log:
    def __init__(self):
        self.events: list[tuple[str, object]] = []


class Out:
    def __init__(self, log: Log, name: str):
        self.log, self.name, self.value = log, name, None

    def write(self, value):
        self.value = value
        self.log.events.append((self.name, value))

    def write_duty(self, duty):
        self.write(duty)


def test_vnh5019_directions_change_only_with_pwm_off():
    log = Log()
    ina, inb, pwm = Out(log, "INA"), Out(log, "INB"), Out(log, "PWM")
    m = Vnh5019Motor("az", ina, inb, pwm)
    assert (ina.value, inb.value, pwm.value) == (False, False, 1.0)     # braked at build
    log.events.clear()
    m.set_drive(0.5)
    assert log.events == [("PWM", 0.0), ("INA", True), ("INB", False), ("PWM", 0.5)]
    log.events.clear()
    m.set_drive(-0.25)
    assert log.events == [("PWM", 0.0), ("INA", False), ("INB", True), ("PWM", 0.25)]
    log.events.clear()
    m.set_drive(0.0)
    # brake to GND: INA = INB = 0 needs PWM high (ST VNH5019A-E §2.4); PWM falls first
    assert log.events == [("PWM", 0.0), ("INA", False), ("INB", False), ("PWM", 1.0)]
    m.set_drive(7.0)
    assert pwm.value == 1.0 and m.direction == 1
    with pytest.raises(Exception):
        m.set_drive(math.nan)


def test_vnh5019_off_is_the_datasheets_brake_to_gnd_row_not_coast():
    """ST VNH5019A-E Rev 7 §2.4, truth table in normal operating conditions, and its
    note: "in all cases, a '0' on the PWM pin turns off both LSA and LSB switches"."""
    # (INA, INB, PWM) -> what the bridge does, written out from the datasheet
    rows = {(1, 0, 1): "forward", (0, 1, 1): "reverse", (1, 1, 1): "brake", (1, 1, 0): "brake",
            (0, 0, 1): "brake", (0, 0, 0): "coast"}
    for (a, b, p), want in rows.items():
        assert vnh5019_state(bool(a), bool(b), bool(p)) == want, (a, b, p)
    log = Log()
    ina, inb, pwm = Out(log, "INA"), Out(log, "INB"), Out(log, "PWM")
    m = Vnh5019Motor("az", ina, inb, pwm)
    for duty in (0.0, 0.7, 0.0, -0.3, 0.0):
        m.set_drive(duty)
        state = vnh5019_state(ina.value, inb.value, pwm.value > 0.0)
        assert state == ("brake" if duty == 0.0 else "forward" if duty > 0 else "reverse")
        assert pwm.value == (1.0 if duty == 0.0 else abs(duty))
    # at exit the PWM stops (idles low): the brake is held by the row that needs no PWM
    m.close()
    assert (ina.value, inb.value, pwm.value) == (True, True, 0.0)
    assert vnh5019_state(ina.value, inb.value, False) == "brake"
    m.set_drive(0.5)                 # closed: a drive after it is refused, the brake held
    assert (ina.value, inb.value, pwm.value) == (True, True, 0.0)


def test_bts7960_never_drives_both_sides():
    log = Log()
    r, l = Out(log, "R"), Out(log, "L")
    m = Bts7960Motor("az", r, l)
    both = []
    for duty in (0.3, -0.6, 1.0, 0.0, -0.1):
        m.set_drive(duty)
        both.append(bool(r.value) and bool(l.value))
    assert not any(both)
    assert (r.value, l.value) == (0.0, 0.1)


def test_lmd18200_brakes_at_zero():
    log = Log()
    pwm, d, brk = Out(log, "PWM"), Out(log, "DIR"), Out(log, "BRAKE")
    m = Lmd18200Motor("el", pwm, d, brk)
    # TI's truth table: braking is BRAKE high with PWM high (PWM low would coast)
    assert brk.value is True and pwm.value == 1.0
    assert lmd18200_state(pwm.value == 1.0, d.value, brk.value) == "brake"
    m.set_drive(-0.4)
    assert (pwm.value, d.value, brk.value) == (0.4, False, False)
    m.set_drive(0.0)
    assert (pwm.value, brk.value) == (1.0, True)
    # never a moment of drive on the way in or out of the brake: PWM falls before BRAKE
    # does, and BRAKE rises before PWM does
    log.events.clear()
    m.set_drive(0.3)
    m.set_drive(0.0)
    levels = {"PWM": 1.0, "DIR": False, "BRAKE": True}
    for name, value in log.events:
        levels[name] = value
        if not levels["BRAKE"]:
            assert levels["PWM"] in (0.0, 0.3), log.events
    assert log.events[-2:] == [("BRAKE", True), ("PWM", 1.0)]
    # at exit, with the PWM channel about to be disabled: BRAKE low, PWM low, the
    # table's other braking row (both sourcing switches on)
    m.close()
    assert (pwm.value, brk.value) == (0.0, False)
    assert lmd18200_state(False, d.value, False) == "brake"


def relay(levels=(0.5, 1.0), fast=False, dead_s=0.5, **kw):
    log, clock = Log(), VirtualClock()
    cw, ccw = Out(log, "CW"), Out(log, "CCW")
    f = Out(log, "FAST") if fast else None
    m = RelayMotor("az", cw, ccw, clock, fast=f, levels=levels, reverse_dead_time_s=dead_s, **kw)
    return m, cw, ccw, f, clock, log


def test_relay_reverse_waits_the_dead_time_with_both_off():
    m, cw, ccw, _, clock, log = relay()
    m.set_drive(1.0)
    assert (cw.value, ccw.value) == (True, False)
    clock.advance(1.0)
    m.set_drive(-1.0)                      # reverse at once: both off now
    assert (cw.value, ccw.value) == (False, False)
    for _ in range(24):                    # 0.48 s later: still off
        clock.advance(0.02)
        m.set_drive(-1.0)
        assert (cw.value, ccw.value) == (False, False)
    clock.advance(0.02)
    m.set_drive(-1.0)
    assert (cw.value, ccw.value) == (False, True)
    # never both closed at any moment of the log
    state = {"CW": False, "CCW": False}
    for name, v in log.events:
        state[name] = v
        assert not (state["CW"] and state["CCW"])


def test_relay_slow_speed_is_pulsed_without_a_speed_relay():
    m, cw, _, _, clock, _ = relay(levels=(0.5, 1.0))
    on = 0
    for _ in range(100):                   # 2 s at 50 Hz
        m.set_drive(0.45)                  # nearest level 0.5
        on += bool(cw.value)
        clock.advance(0.02)
    assert on == pytest.approx(50, abs=2)


def _pulse_starts_s(m, cw, clock, seconds=4.0):
    starts, was = [], False
    for i in range(round(seconds / 0.01)):
        m.set_drive(0.25)
        if cw.value and not was:
            starts.append(round(i * 0.01, 2))
        was = bool(cw.value)
        clock.advance(0.01)
    return starts


def test_relay_slow_pulses_at_the_documents_2_hz_or_as_set():
    """G4JNT: the slow button pulses the motor at 2 Hz (it was 2.5 Hz, fixed)."""
    m, cw, _, _, clock, _ = relay(levels=(0.25, 1.0))
    starts = _pulse_starts_s(m, cw, clock)
    assert len(starts) == 8 and all(b - a == pytest.approx(0.5, abs=0.011) for a, b in zip(starts, starts[1:]))
    m, cw, _, _, clock, _ = relay(levels=(0.25, 1.0), pulse_period_s=1 / 3)
    starts = _pulse_starts_s(m, cw, clock)
    assert len(starts) == 12 and all(b - a == pytest.approx(1 / 3, abs=0.011) for a, b in zip(starts, starts[1:]))


def test_relay_slow_speed_with_a_speed_relay_is_steady():
    m, cw, _, fast, clock, _ = relay(levels=(0.5, 1.0), fast=True)
    for _ in range(50):
        m.set_drive(0.5)
        assert cw.value is True and fast.value is False
        clock.advance(0.02)
    m.set_drive(1.0)
    assert fast.value is True


def test_brake_reports_released_only_after_its_release_time():
    log, clock = Log(), VirtualClock()
    coil = Out(log, "BRAKE")
    b = RelayBrake("az", coil, clock, release_s=0.2)
    assert coil.value is False and not b.is_released()
    b.set_released(True)
    assert coil.value is True and not b.is_released()
    clock.advance(0.2)
    assert b.is_released()
    b.set_released(False)
    assert coil.value is False and not b.is_released()


class Pin:
    def __init__(self, v=True):
        self.v = v

    def read(self):
        return self.v


def test_limit_switch_polarity():
    p = Pin(True)
    nc = LimitSwitchInput("max", p, active_low=False)
    no = LimitSwitchInput("min", p, active_low=True)
    assert nc.is_active() and not no.is_active()
    p.v = False
    assert not nc.is_active() and no.is_active()


# ------------------------------------------------------------------ sensors
ENC = SensorCaps(kind="encoder", resolution_deg=0.1, absolute=False)


class Counter:
    def __init__(self):
        self.c, self.idx = 0, None

    def count(self):
        return self.c

    def index_count(self):
        return self.idx

    def errors(self):
        return getattr(self, "err", 0)


def test_lost_encoder_edges_bound_the_position_and_fault_past_the_limit():
    """Review 20 #3: each lost report (a report of a level the channel already had) may
    cost 4 counts (test_gpio_emulated.py measures 4); the bound grows with them, and past
    max_lost_deg the position is a sensor error until re-referenced, not a known angle."""
    from urc.hardware.parts import PartError
    cnt = Counter()
    enc = QuadratureEncoder(ENC, "az", cnt, max_lost_deg=1.0)
    enc.set_reference_deg(10.0)
    cnt.c, cnt.err = 100, 2
    assert enc.read_deg() == pytest.approx(20.0)
    assert enc.lost_edges() == 2 and enc.uncertainty_deg() == pytest.approx(0.8)
    cnt.err = 3                                # 3 x 4 counts x 0.1 deg = 1.2 deg > 1.0
    with pytest.raises(PartError, match="lost 3 edge"):
        enc.read_deg()
    with pytest.raises(PartError):             # it stays an error ...
        enc.read_deg()
    enc.set_reference_deg(20.0)                # ... until re-referenced
    assert enc.read_deg() == pytest.approx(20.0) and enc.uncertainty_deg() == 0.0
    cnt.err = 9                                # an index pass wipes the bound too
    enc2 = QuadratureEncoder(ENC, "az", cnt, index_deg=180.0)
    enc2.set_reference_deg(100.0)
    cnt.err, cnt.c, cnt.idx = 20, 805, 805
    assert enc2.read_deg() == pytest.approx(180.0) and enc2.lost_edges() == 0


def test_encoder_reference_and_index_rereference():
    cnt = Counter()
    enc = QuadratureEncoder(ENC, "az", cnt, index_deg=180.0)
    enc.set_reference_deg(100.0)
    cnt.c = 250
    assert enc.read_deg() == pytest.approx(125.0)
    # edges were missed: the index mark (at 180 deg) comes at count 805, not 800
    cnt.c, cnt.idx = 805, 805
    assert enc.read_deg() == pytest.approx(180.0)
    cnt.c = 815
    assert enc.read_deg() == pytest.approx(181.0)
    assert enc.last_index_correction_deg == pytest.approx(-0.5)


def test_encoder_index_every_period_snaps_to_the_nearest_mark():
    """An index each 360 deg on a 400 deg azimuth: the pulse at 380 is the mark at 20
    one turn on, not 20 (the old driver re-referenced every pulse to index_deg)."""
    cnt = Counter()
    enc = QuadratureEncoder(ENC, "az", cnt, index_deg=20.0)
    enc.set_reference_deg(0.0)
    cnt.c, cnt.idx = 3803, 3803                # 380.3 by the count: the mark at 380
    assert enc.read_deg() == pytest.approx(380.0) and enc.index_rereferences == 1
    # an encoder on a shaft turning 4x per axis turn: a pulse every 90 deg
    enc = QuadratureEncoder(ENC, "az", Counter(), index_deg=20.0, index_period_deg=90.0)
    enc.set_reference_deg(0.0)
    enc.counter.c = enc.counter.idx = 2004     # 200.4: the mark at 200 (= 20 + 2 x 90)
    assert enc.read_deg() == pytest.approx(200.0)


def test_encoder_counting_with_motor_off_is_an_error():
    cnt, clock, motor = Counter(), VirtualClock(), DirectionTracker()
    motor.duty = 0.0
    enc = QuadratureEncoder(ENC, "az", cnt, motor=motor, drift_counts=2, still_after_s=1.0, clock=clock)
    for c in (0, 3, 6):                    # coasting after switch-off is fine
        cnt.c = c
        enc.read_deg()
        clock.advance(0.4)
    clock.advance(1.0)
    enc.read_deg()
    cnt.c = 10                             # 4 counts with the motor off for > 1 s
    with pytest.raises(SensorError, match="motor off"):
        enc.read_deg()
    with pytest.raises(SensorError):       # latched until re-referenced
        enc.read_deg()
    enc.set_reference_deg(0.0)
    assert enc.read_deg() == pytest.approx(0.0)


def test_pulse_counter_takes_direction_from_the_drive():
    caps = SensorCaps(kind="pulse", resolution_deg=0.5, absolute=False)
    cnt = Counter()
    drive = DirectionTracker()
    s = SpidPulseSensor(caps, "az", cnt, drive)
    cnt.c = 10
    drive._track(-1.0)                     # reversal: 10 pulses folded in going up
    cnt.c = 14
    assert s.counts() == 10 - 4 and s.read_deg() == pytest.approx(3.0)


class Adc:
    #: what the pot supply nominally reads (3.3 V on the ADS1115's 4.096 V range)
    full_scale_counts = 26400

    def __init__(self, counts, ref):
        self.counts, self.ref = counts, ref

    def read_counts(self):
        return self.counts

    def read_reference_counts(self):
        return self.ref


def test_ratiometric_pot_formula_independent_of_adc_and_supply():
    caps = SensorCaps(kind="pot", resolution_deg=0.9, absolute=True)
    for ref in (26400, 22000):             # the supply sags: the bearing must not
        x = 0.3
        adc = Adc(round(ref * 2 * x / (1 + x)), ref)
        pot = PotSensor(caps, "az", adc, law="ratiometric", m=360 / 4096, c=0.0)
        n = 1024 * adc.counts / ref
        assert pot.raw_units() == pytest.approx(4096 * n / (2048 - n))
        assert pot.read_deg() == pytest.approx(108.0, abs=0.02)


def test_pot_reference_out_of_range_is_an_error():
    caps = SensorCaps(kind="pot", resolution_deg=0.5, absolute=True)
    pot = PotSensor(caps, "az", Adc(1000, 1200), law="linear", m=0.5, c=0.0)
    with pytest.raises(SensorError, match="reference"):
        pot.read_deg()


class FakeAs5600:
    def __init__(self):
        self.raw, self.status = 0, MagnetStatus(True)

    def read_raw_angle(self):
        return self.raw

    def magnet_status(self):
        return self.status


def test_as5600_zero_unwrap_and_magnet_errors():
    caps = SensorCaps(kind="as5600", resolution_deg=360 / 4096, absolute=True, modulo_deg=360.0)
    part = FakeAs5600()
    s = As5600Sensor(caps, "az", part)
    part.raw = 4000
    s.set_reference_deg(350.0)
    part.raw = 100                          # crossed 0/360 upwards
    assert s.read_deg() == pytest.approx((100 - 4000) * 360 / 4096 + 350.0 + 360.0 - 360.0)
    assert s.turns == 1 and s.unwrapped_deg() == pytest.approx(s.read_deg() + 360.0)
    part.status = MagnetStatus(True, too_weak=True)
    with pytest.raises(SensorError, match="too weak"):
        s.read_deg()
    part.status = MagnetStatus(True, too_strong=True)
    with pytest.raises(SensorError, match="too strong"):
        s.read_deg()
    part.status = MagnetStatus(False)
    with pytest.raises(SensorError, match="not detected"):
        s.read_deg()


def test_as5600_reversed_counts_the_other_way_and_unwraps_the_other_way():
    """DIR to VDD (or the chip on the other side of the magnet): the raw count falls as
    the axis turns up; ``reversed`` reads 4096 - raw, so the angle still rises."""
    caps = SensorCaps(kind="as5600", resolution_deg=360 / 4096, absolute=True, modulo_deg=360.0)
    part = FakeAs5600()
    s = As5600Sensor(caps, "az", part, reversed=True)
    part.raw = 1024                               # 90 deg counted the other way: 270 deg
    assert s.read_deg() == pytest.approx(270.0)
    part.raw = 0                                  # up 90 deg, across 0/360
    assert s.read_deg() == pytest.approx(0.0) and s.turns == 1
    part.raw = 4000                               # up another 96 counts
    assert s.read_deg() == pytest.approx(96 * 360 / 4096)
    assert s.turns == 1 and s.unwrapped_deg() == pytest.approx(360.0 + 96 * 360 / 4096)


class Vec:
    def __init__(self, v):
        self.v = v

    def read_vector(self):
        return self.v


def on_chip(v):
    """A vector on the heading formulas' axes (x boresight, y right, z up) as the LSM303
    mounted as seed 001 says reads it (X right, Y boresight, Z up)."""
    return (v[1], v[0], v[2])


@pytest.mark.parametrize("pitch_deg, roll_deg", [(0, 0), (30, 0), (-20, 10), (60, -15)])
def test_tilt_compensation_recovers_the_heading(pitch_deg, roll_deg):
    psi, dip = math.radians(123.0), math.radians(70.0)     # heading, field inclination
    # world field (x north-ish along heading convention, z down) in the level frame
    h = (math.cos(psi) * math.cos(dip), -math.sin(psi) * math.cos(dip), math.sin(dip))
    p, r = math.radians(pitch_deg), math.radians(roll_deg)

    def to_body(v):                        # rotate level -> body: pitch about y, roll about x
        x, y, z = v
        x, z = x * math.cos(p) - z * math.sin(p), x * math.sin(p) + z * math.cos(p)
        y, z = y * math.cos(r) + z * math.sin(r), -y * math.sin(r) + z * math.cos(r)
        return (x, y, z)

    m, a = to_body(h), to_body((0.0, 0.0, 1.0))
    bx, by = tilt_compensate(m, a)
    assert math.degrees(math.atan2(-by, bx)) % 360 == pytest.approx(123.0, abs=1e-6)
    caps = SensorCaps(kind="magnetometer", resolution_deg=0.1, absolute=True, modulo_deg=360.0)
    c = CompassSensor(caps, "az", Vec(on_chip(m)), Vec(on_chip(a)), declination_deg=5.0)
    assert c.read_deg() == pytest.approx(128.0, abs=0.05)


def test_compass_hard_and_soft_iron():
    caps = SensorCaps(kind="magnetometer", resolution_deg=0.1, absolute=True, modulo_deg=360.0)
    psi = math.radians(200.0)
    # soft iron stretches x by 1.2 after a hard-iron offset of (0.1, -0.05)
    raw = (1.2 * math.cos(psi) + 0.1, -math.sin(psi) - 0.05, 0.0)
    # (the hard iron on the chip's own axes)
    c = CompassSensor(caps, "az", Vec(on_chip(raw)), hard_iron=(-0.05, 0.1), soft_iron=(1 / 1.2, 0, 0, 1))
    assert c.read_deg() == pytest.approx(200.0, abs=0.05)
    c.load_calibration({"soft_iron": [1, 0, 0, 1]})
    assert abs(c.read_deg() - 200.0) > 1.0


def test_tilt_sensor():
    caps = SensorCaps(kind="magnetometer", resolution_deg=0.1, absolute=True)
    el = math.radians(33.3)
    t = TiltSensor(caps, "el", Vec(on_chip((math.sin(el), 0.0, math.cos(el)))))
    assert t.read_deg() == pytest.approx(33.3)
    t.set_reference_deg(30.0)
    assert t.read_deg() == pytest.approx(30.0)


def test_soft_iron_fit_makes_the_compass_true():
    from urc.procedures.calibration import fit_hard_iron, fit_soft_iron
    caps = SensorCaps(kind="magnetometer", resolution_deg=0.1, absolute=True, modulo_deg=360.0)

    def raw(psi_deg):                      # x stretched 1.25, sheared, hard iron (0.3, -0.1)
        p = math.radians(psi_deg)
        x, y = math.cos(p), -math.sin(p)
        return (1.25 * x + 0.1 * y + 0.3, 0.1 * x + 0.9 * y - 0.1, 0.0)
    samples = [raw(30 * i)[:2] for i in range(12)]
    fit = fit_soft_iron(samples)
    assert (fit.x, fit.y) == pytest.approx((0.3, -0.1), abs=1e-9)
    assert fit.axis_ratio > 1.2 and fit.rms_rel < 1e-9
    assert fit_hard_iron(samples).rms_rel > 0.05      # a circle fit would be refused
    errs = []
    for psi in range(0, 360, 7):
        c = CompassSensor(caps, "az", Vec(on_chip(raw(psi))), hard_iron=chip_horizontal(fit.x, fit.y),
                          soft_iron=fit.matrix)
        errs.append((c.read_deg() - psi + 180) % 360 - 180)
    # a symmetric correction leaves at most a constant rotation (taken out by the offset)
    mean = sum(errs) / len(errs)
    assert max(abs(e - mean) for e in errs) < 0.15
