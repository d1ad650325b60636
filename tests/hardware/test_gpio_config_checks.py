"""`urc config check` on the pin map: every pin (the front panel's too) against every
other and the buses' pins; outputs that are on while the Pi boots; the safety chain."""

from __future__ import annotations

from pathlib import Path

import pytest

from urc.config import Config, load_config
from urc.errors import ConfigError
from urc.hardware.gpio.checks import BOOT_HIGH_PINS, gpio_warnings

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
GPIO_EXAMPLES = sorted(p for p in EXAMPLES.glob("*.toml") if 'backend = "gpio"' in p.read_text())


def example(name: str, **changes) -> dict:
    data = load_config(EXAMPLES / f"{name}.toml").to_dict()
    for path, value in changes.items():
        node = data
        *head, last = path.split(".")
        for k in head:
            node = node.setdefault(k, {})
        node[last] = value
    return data


@pytest.mark.parametrize("path", GPIO_EXAMPLES, ids=lambda p: p.stem)
def test_examples_keep_outputs_off_at_boot_and_wire_the_safety_chain(path):
    cfg = load_config(path)
    g = cfg.hardware.gpio
    assert g.heartbeat_pin is not None and g.motor_enable_timeout_s is not None
    assert g.motor_enable_timeout_s <= 0.25
    assert not [n for n in gpio_warnings(cfg) if "power-on" in n or "safety chain" in n]
    for name in cfg_axes(cfg):
        ax = getattr(g, name)
        assert not ax.limit_active_low          # normally-closed limit switches


def cfg_axes(cfg: Config) -> list[str]:
    return [n for n in ("az", "el") if getattr(cfg.hardware.gpio, n) is not None]


@pytest.mark.parametrize("section, pin, taken_by", [
    ("panel.buttons.cw", 24, "hardware.gpio.az.pins.ina"),          # the case, on today's map
    ("panel.buttons.ccw", 10, "SPI0"),                              # the MCP3008's MOSI
    ("panel.leds.fault", 12, "hardware.gpio.az.pins.pwm"),
])
def test_panel_pins_are_checked_against_the_motor_and_bus_pins(section, pin, taken_by):
    with pytest.raises(ConfigError, match=section.replace(".", r"\.")) as exc:
        Config.from_dict(example("tartu-urc", **{section: pin}))
    assert taken_by in str(exc.value)


@pytest.mark.parametrize("name", ["tartu-urc", "bigras"])
def test_an_ir_receiver_pin_is_checked_against_every_other_pin(name):
    """The docs used to put the gpio-ir receiver on GPIO17: tartu-urc's az encoder A and
    bigras' az reed input. The pin the docs give now (14) is free in every example."""
    ir = {"device": "/dev/input/by-path/platform-ir-receiver@11-event"}
    with pytest.raises(ConfigError, match=r"panel\.ir\.gpio_pin") as exc:
        Config.from_dict(example(name, **{"panel.ir": {**ir, "gpio_pin": 17}}))
    assert "az.pins." in str(exc.value)
    with pytest.raises(ConfigError, match=r"panel\.ir\.gpio_pin"):        # a panel LED on it too
        Config.from_dict(example(name, **{"panel.ir": {**ir, "gpio_pin": 14}, "panel.leds.fault": 14}))
    for path in GPIO_EXAMPLES:
        Config.from_dict(example(path.stem, **{"panel.ir": {**ir, "gpio_pin": 14}}))


def test_i2c_pins_are_reserved_while_a_chip_is_on_the_bus():
    with pytest.raises(ConfigError, match=r"panel\.leds\.fault.*I2C1 SCL"):
        Config.from_dict(example("berkeley", **{"panel.leds.fault": 3}))
    with pytest.raises(ConfigError, match=r"hardware\.gpio\.az\.pins\.dir.*I2C1 SDA"):
        Config.from_dict(example("berkeley", **{"hardware.gpio.az.pins": {"pwm": 12, "dir": 2}}))


def test_an_output_high_at_boot_is_warned_about_unless_pulled_down():
    assert BOOT_HIGH_PINS == frozenset(range(9))
    cfg = Config.from_dict(example("g5500", **{"hardware.gpio.az.pins": {"cw": 5, "ccw": 6}}))
    notes = [n for n in gpio_warnings(cfg) if "power-on" in n]
    assert len(notes) == 2 and notes[0].startswith("hardware.gpio.az.pins.ccw: GPIO6 is pulled HIGH")
    cfg = Config.from_dict(example("g5500", **{"hardware.gpio.az.pins": {"cw": 5, "ccw": 6},
                                               "hardware.gpio.pulled_down": [5, 6]}))
    assert not [n for n in gpio_warnings(cfg) if "power-on" in n]
    # an active-low relay module is off when its pin is high: fine on GPIO5, not on 23
    cfg = Config.from_dict(example("g5500", **{"hardware.gpio.az.pins": {"cw": 5, "ccw": 23},
                                               "hardware.gpio.az.active_low": ["cw", "ccw"]}))
    notes = [n for n in gpio_warnings(cfg) if "power-on" in n]
    assert len(notes) == 1 and "ccw: active low on GPIO23" in notes[0]


def test_active_low_names_output_pins_and_the_part_needs_the_heartbeat():
    with pytest.raises(ConfigError, match=r"hardware\.gpio\.az\.active_low"):
        Config.from_dict(example("tartu-urc", **{"hardware.gpio.az.active_low": ["enc_a"]}))
    with pytest.raises(ConfigError, match=r"motor_enable_timeout_s.*heartbeat_pin"):
        Config.from_dict(example("tartu-urc", **{"hardware.gpio.heartbeat_pin": None}))
    cfg = Config.from_dict(example("tartu-urc", **{"hardware.gpio.motor_enable_timeout_s": None}))
    assert any("no safety chain declared" in n for n in gpio_warnings(cfg))


def test_a_heartbeat_pulled_up_at_boot_is_warned_about():
    cfg = Config.from_dict(example("g5500", **{"hardware.gpio.heartbeat_pin": 4}))
    assert any(n.startswith("hardware.gpio.heartbeat_pin: GPIO4 is pulled high at power-on")
               for n in gpio_warnings(cfg))


def test_a_bts7960_current_sense_warns_of_a_pwm_frequency_its_filter_does_not_suit():
    sensed = {"hardware.gpio.az.current_sense_channel": 0}
    for hz, warned in ((1000.0, False), (500.0, False), (5000.0, False), (100.0, True), (20000.0, True)):
        cfg = Config.from_dict(example("bigras", **sensed, **{"hardware.gpio.az.pwm_frequency_hz": hz}))
        notes = [n for n in gpio_warnings(cfg) if n.startswith("hardware.gpio.az.pwm_frequency_hz")]
        assert bool(notes) == warned, (hz, notes)
    # no current sense: no filter to suit
    cfg = Config.from_dict(example("bigras", **{"hardware.gpio.az.pwm_frequency_hz": 100.0}))
    assert not [n for n in gpio_warnings(cfg) if "pwm_frequency_hz" in n and "BTS7960" in n]


def test_pins_with_a_boot_time_function_are_warned_about():
    """Review 35 #9: active-low relays on GPIO0/1 passed (high at boot is their "off"),
    but the firmware probes the HAT ID EEPROM on those pins at boot; a heartbeat on
    GPIO14 (UART TXD, the boot messages) passed too. Both warn now, whatever the level."""
    cfg = Config.from_dict(example("g5500", **{"hardware.gpio.az.pins": {"cw": 0, "ccw": 1},
                                               "hardware.gpio.az.active_low": ["cw", "ccw"]}))
    notes = [n for n in gpio_warnings(cfg) if "while the Pi boots" in n]
    assert notes == [
        "hardware.gpio.az.pins.ccw: GPIO1: ID_SC (the HAT ID EEPROM's I2C clock, probed by the firmware at "
        "boot): the output toggles while the Pi boots, before urc claims it; use a free pin from GPIO9-27 "
        "(GPIO4-8 with active_low)",
        "hardware.gpio.az.pins.cw: GPIO0: ID_SD (the HAT ID EEPROM's I2C data, probed by the firmware at "
        "boot): the output toggles while the Pi boots, before urc claims it; use a free pin from GPIO9-27 "
        "(GPIO4-8 with active_low)"]
    assert not [n for n in gpio_warnings(cfg) if "power-on" in n]        # (high at boot is their off)
    cfg = Config.from_dict(example("tartu-urc", **{"hardware.gpio.heartbeat_pin": 14}))
    (note,) = [n for n in gpio_warnings(cfg) if "while the Pi boots" in n]
    assert note.startswith("hardware.gpio.heartbeat_pin: GPIO14: UART TXD") and "safety chain's relay" in note
    cfg = Config.from_dict(example("g5500", **{"hardware.gpio.el.pins": {"cw": 15, "ccw": 21},
                                               "hardware.gpio.pulled_down": [15]}))
    assert [n.split(":")[0] for n in gpio_warnings(cfg) if "while the Pi boots" in n] == ["hardware.gpio.el.pins.cw"]


def test_an_output_or_heartbeat_high_at_boot_is_warned_about():
    """GPIO0-8 are pulled up at power-on (BCM2835 peripherals §6.2, Table 6-31, the pull
    column): a motor output or the heartbeat there is high until urc claims it."""
    cfg = Config.from_dict(example("tartu-urc", **{"hardware.gpio.heartbeat_pin": 4}))
    assert any(n.startswith("hardware.gpio.heartbeat_pin: GPIO4 is pulled high") for n in gpio_warnings(cfg))
    cfg = Config.from_dict(example("tartu-urc", **{"hardware.gpio.az.pins": {
        "ina": 4, "inb": 25, "pwm": 12, "enc_a": 17, "enc_b": 27, "brake": 16}}))
    assert any(n.startswith("hardware.gpio.az.pins.ina: GPIO4 is pulled HIGH") for n in gpio_warnings(cfg))


def test_the_safety_chain_read_back_is_checked():
    """The read-back's pin is one pin among the others, reads a chain that exists, at a
    point it can be wired to; a chain without one is warned about (it cannot be tested)."""
    with pytest.raises(ConfigError, match=r"motor_enable_sense_pin.*GPIO18 is hardware.gpio.heartbeat_pin"):
        Config.from_dict(example("g5500", **{"hardware.gpio.motor_enable_sense_pin": 18}))
    with pytest.raises(ConfigError, match=r"hardware.gpio.el.pins.cw.*GPIO22 is hardware.gpio.motor_enable_sense_pin"):
        Config.from_dict(example("g5500", **{"hardware.gpio.el.pins": {"cw": 22, "ccw": 21}}))
    cfg = Config.from_dict(example("g5500", **{"hardware.gpio.heartbeat_pin": None,
                                               "hardware.gpio.motor_enable_timeout_s": None}))
    assert any(n.startswith("hardware.gpio.motor_enable_sense_pin: a read-back with no safety chain")
               for n in gpio_warnings(cfg))
    with pytest.raises(ConfigError, match=r"motor_enable_sense_point"):
        Config.from_dict(example("g5500", **{"hardware.gpio.motor_enable_sense_point": "coil"}))
    cfg = Config.from_dict(example("g5500", **{"hardware.gpio.motor_enable_sense_pin": None}))
    assert any(n.startswith("hardware.gpio.motor_enable_sense_pin: the safety chain is not read back")
               for n in gpio_warnings(cfg))
    cfg = Config.from_dict(example("g5500", **{"hardware.gpio.motor_enable_sense_pin": 14}))
    assert any("motor_enable_sense_pin" in n and "UART TXD" in n for n in gpio_warnings(cfg))


def test_a_stepper_enable_is_judged_at_its_chips_polarity():
    """ENABLE is active low on the step/dir chips: on a pin pulled low at boot the boards
    are enabled while the Pi boots (the check took it as active high: no warning)."""
    cfg = Config.from_dict(example("satnogs-v3", **{"hardware.gpio.az.pins": {"step": 17, "dir": 27, "enable": 22}}))
    notes = [n for n in gpio_warnings(cfg) if "power-on" in n]
    assert len(notes) == 1 and "az.pins.enable" in notes[0]
    cfg = Config.from_dict(example("satnogs-v3", **{"hardware.gpio.az.pins": {"step": 17, "dir": 27, "enable": 5}}))
    assert not [n for n in gpio_warnings(cfg) if "power-on" in n]
