"""SARCNET compass handedness (seed 001): the LSM303 sits flat on top of the boom, its Y
axis along the boresight; pointing north and level, its X axis points east and its Z
axis up. The chip's axes are right-handed and its accelerometer reads +1 g up at rest
(LSM303D datasheet, the axes of detectable acceleration and magnetic field).

The readings are computed here from that description alone (a field pointing north and
dipping down, gravity), not from urc's simulator; the real driver must give the heading
(increasing clockwise) and the elevation from them. Then the same through the emulated
chip: turning the simulated antenna clockwise increases the heading, and the emulated
chip's registers carry the field on the axes the document names."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from urc.assembly import build_rotator
from urc.cli import with_emulation
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.hardware.drivers import CompassSensor, TiltSensor
from urc.hardware.gpio.emulate import FakeLsm303d, FakeSMBus
from urc.hardware.gpio.i2c import Lsm303Accel, Lsm303dChip, Lsm303Mag
from urc.profiles import get_profile
from urc.rotator.loop import run_virtual

H_GAUSS, DIP_DEG = 0.25, 65.0           # a field 65 deg below the horizon (northern site)
SARCNET = Path(__file__).resolve().parents[2] / "examples" / "sarcnet-mini.toml"


def chip_axes(az_deg: float, el_deg: float) -> np.ndarray:
    """The chip's X, Y, Z as rows, in east-north-up, on a boom pointing (az, el)."""
    a, e = math.radians(az_deg), math.radians(el_deg)
    y = np.array([math.sin(a) * math.cos(e), math.cos(a) * math.cos(e), math.sin(e)])   # boresight
    x = np.array([math.cos(a), -math.sin(a), 0.0])                                      # its right
    return np.array([x, y, np.cross(x, y)])                                             # right-handed


class Boom:
    """What an LSM303D on the boom reads, pointing (az, el) (magnetic azimuth)."""

    def __init__(self):
        self.az_deg = self.el_deg = 0.0

    def field(self):
        f = np.array([0.0, H_GAUSS, -H_GAUSS * math.tan(math.radians(DIP_DEG))])
        return tuple(chip_axes(self.az_deg, self.el_deg) @ f)

    def gravity(self):
        return tuple(chip_axes(self.az_deg, self.el_deg) @ np.array([0.0, 0.0, 1.0]))


@pytest.fixture
def drivers():
    boom, bus = Boom(), FakeSMBus()
    bus.devices[Lsm303dChip.ADDRESS] = FakeLsm303d(boom.field, boom.gravity)
    chip = Lsm303dChip(bus)
    caps = get_profile("sarcnet-mini")
    compass = CompassSensor(caps.az.sensor, "az", Lsm303Mag(chip), Lsm303Accel(chip))
    tilt = TiltSensor(caps.el.sensor, "el", Lsm303Accel(chip))
    return boom, compass, tilt


def _diff(a: float, b: float) -> float:
    return (a - b + 180.0) % 360.0 - 180.0


@pytest.mark.parametrize("el_deg", [0.0, 30.0, 60.0])
def test_the_driver_reads_the_documents_mounting_heading_clockwise_and_elevation_up(drivers, el_deg):
    boom, compass, tilt = drivers
    boom.el_deg = el_deg
    headings = []
    for az_deg in range(0, 360, 15):              # the antenna turned clockwise
        boom.az_deg = float(az_deg)
        headings.append(compass.read_deg())
        assert _diff(compass.read_deg(), az_deg) == pytest.approx(0.0, abs=0.3), (az_deg, el_deg)
        assert tilt.read_deg() == pytest.approx(el_deg, abs=0.3)
    steps = [_diff(b, a) for a, b in zip(headings, headings[1:])]
    assert all(14.0 < s < 16.0 for s in steps), steps     # every step clockwise, none mirrored


def test_emulated_chip_carries_the_field_on_the_documents_axes_and_heading_turns_clockwise(tmp_path):
    data = with_emulation(load_config(SARCNET)).to_dict()
    data["hardware"]["sim"] = {"wind": False}
    clock = VirtualClock(1000.0)
    rot = build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False, fast_virtual=True)
    sensor = rot.hw.az.sensor
    decl_deg = sensor.calibration()["declination_deg"]
    seen = []
    for az_deg in (30.0, 100.0, 170.0, 240.0):       # clockwise, one goto after another
        rot.goto(az_deg, 0.0)
        s = run_virtual(rot, clock, 300.0, until=lambda s: not s.moving and abs(s.az_deg - az_deg) < 0.5
                        and s.az.mode in ("holding", "idle"))
        truth_deg = s.sim_truth["az"]["deg"]
        seen.append((truth_deg, s.az_deg))
        # the raw chip, its hard iron off: the field's horizontal part on X (east when
        # pointing north) and Y (the boresight), pointing at magnetic north
        mx, my, _ = sensor.mag.read_vector()
        mx, my = mx - sensor.hard_iron_x, my - sensor.hard_iron_y
        magnetic_deg = truth_deg - decl_deg
        assert my == pytest.approx(math.hypot(mx, my) * math.cos(math.radians(magnetic_deg)), abs=0.01)
        assert mx == pytest.approx(-math.hypot(mx, my) * math.sin(math.radians(magnetic_deg)), abs=0.01)
        ax, ay, az = sensor.accel.read_vector()          # level: +1 g up the chip's Z
        assert az == pytest.approx(1.0, abs=0.02) and abs(ax) < 0.02 and abs(ay) < 0.02
    assert [round(t) for t, _ in seen] == sorted(round(t) for t, _ in seen)
    assert all(abs(_diff(shown, t)) < 1.0 for t, shown in seen)
    rot.hw.close()
