"""The front panel on a rotator without elevation ([rotator] elevation = false): the
BIG-RAS button row with "Elevation: OFF" (seed 002), UP/DOWN with no function on a
labelled panel, and displays that show no elevation."""

from __future__ import annotations

import pytest

from urc.frontpanel.lcd import CharLcd, Pcf8574Hd44780

AZ_ONLY = {"rotator": {"elevation": False}}
#: the BIG-RAS panel's five buttons, left to right, named by their two-axis functions
BIGRAS_ROW = {"down": 5, "up": 6, "stop": 13, "ccw": 19, "cw": 26}


def _az_after_press(rig, button, seconds=2.0):
    az0 = rig.settle().az.pos_deg
    rig.press(button)
    st = rig.run(seconds)
    held = rig.rot.local_controls()
    rig.release(button)
    rig.settle()
    return st.az.pos_deg - az0, held


def test_bigras_row_with_elevation_off_follows_the_document(panel_rig):
    rig = panel_rig("bigras", AZ_ONLY, buttons=BIGRAS_ROW, layout="big-ras")
    rig.rot.goto(180.0, 0.0)
    rig.settle()
    moved, held = _az_after_press(rig, "down")   # far left: turns left
    assert moved < -2.0 and held == ("CCW button",)
    moved, held = _az_after_press(rig, "cw")     # far right: turns right
    assert moved > 2.0 and held == ("CW button",)
    for second_or_fourth in ("up", "ccw"):       # no function: no motion, no hold, no beep
        played = len(rig.panel.beeper.played)
        moved, held = _az_after_press(rig, second_or_fourth)
        assert abs(moved) < 0.1 and held == () and len(rig.panel.beeper.played) == played
    # the middle one stops a remote goto
    rig.rot.goto(20.0, 0.0)
    rig.run(2.0)
    rig.press("stop")
    rig.release("stop")
    st = rig.settle()
    assert abs(st.az.pos_deg - 20.0) > 30.0, "stopped on its way"


def test_bigras_row_with_elevation_on_keeps_its_two_axis_functions(panel_rig):
    rig = panel_rig("bigras", buttons=BIGRAS_ROW, layout="big-ras")
    rig.rot.goto(180.0, 45.0)
    rig.settle()
    el0 = rig.rot.status().el.pos_deg
    moved, _ = _az_after_press(rig, "ccw")
    assert moved < -2.0
    rig.press("down")
    st = rig.run(2.0)
    rig.release("down")
    assert st.el.pos_deg < el0 - 2.0


def test_labelled_up_down_do_nothing_on_a_single_axis_rotator(panel_rig):
    """Before, UP on an az-only rotator registered a hold (refusing every client's
    motion while it was down) and beeped a refusal; now it has no function."""
    rig = panel_rig("tartu-urc", AZ_ONLY)
    rig.rot.goto(100.0, 0.0)
    rig.settle()
    rig.press("up")
    assert rig.rot.local_controls() == ()
    rig.rot.goto(150.0, 0.0)   # a client still commands while UP is down
    st = rig.settle()
    rig.release("down")
    rig.release("up")
    assert st.az.pos_deg == pytest.approx(150.0, abs=0.5)
    assert "refused" not in rig.panel.beeper.played
    moved, _ = _az_after_press(rig, "ccw")
    assert moved < -2.0, "CW/CCW work as labelled"


def test_zero_setting_starts_from_the_bigras_turn_buttons_on_a_single_axis_rotator(panel_rig):
    """Both turn buttons held at power-on (the far left and far right with elevation
    off); this crashed on the missing elevation before."""
    rig = panel_rig("bigras", AZ_ONLY, buttons=BIGRAS_ROW, layout="big-ras", held=("down", "cw"))
    assert rig.panel.zero is not None and rig.panel.zero.active
    assert rig.panel.zero.label == "AZ" and rig.panel.zero.value_deg == pytest.approx(rig.rot.status().az_deg, abs=0.1)


@pytest.mark.parametrize("rows", [2, 4])
def test_lcd_shows_no_elevation_on_a_single_axis_rotator(panel_rig, rows):
    chip = Pcf8574Hd44780(0x27, 20, rows)
    rig = panel_rig("tartu-urc", AZ_ONLY, display=CharLcd(chip, 0x27, 20, rows))
    rig.rot.goto(123.4, 45.0)
    rig.run(1.0)
    rig.panel.refresh_display()
    text = chip.text()
    assert text[0].startswith("AZ ") and ">123.4" in text[0]
    assert text[1].rstrip() == "TGT 123.4", "the elevation row carries the summary"
    assert not any("EL" in row or "+" in row for row in text), text
    rig.settle()
    seen = {row for screen in rig.screens_while_held("cw", chip) for row in screen}
    assert "LOCAL CW button" in seen and not any(r.startswith("EL") for r in seen)


def test_oled_rows_show_no_elevation_on_a_single_axis_rotator(panel_rig):
    from urc.frontpanel.screen import status_rows

    rig = panel_rig("tartu-urc", AZ_ONLY)
    rig.rot.goto(200.0, 0.0)
    rig.run(1.0)
    rows = status_rows(rig.rot.status(), 0.0, 21, 5, utc_unix_s=0.0)
    assert rows[1].rstrip() == "TGT 200.0" and "UTC 00:00:00" in [r.rstrip() for r in rows]
    assert not any(r.startswith("EL") for r in rows)


def test_config_layout_reaches_the_panel(bench):
    """[panel] layout = "big-ras" from a config file: build_panel wires the row so."""
    from urc.config import loads_config
    from urc.frontpanel import build_panel

    cfg = loads_config("""
[rotator]
elevation = false
[panel]
enabled = true
emulate = true
layout = "big-ras"
[panel.buttons]
down = 5
up = 6
stop = 13
ccw = 19
cw = 26
""", "p.toml")
    b = bench("bigras", **AZ_ONLY)
    panel = build_panel(cfg, b.rot)
    try:
        assert panel.actions == {"down": "ccw", "up": None, "stop": "stop", "ccw": None, "cw": "cw"}
    finally:
        panel.close()
