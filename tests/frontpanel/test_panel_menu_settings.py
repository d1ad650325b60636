"""BIG-RAS menu settings on the front panel (seed 002): beeper type (off, an active
beeper, or a passive one's tone in Hz) and a beep on each command from a port, the
backlight and the screensaver."""

from __future__ import annotations

import pytest
from gpiozero.pins.mock import MockFactory, MockPWMPin

from urc.config import loads_config
from urc.errors import ConfigError
from urc.frontpanel import build_panel
from urc.frontpanel.lcd import CharLcd, Pcf8574Hd44780
from urc.frontpanel.oled import Oled, Ssd1306Bus
from urc.frontpanel.panel import FrontPanel

from .conftest import BEEPER, BUTTONS


def make_panel(bench, display=None, **kw):
    b = bench("bigras")
    b.rot.set_position(b.truth("az"), b.truth("el"))        # a pulse rotator starts unreferenced
    b.run(0.1)
    factory = MockFactory(pin_class=MockPWMPin)
    panel = FrontPanel(b.rot, pin_factory=factory, buttons=BUTTONS, beeper_pin=BEEPER, display=display,
                       layout="big-ras", **kw)
    panel.power_on()
    return b, factory, panel


def run(b, panel, seconds):
    return b.run(seconds, on_tick=lambda st: panel.update(st.t_s))


def beeper_levels(b, panel, factory, seconds=0.2):
    """What the beeper pin carried each tick (its PWM value or on/off state)."""
    seen = []
    b.run(seconds, on_tick=lambda st: (panel.update(st.t_s), seen.append(factory.pin(BEEPER).state)))
    return seen


@pytest.mark.parametrize("beeper_type, tone_hz, sounding", [("dc", None, 1), (1000, 1000, 0.5), ("off", None, None)])
def test_beeper_type(bench, beeper_type, tone_hz, sounding):
    b, factory, panel = make_panel(bench, beeper_type=beeper_type)
    panel.beeper.beep("refused")
    levels = beeper_levels(b, panel, factory)
    if sounding is None:        # off: the pin is never claimed, nothing sounds
        assert all(not v for v in levels)
        assert BEEPER not in [d.pin.info.number for d in panel._devices if hasattr(d, "pin")]
    else:
        assert sounding in levels and 0 in levels
    if tone_hz is not None:     # a passive beeper: a square wave at the set tone
        assert factory.pin(BEEPER).frequency == tone_hz


def test_beep_on_each_command_from_a_port(bench):
    b, factory, panel = make_panel(bench, beep_on_command=True)
    run(b, panel, 2.0)
    before = len(panel.beeper.played)
    b.rot.goto(30.0, 10.0)                      # what a protocol session does
    run(b, panel, 0.2)
    assert panel.beeper.played[before:] == ["command"]
    b.rot.goto(31.0, 10.0)
    run(b, panel, 0.2)
    assert panel.beeper.played[before:] == ["command", "command"]
    b2, _, quiet = make_panel(bench)            # off unless asked for
    run(b2, quiet, 2.0)
    b2.rot.goto(30.0, 10.0)
    run(b2, quiet, 0.2)
    assert "command" not in quiet.beeper.played


def test_lcd_backlight_and_screensaver(bench):
    chip = Pcf8574Hd44780(0x27, 20, 2)
    b, factory, panel = make_panel(bench, display=CharLcd(chip, 0x27, 20, 2), screensaver_s=5.0)
    panel.refresh_display()
    assert chip.backlight and chip.display_on
    run(b, panel, 4.0)
    assert chip.backlight and not panel.asleep
    run(b, panel, 1.5)                          # 5 s without a key: dark
    assert panel.asleep and not chip.backlight and not chip.display_on
    factory.pin(BUTTONS["stop"]).drive_low()    # a key wakes it
    factory.pin(BUTTONS["stop"]).drive_high()
    run(b, panel, 0.1)
    assert chip.backlight and chip.display_on and not panel.asleep
    chip2 = Pcf8574Hd44780(0x27, 20, 2)
    _, _, dark = make_panel(bench, display=CharLcd(chip2, 0x27, 20, 2), backlight_pct=0)
    dark.refresh_display()
    assert not chip2.backlight


def test_oled_backlight_is_its_brightness(bench):
    bus = Ssd1306Bus(0x3C, 128, 64)
    b, factory, panel = make_panel(bench, display=Oled(bus, contrast=200), backlight_pct=50, screensaver_s=2.0)
    assert bus.contrast == 100 and bus.on
    run(b, panel, 2.5)
    assert not bus.on
    factory.pin(BUTTONS["stop"]).drive_low()
    factory.pin(BUTTONS["stop"]).drive_high()
    run(b, panel, 0.1)
    assert bus.on and bus.contrast == 100


def test_menu_settings_in_the_configuration(bench):
    cfg = loads_config("""
[panel]
enabled = true
emulate = true
beeper = 18
beeper_type = 2400
beep_on_command = true
backlight_pct = 40
screensaver_s = 30
[panel.oled]
""", "p.toml")
    panel = build_panel(cfg, bench("bigras").rot)
    try:
        assert panel.beeper.output.pwm.frequency == 2400 and panel.beep_on_command
        assert panel.display.full_contrast == 0xCF
        assert panel.screensaver_s == 30 and panel.backlight_pct == 40
    finally:
        panel.close()
    for text, key in (("beeper_type = 100", "panel.beeper_type"), ('beeper_type = "on"', "panel.beeper_type"),
                      ("backlight_pct = 101", "panel.backlight_pct"), ("screensaver_s = -1", "panel.screensaver_s")):
        with pytest.raises(ConfigError) as exc:
            loads_config(f"[panel]\n{text}\n", "p.toml")
        assert exc.value.key == key


def test_autoturn_goes_on_after_a_5_s_hold_until_a_key(bench):
    b, factory, panel = make_panel(bench, autoturn=True)
    cw = factory.pin(BUTTONS["cw"])
    cw.drive_low()
    run(b, panel, 1.0)
    cw.drive_high()                               # a short hold: stops on release
    st = run(b, panel, 3.0)
    assert not st.moving and not panel.controls.autoturning
    cw.drive_low()
    run(b, panel, 5.5)
    cw.drive_high()                               # held 5 s: goes on by itself
    az0 = run(b, panel, 0.1).az.pos_deg
    st = run(b, panel, 3.0)
    assert st.moving and st.az.pos_deg > az0 + 5 and panel.controls.autoturning == {"az": "cw"}
    assert st.local_control == ()                 # no longer held: the ports are not locked out
    stop = factory.pin(BUTTONS["stop"])           # a key ends it
    stop.drive_low()
    stop.drive_high()
    st = b.settle()
    assert not st.moving and not panel.controls.autoturning
    # the same hold without autoturn stops on release
    b2, f2, plain = make_panel(bench)
    f2.pin(BUTTONS["cw"]).drive_low()
    run(b2, plain, 5.5)
    f2.pin(BUTTONS["cw"]).drive_high()
    assert not b2.settle().moving


def test_autoturn_runs_to_the_end_of_travel(bench):
    b, factory, panel = make_panel(bench, autoturn=True)
    b.rot.goto(400.0, 0.0)
    b.settle()
    factory.pin(BUTTONS["cw"]).drive_low()
    run(b, panel, 5.5)
    factory.pin(BUTTONS["cw"]).drive_high()
    st = b.run(120.0, until=lambda s: not s.moving)
    assert st.az.pos_deg == pytest.approx(b.rot.status().limits["az"][1], abs=1.5) and not st.faults
