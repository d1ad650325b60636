"""The same contract over every backend that has parts: the sim backend and the gpio
backend on emulated pins and chips, for every shipped example's profile."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from urc.assembly import hardware_options, settings_from_config
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.errors import HardwareError
from urc.hardware import build_hardware
from urc.hardware.interfaces import Brake, LimitSwitch, Motor, PositionSensor

EXAMPLES = sorted(p for p in (Path(__file__).resolve().parents[2] / "examples").glob("*.toml")
                  if 'backend = "gpio"' in p.read_text())   # (a bridge example has no parts of urc's)


def make(path: Path, backend: str, tmp_path: Path):
    data = load_config(path).to_dict()
    start = {"wind": False, "start_el_deg": 30.0, "start_az_deg": 100.0}
    if data.get("rotator", {}).get("elevation") is False:
        del start["start_el_deg"]  # a single-axis example: no elevation to start anywhere
    if backend == "sim":
        data["hardware"] = {"sim": start}
    else:
        data["hardware"]["gpio"]["emulate"] = True
        data["hardware"]["sim"] = start
    cfg = Config.from_dict(data)
    caps = settings_from_config(cfg).caps
    clock = VirtualClock(1000.0)
    hw = build_hardware(cfg.hardware.backend, caps, clock, tmp_path, hardware_options(cfg))
    hw.poll(clock.now_s())
    return hw, caps, clock


def run(hw, clock, seconds: float, drive: dict | None = None) -> None:
    """Ticks of 20 ms, each toggling the heartbeat as the control loop does (the gpio
    examples wire the safety chain: no heartbeat, no motor power)."""
    for k in range(round(seconds / 0.02)):
        clock.advance(0.02)
        hw.poll(clock.now_s())
        for name, duty in (drive or {}).items():
            hw.axis(name).motor.set_drive(duty)
        if hw.heartbeat is not None:
            hw.heartbeat.write(k % 2 == 0)


def circ(a: float, b: float, m: float | None) -> float:
    d = a - b
    return (d + m / 2) % m - m / 2 if m else d


@pytest.mark.parametrize("backend", ["sim", "gpio"])
@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_contract(path, backend, tmp_path):
    hw, caps, clock = make(path, backend, tmp_path)
    assert hw.sim_truth() is not None
    assert (hw.el is None) == (not caps.has_el)  # single-axis: no elevation parts at all
    for name in caps.axes:
        ax, ax_caps = hw.axis(name), caps.axis(name)
        assert isinstance(ax.motor, Motor) and isinstance(ax.sensor, PositionSensor)
        assert ax.brake is None or (isinstance(ax.brake, Brake) and not ax.brake.is_released())
        for sw in (ax.limit_min, ax.limit_max):
            assert sw is None or (isinstance(sw, LimitSwitch) and sw.is_active() is False)
        with pytest.raises(HardwareError):
            ax.motor.set_drive(math.nan)
        m = ax_caps.sensor.modulo_deg
        r0 = ax.sensor.read_deg()
        assert math.isfinite(r0) and (m is None or 0 <= r0 < m)
        # the reading follows the true angle
        assert abs(circ(r0, hw.sim_truth()[name]["deg"], m)) < 1.0 + 2 * ax_caps.sensor.resolution_deg
        # drive up: the sensor counts up, then it stops
        if ax.brake is not None:
            ax.brake.set_released(True)
            run(hw, clock, ax_caps.brake_release_s + 0.1)
            assert ax.brake.is_released()
        run(hw, clock, 1.5, {name: 1.0})
        run(hw, clock, 1.5, {name: 0.0})
        r1 = ax.sensor.read_deg()
        assert circ(r1, r0, m) > 0.5 * ax_caps.max_rate_deg_per_s * 1.0, (r0, r1)
        assert abs(circ(r1, hw.sim_truth()[name]["deg"], m)) < 1.0 + 2 * ax_caps.sensor.resolution_deg
        run(hw, clock, 0.5)
        assert hw.sim_truth()[name]["rate_deg_per_s"] == 0.0
        if ax.brake is not None:
            ax.brake.set_released(False)
            run(hw, clock, ax_caps.brake_engage_s + 0.1)
            assert not ax.brake.is_released()
        # re-reference and calibration round trip
        ax.sensor.set_reference_deg(50.0)
        assert abs(circ(ax.sensor.read_deg(), 50.0, m)) <= 2 * ax_caps.sensor.resolution_deg + 4 * ax_caps.sensor.noise_deg
        cal = ax.sensor.calibration()
        ax.sensor.load_calibration(cal)
        assert ax.sensor.calibration() == cal
    hw.close()
