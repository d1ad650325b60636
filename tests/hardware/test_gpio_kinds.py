"""The gpio backend's kind tables (urc.hardware.gpio.kinds) serve both its builder and
the configuration check: every kind in a table is accepted by validation and built by
the builder, and a kind missing from it is refused by both in the same words."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from urc.assembly import hardware_options
from urc.cli import with_emulation
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.config.issues import error_from_issues
from urc.errors import ConfigError
from urc.hardware.drivers import (As5600Sensor, Bts7960Motor, CompassSensor, Lmd18200Motor, PotSensor,
                                  PwmDirMotor, QuadratureEncoder, RelayMotor, SpidPulseSensor, Vnh5019Motor)
from urc.hardware.drivers.stepper import StepDirMotor
from urc.hardware.gpio import build_gpio_hardware
from urc.hardware.gpio.checks import gpio_issues
from urc.hardware.gpio.kinds import MOTORS, SENSORS

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

#: what each motor kind must be built as (written out here, not read from the table)
MOTOR_CLASSES = {"vnh5019": Vnh5019Motor, "lmd18200": Lmd18200Motor, "bts7960": Bts7960Motor,
                 "pwm_dir": PwmDirMotor, "relay": RelayMotor, "stepdir": StepDirMotor}
#: a shipped example per sensor kind, and the driver it must get
SENSOR_EXAMPLES = {"encoder": ("tartu-urc", QuadratureEncoder), "pulse": ("bigras", SpidPulseSensor),
                   "pot": ("g4jnt", PotSensor), "as5600": ("berkeley", As5600Sensor),
                   "magnetometer": ("sarcnet-mini", CompassSensor)}
#: free BCM pins per axis (no I2C1, no SPI0, none pulled high at boot)
POOL = {"az": [12, 14, 15, 16, 17, 22, 27], "el": [13, 19, 20, 21, 23, 24, 25]}


def test_every_kind_in_the_tables_is_covered_here():
    assert set(MOTOR_CLASSES) == set(MOTORS)
    assert set(SENSOR_EXAMPLES) == set(SENSORS)


def _motor_config(kind: str) -> dict:
    """tartu-urc (PWM drive, encoders, brakes) or g4jnt (relay drive, pots on an
    MCP3008) with ``kind`` on both axes and every pin its parts need."""
    profile = "g4jnt" if MOTORS[kind].drive == "relay" else "tartu-urc"
    data = load_config(EXAMPLES / f"{profile}.toml").to_dict()
    caps = Config.from_dict(data).caps
    for name in ("az", "el"):
        ax = data["hardware"]["gpio"][name]
        # (a stepper is its own sensor: its step count)
        need = list(MOTORS[kind].pins) + ([] if MOTORS[kind].own_sensor is not None
                                          else list(SENSORS[caps.axis(name).sensor.kind].pins))
        need += ["brake"] if caps.axis(name).brake else []
        ax["motor"] = kind
        ax["pins"] = dict(zip(need, POOL[name]))
        ax.pop("current_sense_channel", None)
    data["hardware"]["gpio"]["emulate"] = True
    data["hardware"]["gpio"].pop("heartbeat_pin", None)
    data["hardware"]["gpio"].pop("motor_enable_timeout_s", None)
    return data


def _build(cfg: Config, state_dir: Path):
    return build_gpio_hardware(cfg.caps, VirtualClock(1000.0), state_dir, hardware_options(cfg))


@pytest.mark.parametrize("kind", sorted(MOTORS))
def test_a_motor_kind_in_the_table_is_accepted_and_built(kind, tmp_path):
    cfg = Config.from_dict(_motor_config(kind))
    hw = _build(cfg, tmp_path)
    try:
        for name in ("az", "el"):
            assert type(hw.axis(name).motor.driver) is MOTOR_CLASSES[kind]
    finally:
        hw.close()


@pytest.mark.parametrize("kind", sorted(MOTORS))
def test_each_pin_a_motor_kind_needs_is_asked_for(kind):
    data = _motor_config(kind)
    for pin in MOTORS[kind].pins:
        pins = dict(data["hardware"]["gpio"]["az"]["pins"])
        del pins[pin]
        broken = {**data, "hardware": {**data["hardware"], "gpio": {
            **data["hardware"]["gpio"], "az": {**data["hardware"]["gpio"]["az"], "pins": pins}}}}
        with pytest.raises(ConfigError) as err:
            Config.from_dict(broken)
        assert err.value.key == f"hardware.gpio.az.pins.{pin}" and f"needed by {kind}" in str(err.value)


@pytest.mark.parametrize("kind", sorted(SENSORS))
def test_a_sensor_kind_in_the_table_is_accepted_and_built(kind, tmp_path):
    example, cls = SENSOR_EXAMPLES[kind]
    cfg = with_emulation(load_config(EXAMPLES / f"{example}.toml"))
    assert cfg.caps.az.sensor.kind == kind
    hw = _build(cfg, tmp_path)
    try:
        assert type(hw.az.sensor) is cls
    finally:
        hw.close()


def test_an_unknown_motor_kind_is_refused_by_both_in_the_same_words(tmp_path):
    data = _motor_config("vnh5019")
    data["hardware"]["gpio"]["az"]["motor"] = "stepper"
    with pytest.raises(ConfigError) as checked:
        Config.from_dict(data, source="<config>")
    # the same section handed to the builder without the check (as a caller could)
    section = Config.from_dict(_motor_config("vnh5019")).hardware.gpio
    assert section is not None and section.az is not None
    bad = section.model_copy(update={"az": section.az.model_copy(update={"motor": "stepper"})})
    cfg = Config.from_dict(_motor_config("vnh5019"))
    with pytest.raises(ConfigError) as built:
        build_gpio_hardware(cfg.caps, VirtualClock(1000.0), tmp_path, {"gpio": bad, "emulate": True})
    assert str(built.value) == str(checked.value)
    assert checked.value.key == "hardware.gpio.az.motor" and "one of vnh5019" in str(checked.value)
    assert not list(tmp_path.iterdir())   # refused before the simulator or any pin was made


def test_an_unknown_sensor_kind_is_refused_by_both_in_the_same_words(tmp_path):
    cfg = Config.from_dict(_motor_config("vnh5019"))
    caps = cfg.caps
    # a profile whose sensor only another backend reads (the bridge's "controller")
    odd = dataclasses.replace(caps, az=dataclasses.replace(caps.az, sensor=dataclasses.replace(
        caps.az.sensor, kind="controller")))
    issues = gpio_issues(cfg, odd)
    assert [i[0] for i in issues] == ["hardware.gpio.az"] and issues[0][2] == "controller"
    with pytest.raises(ConfigError) as built:
        build_gpio_hardware(odd, VirtualClock(1000.0), tmp_path, {"gpio": cfg.hardware.gpio, "emulate": True})
    assert str(built.value) == str(error_from_issues(issues, "<config>"))
