"""The LCD (RPLCD over an emulated PCF8574 + HD44780, bytes decoded back into
characters) and the OLED (luma.oled over an emulated SSD1306) show the Tartu content."""

from __future__ import annotations

import pytest

from urc.frontpanel.lcd import CharLcd, Pcf8574Hd44780
from urc.protocols.tartu_codec import lcd_rows
from urc.testing.sessions import fed


def test_lcd_20x2_shows_the_tartu_rows(panel_rig):
    chip = Pcf8574Hd44780(0x27, 20, 2)
    rig = panel_rig(display=CharLcd(chip, 0x27, 20, 2))
    assert chip.four_bit and chip.display_on and chip.backlight
    rig.rot.goto(123.4, 45.6)
    rig.run(1.0)
    rig.panel.refresh_display()
    text = chip.text()
    assert text == lcd_rows(rig.rot.status())
    assert text[0].startswith("AZ ") and ">123.4" in text[0] and text[0].endswith("RUN")
    assert text[1].startswith("EL ") and ">045.6" in text[1]
    st = rig.settle()
    rig.panel.refresh_display()
    writes = chip.writes
    assert chip.text() == [f"AZ {st.az.pos_deg:05.1f}>123.4   HLD", f"EL {st.el.pos_deg:05.1f}>045.6   HLD"]
    rig.panel.refresh_display()
    assert chip.writes == writes, "nothing is written when nothing changed"


def test_lcd_20x4_shows_fault_with_its_blink_code(panel_rig):
    chip = Pcf8574Hd44780(0x27, 20, 4)
    rig = panel_rig(display=CharLcd(chip, 0x27, 20, 4))
    rig.bench.world.inject("az", "jam")
    rig.rot.goto(90.0, 90.0)
    rig.run(10.0, until=lambda s: bool(s.faults))
    rig.panel.refresh_display()
    text = chip.text()
    assert text[0].rstrip().endswith("FLT")
    assert text[2].rstrip() == "E5 overcurrent az"  # code 5, as the error LED blinks


def test_lcd_20x2_alternates_the_message_row(panel_rig):
    chip = Pcf8574Hd44780(0x27, 20, 2)
    rig = panel_rig(display=CharLcd(chip, 0x27, 20, 2))
    rig.rot.goto(100.0, 30.0)
    rig.settle()
    seen = {screen[1] for screen in rig.screens_while_held("cw", chip)}
    assert "LOCAL CW button" in seen and any(s.startswith("EL ") for s in seen)


def test_oled_shows_the_same_rows():
    pytest.importorskip("luma.oled")
    from urc.frontpanel.oled import Oled, Ssd1306Bus, render

    chip = Ssd1306Bus(0x3C, 128, 64)
    oled = Oled(chip, 0x3C, 128, 64)
    oled.contrast(0x40)
    rows = ["AZ 123.4>130.0   RUN", "EL 045.0         HLD", "E1 stall az", "TGT 130.0 +45.0"]
    oled.show(rows)
    assert chip.on and chip.contrast == 0x40
    glass = chip.image()
    assert glass.tobytes() == render(rows, 128, 64).tobytes()
    assert glass.tobytes() != render(rows[:1], 128, 64).tobytes()


def test_tartu_lcdc_sets_the_oled_contrast(panel_rig):
    pytest.importorskip("luma.oled")
    from urc.frontpanel.oled import Oled, Ssd1306Bus
    from urc.protocols.tartu import TartuSession

    chip = Ssd1306Bus(0x3C, 128, 64)
    rig = panel_rig(display=Oled(chip, 0x3C, 128, 64))
    rig.panel.refresh_display()
    assert chip.contrast == 0xCF, "luma's power-on contrast until a client sets one"
    assert fed(TartuSession(rig.rot), b"LCDC 10\r\n") == [b"OK\r\n"]
    rig.panel.refresh_display()
    assert chip.contrast == round(10 * 255 / 63)


def test_oled_panel_shows_position_target_and_utc_time(panel_rig):
    """Berkeley's OLED: encoder and target data and the time."""
    pytest.importorskip("luma.oled")
    from urc.frontpanel.oled import Oled, Ssd1306Bus, render

    chip = Ssd1306Bus(0x3C, 128, 64)
    rig = panel_rig("berkeley", display=Oled(chip, 0x3C, 128, 64))
    rig.panel.wall_s = lambda: 1.7e9
    rig.rot.goto(123.4, 45.6)
    rig.settle()
    rig.panel.refresh_display()
    rows = rig.panel.display_rows()
    assert len(rows) == 5 and rows[:2] == [r.ljust(21) for r in lcd_rows(rig.rot.status())]
    assert rows[3].rstrip() == "TGT 123.4 +45.6" and rows[4].rstrip() == "UTC 22:13:20"
    assert chip.image().tobytes() == render(rows, 128, 64).tobytes()
