"""The takeover's outputs-only build (review 20 #5) and the sysfs PWM off-switch
(review 20 #13), on mock pins: every motor, relay, brake and heartbeat output claimed
at its safe level with no bus I/O at all, each line on its own."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import pytest
from gpiozero import Device
from gpiozero.pins.mock import MockFactory, MockPWMPin

from urc.assembly import take_outputs
from urc.config import Config, load_config
from urc.hardware.drivers.motors import lmd18200_state, vnh5019_state
from urc.hardware.gpio.outputs_only import take_gpio_outputs
from urc.hardware.gpio.pwm import HardwarePwm, sysfs_pwm_off

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def cfg_of(name: str) -> Config:
    return load_config(EXAMPLES / f"{name}.toml")


@pytest.fixture
def factory():
    f = MockFactory(pin_class=MockPWMPin)
    yield f
    f.close()


def _no_bus(*_a, **_k):
    raise OSError(110, "Connection timed out (a hung I2C transfer)")


def test_takeover_on_iron_claims_the_outputs_with_no_bus_io(factory, monkeypatch, tmp_path):
    """tartu-urc on iron: its buses would fail (the control process may have hung in
    one); the takeover still brakes both VNH5019s, engages the brakes and stops the
    heartbeat. The full build opened the MCP3008 first and raised."""
    import smbus2
    monkeypatch.setattr(Device, "pin_factory", factory)
    monkeypatch.setattr(smbus2, "SMBus", _no_bus)
    monkeypatch.setitem(sys.modules, "spidev", types.SimpleNamespace(SpiDev=_no_bus))
    cfg = cfg_of("tartu-urc")
    assert not cfg.hardware.gpio.emulate
    held = take_outputs(cfg, tmp_path)
    levels = held.levels()
    assert held.failed == []
    for axis in ("az", "el"):
        ina, inb, pwm = (levels[f"{axis} vnh5019 {k}"] for k in ("ina", "inb", "pwm"))
        assert vnh5019_state(ina, inb, pwm) == "brake"        # INA = INB = 1: brake to VCC
        assert levels[f"{axis} brake"] is False
    assert levels["heartbeat"] is False
    pins = cfg.hardware.gpio.az.pins
    assert factory.pin(pins["ina"]).function == "output" and factory.pin(pins["ina"]).state
    held.drive_safe()
    assert held.levels() == levels
    held.close()
    assert factory.pin(pins["ina"]).function == "output"      # never floated


def test_takeover_levels_per_bridge_follow_their_tables(factory):
    lmd = take_gpio_outputs(cfg_of("sarcnet-mini").hardware.gpio, ("az", "el"), factory)
    lv = lmd.levels()
    assert lmd18200_state(lv["az lmd18200 pwm"], lv["az lmd18200 dir"], lv["az lmd18200 bridge_brake"]) == "brake"
    bts = take_gpio_outputs(cfg_of("bigras").hardware.gpio, ("az", "el"), factory)
    assert {k: v for k, v in bts.levels().items() if "pwm" in k} == {
        "az bts7960 rpwm": False, "az bts7960 lpwm": False, "el bts7960 rpwm": False, "el bts7960 lpwm": False}


def test_takeover_makes_every_claimable_line_safe_and_reports_the_rest(factory):
    """A line still held (its process not gone from the kernel) is reported; the others
    are still claimed safe. The relays of g5500 listed active low are driven high."""
    data = cfg_of("g5500").to_dict()
    data["hardware"]["gpio"]["az"]["active_low"] = ["cw", "ccw"]
    gpio = Config.from_dict(data).hardware.gpio
    busy = gpio.el.pins["cw"]
    real_pin = factory.pin

    def pin(n, *a, **k):
        if n == busy:
            raise OSError(16, "Device or resource busy")
        return real_pin(n, *a, **k)
    factory.pin = pin
    held = take_gpio_outputs(gpio, ("az", "el"), factory)
    assert [what for what, _ in held.failed] == ["el relay cw"] and "busy" in held.failed[0][1]
    assert held.levels()["el relay ccw"] is False and held.levels()["az relay cw"] is False
    assert real_pin(gpio.az.pins["cw"]).state == 1 and real_pin(gpio.az.pins["ccw"]).state == 1   # active low: off
    assert real_pin(gpio.el.pins["ccw"]).state == 0


def _channel(tmp_path: Path, duty_ns: int, period_ns: int, enabled: bool) -> Path:
    ch = tmp_path / "pwmchip0" / "pwm0"
    ch.mkdir(parents=True)
    (ch / "duty_cycle").write_text(str(duty_ns))
    (ch / "period").write_text(str(period_ns))
    (ch / "enable").write_text("1" if enabled else "0")
    return ch


def test_a_channel_a_dead_urc_left_enabled_is_switched_off_before_the_library_writes(tmp_path):
    """Review 20 #13: rpi-hardware-pwm writes the period before the duty; a duty left
    longer than the new period makes that fail (EINVAL), and urc fell back to software
    PWM with the channel still enabled. Duty 0 and enable 0 go straight to sysfs first."""
    ch = _channel(tmp_path, duty_ns=900_000, period_ns=1_000_000, enabled=True)   # 1 kHz, 90 %
    seen = {}

    class Library:
        def __init__(self, pwm_channel, hz, chip=0):
            seen["duty_at_init"] = (ch / "duty_cycle").read_text()
            seen["enable_at_init"] = (ch / "enable").read_text()
            if int(seen["duty_at_init"]) > 1e9 / hz:
                raise OSError(22, "Invalid argument")          # the kernel refuses the period
        def stop(self):
            pass
    HardwarePwm(12, 0, frequency_hz=20_000.0, pwm_class=Library, chip=0, sys_pwm=tmp_path)
    assert seen == {"duty_at_init": "0", "enable_at_init": "0"}
    assert sysfs_pwm_off(0, 1, tmp_path) is False               # not exported: nothing to do


def test_takeover_stops_satnogs_steppers_and_disables_their_chips(factory):
    """The takeover had no stepdir entry: STEP, DIR and ENABLE were never claimed. ENABLE
    is off at the chip's polarity (all four active low: the pin HIGH), not active_low's."""
    gpio = cfg_of("satnogs-v3").hardware.gpio
    held = take_gpio_outputs(gpio, ("az", "el"), factory)
    levels = held.levels()
    assert held.failed == []
    for axis in ("az", "el"):
        pins = getattr(gpio, axis).pins
        assert {k: levels[f"{axis} stepdir {k}"] for k in ("step", "dir", "enable")} == {
            "step": False, "dir": False, "enable": False}
        assert factory.pin(pins["enable"]).state                 # HIGH: the A4988's outputs off
        assert not factory.pin(pins["step"]).state and not factory.pin(pins["dir"]).state
