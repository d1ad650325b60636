"""Simulated sensors: quantisation, formulas, quirks and calibration."""

from __future__ import annotations

import math
import statistics

import pytest

from urc.hardware.sim import physics_for
from sim_rig import rig  # noqa: F401  (fixture)

def _place(world, axis: str, deg: float, gear_offset_deg: float = 0.0) -> None:
    """Put the mechanism at rest at ``deg`` (test helper; bypasses the motor)."""
    a = world.axes[axis]
    a.load_deg, a.gear_deg = deg, deg + gear_offset_deg
    a.load_deg_per_s = a.gear_deg_per_s = 0.0


def test_encoder_counts_and_reference(rig):
    r = rig("tartu-urc", start_az_deg=12.34)
    enc = r.hw.az.sensor
    assert enc.counts_per_deg == 10 and enc.counts() == 0
    assert enc.read_deg() == pytest.approx(12.34)        # fresh rotator: referenced
    r.release_brake("az")
    r.hw.az.motor.set_drive(1.0)
    r.run(2.0)
    r.hw.az.motor.set_drive(0.0)
    r.run(1.0)
    gear = r.truth("az")["gear_deg"]                     # the encoder is on the motor side
    assert enc.counts() == math.floor(gear * 10 + 1e-9) - math.floor(12.34 * 10 + 1e-9)
    assert enc.read_deg() == pytest.approx(enc.counts() * 0.1 + 12.34)
    assert abs(enc.read_deg() - gear) <= 0.1 + 1e-9
    enc.set_reference_deg(200.0)
    assert enc.read_deg() == pytest.approx(200.0)
    assert enc.calibration()["reference_deg"] == pytest.approx(200.0 - enc.counts() * 0.1)


def test_pulse_counter_direction_comes_from_the_command(rig):
    r = rig("bigras", start_az_deg=100.0)
    sensor, motor = r.hw.az.sensor, r.hw.az.motor
    motor.set_drive(1.0)
    r.run(3.0)
    motor.set_drive(0.0)
    r.run(1.0)
    assert abs(sensor.read_deg() - r.truth("az")["gear_deg"]) <= 0.5 + 1e-9
    # The gear is 0.005 deg short of a pulse edge, coasting forward at full speed, when
    # the controller reverses the command (a tiny reverse duty, below stiction). The
    # counter takes the coast over the edge as a step *back*: a miscount, as on real iron.
    world = r.world
    edge = (math.floor(r.truth("az")["gear_deg"] / 0.5) + 1) * 0.5
    a = world.axes["az"]
    read0 = sensor.read_deg()
    a.gear_deg = edge - 0.005
    a.load_deg = a.gear_deg - a.half_gap_deg
    a.gear_deg_per_s = a.load_deg_per_s = r.caps.az.max_rate_deg_per_s
    motor.set_drive(-0.01)
    r.run(1.0)
    assert r.truth("az")["gear_deg"] > edge                 # it really went forward
    assert sensor.read_deg() == pytest.approx(read0 - 0.5)  # counted backwards


def test_pulse_counter_no_direction_with_reversed_motor(rig):
    r = rig("bigras", start_el_deg=40.0)
    r.world.inject("el", "reverse_wiring")
    r.hw.el.motor.set_drive(1.0)
    r.run(2.0)
    assert r.truth("el")["deg"] < 37.0
    assert r.hw.el.sensor.read_deg() > 43.0               # counts up while it goes down


@pytest.mark.parametrize("axis", ["az", "el"])
def test_g4jnt_ratiometric_pot_round_trip(rig, axis):
    r = rig("g4jnt", sensor_noise=False)
    ax = r.caps.axis(axis)
    pot = r.hw.axis(axis).sensor
    p = physics_for("g4jnt").axis(axis).sensor
    cal = pot.calibration()
    assert cal["M"] == pytest.approx(p.pot_span_deg / 4096) and cal["Z"] == 0.0
    for i in range(101):
        deg = ax.min_deg + ax.span_deg * i / 100
        _place(r.world, axis, deg)
        x = (deg - p.pot_start_deg) / p.pot_span_deg
        n = pot.adc.read_counts(noisy=False)
        assert n == min(1023, round(2048 * x / (1 + x)))
        assert pot.linearised(n) == pytest.approx(4096 * n / (2048 - n))
        count_deg = abs(p.pot_span_deg) * (1 + x) ** 2 / 2048  # one count here (Table 1 pot: backwards)
        assert abs(pot.read_deg() - deg) <= count_deg
        assert count_deg <= ax.sensor.resolution_deg + 1e-9
    c_before = pot.calibration()["C"]
    pot.set_reference_deg(ax.max_deg)        # a re-reference moves the intercept C ...
    assert pot.read_deg() == pytest.approx(ax.max_deg)
    assert pot.calibration()["C"] != c_before
    assert pot.calibration()["Z"] == 0.0     # ... never Z, the bearing of the reference


def test_g5500_linear_pot_and_noise(rig):
    r = rig("g5500", start_az_deg=200.0)
    pot = r.hw.az.sensor
    p = physics_for("g5500").az.sensor
    x = (200.0 - p.pot_start_deg) / p.pot_span_deg
    assert pot.adc.read_counts(noisy=False) == round(1023 * x)
    reads = [pot.read_deg() for _ in range(400)]
    assert statistics.mean(reads) == pytest.approx(200.0, abs=0.2)
    assert 0.05 < statistics.pstdev(reads) < 0.4
    step = p.pot_span_deg / 1023
    for v in reads:                                            # on the ADC grid
        k = (v - p.pot_start_deg) / step
        assert k == pytest.approx(round(k), abs=1e-6)


def test_as5600_modulo_and_quantisation(rig):
    r = rig("berkeley", sensor_noise=False, start_az_deg=365.3)
    enc = r.hw.az.sensor
    q = 360.0 / 4096
    v = enc.read_deg()
    assert 0.0 <= v < 360.0
    assert v == pytest.approx(round(365.3 / q) * q - 360.0)
    assert (v / q) == pytest.approx(round(v / q))
    _place(r.world, "az", -0.01)
    assert enc.read_deg() == 0.0 or enc.read_deg() > 359.9
    _place(r.world, "az", 123.456)
    enc.set_reference_deg(10.0)
    assert enc.read_deg() == pytest.approx(10.0)
    assert enc.calibration()["zero_deg"] == pytest.approx(round(123.456 / q) * q - 10.0)
    _place(r.world, "az", 123.456 + 355.0)
    assert enc.read_deg() == pytest.approx(5.0, abs=q)


def test_as5600_glitches_are_rare_and_one_count(rig):
    r = rig("berkeley", start_az_deg=100.0)
    q = 360.0 / 4096
    base = round(100.0 / q) * q
    reads = [r.hw.az.sensor.read_deg() for _ in range(2000)]
    off = [round((v - base) / q) for v in reads]
    assert set(off) <= {-1, 0, 1}
    assert 0 < sum(1 for o in off if o) < 0.05 * len(off)


def _heading_errors(r, n: int = 72) -> list[float]:
    errs = []
    for i in range(n):
        deg = -90.0 + 540.0 * i / n
        _place(r.world, "az", deg)
        e = (r.hw.az.sensor.read_deg() - deg + 180.0) % 360.0 - 180.0
        errs.append(e)
    return errs


def test_magnetometer_calibrated_accuracy(rig):
    r = rig("sarcnet-mini")
    errs = _heading_errors(r)
    assert all(0.0 <= r.hw.az.sensor.read_deg() < 360.0 for _ in range(5))
    assert math.sqrt(statistics.mean(e * e for e in errs)) < 0.3
    assert max(abs(e) for e in errs) < 0.8
    v = r.hw.az.sensor.read_deg()
    assert round(v / 0.1) * 0.1 == pytest.approx(v)           # 0.1 deg steps


def test_magnetometer_uncalibrated_error(rig):
    r = rig("sarcnet-mini", sensor_noise=False)
    r.hw.az.sensor.load_calibration({"hard_iron_x": 0.0, "hard_iron_y": 0.0})
    errs = _heading_errors(r)
    # hard iron: a few degrees, varying with heading
    assert 1.0 < max(abs(e) for e in errs) < 5.0
    assert statistics.pstdev(errs) > 0.7
    r.hw.az.sensor.load_calibration({"declination_deg": 0.0})   # and the declination
    errs = _heading_errors(r)
    declination_deg = physics_for("sarcnet-mini").az.sensor.declination_deg
    assert statistics.mean(errs) == pytest.approx(-declination_deg, abs=1.0)
    truth = physics_for("sarcnet-mini").az.sensor          # calibrated again
    r.hw.az.sensor.load_calibration({"hard_iron_x": truth.hard_iron_x,
                                     "hard_iron_y": truth.hard_iron_y,
                                     "declination_deg": truth.declination_deg})
    assert max(abs(e) for e in _heading_errors(r)) < 0.1


def test_tilt_sensor_elevation(rig):
    r = rig("sarcnet-mini")
    for deg in (0.0, 12.3, 45.0, 89.9):
        _place(r.world, "el", deg)
        reads = [r.hw.el.sensor.read_deg() for _ in range(100)]
        assert statistics.mean(reads) == pytest.approx(deg, abs=0.05)
        assert statistics.pstdev(reads) < 0.2
    # re-referencing takes a fresh reading (noise-free here, to check the arithmetic)
    r = rig("sarcnet-mini", sensor_noise=False)
    _place(r.world, "el", 89.9)
    r.hw.el.sensor.set_reference_deg(90.0)
    assert r.hw.el.sensor.calibration()["offset_deg"] == pytest.approx(0.1, abs=0.001)
