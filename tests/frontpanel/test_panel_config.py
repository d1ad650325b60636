"""The [panel] section: validated like every other key (file, key, expected, found)."""

from __future__ import annotations

import pytest

from urc.config import loads_config
from urc.errors import ConfigError


def test_panel_defaults_off():
    cfg = loads_config("")
    assert not cfg.panel.enabled and cfg.panel.lcd is None


def test_panel_section_parses():
    cfg = loads_config("""
[panel]
enabled = true
emulate = true
beeper = 18
[panel.buttons]
cw = 5
ccw = 6
[panel.leds]
fault = 25
[panel.lcd]
address = 0x3f
rows = 4
[panel.ir]
device = "/dev/input/event3"
keys = { KEY_LEFT = "ccw", KEY_RIGHT = "cw", KEY_POWER = "stop" }
""", "p.toml")
    assert cfg.panel.buttons.cw == 5 and cfg.panel.lcd.address == 0x3F and cfg.panel.lcd.rows == 4
    assert cfg.panel.ir.keys["KEY_POWER"] == "stop"


@pytest.mark.parametrize("text, key, found", [
    ("[panel.buttons]\ncw = 5\nccw = 5\n", "panel.buttons.ccw", "5"),
    ("[panel]\nbeeper = 60\n", "panel.beeper", "60"),
    ("[panel.lcd]\nrows = 3\n[panel.oled]\n", "panel.oled", "both"),
    ("[panel.lcd]\ncols = 40\n", "panel.lcd.cols", "40"),
    ('[panel.ir]\ndevice = "/dev/input/event0"\nkeys = { KEY_LEFT = "left" }\n', "panel.ir.keys.KEY_LEFT", "left"),
    ('[panel.ir]\ndevice = "/dev/input/event0"\nkeys = { left = "cw" }\n', "panel.ir.keys.left", "left"),
    ("[panel]\nbutons = 1\n", "panel.butons", "butons"),
    ('[panel]\nlayout = "bigras"\n', "panel.layout", "bigras"),
])
def test_panel_errors_name_file_key_expected_found(text, key, found):
    with pytest.raises(ConfigError) as exc:
        loads_config(text, "p.toml")
    msg = str(exc.value)
    assert msg.startswith("p.toml") and key in msg and "expected" in msg and found in msg, msg
