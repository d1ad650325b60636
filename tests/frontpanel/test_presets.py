"""BIG-RAS preset knobs P1/P2 with SW7 (azimuth there), SW8 (elevation there) and SW10
(show where), seed 002; and the panel clock. The knobs are read through the real ADC
drivers over emulated chips (an ADS1115 on a fake SMBus, an MCP3008 behind a fake SPI)."""

from __future__ import annotations

import pytest

from urc.config import loads_config
from urc.errors import ConfigError
from urc.frontpanel import build_panel
from urc.frontpanel.presets import EmulatedKnobs
from urc.frontpanel.screen import clock_text, status_rows

PANEL = """
[panel]
enabled = true
emulate = true
layout = "big-ras"
[panel.buttons]
stop = 26
park = 21
preset_az = 5
preset_el = 6
show_preset = 13
[panel.lcd]
rows = 2
[panel.presets]
{presets}
"""


def rig(bench, presets="pots = 2", profile="bigras", referenced=True):
    b = bench(profile)
    if referenced:
        b.rot.set_position(b.truth("az"), b.truth("el"))     # a pulse rotator starts unreferenced
        b.run(0.1)
    cfg = loads_config(PANEL.format(presets=presets), "p.toml")
    panel = build_panel(cfg, b.rot)
    knobs = EmulatedKnobs(cfg.panel.presets, panel.presets_bus)
    return b, panel, knobs


def press(panel, name):
    panel.buttons[name].pin.drive_low()


def release(panel, name):
    panel.buttons[name].pin.drive_high()


def tap(panel, name):
    press(panel, name)
    release(panel, name)


def settle(b, panel, seconds=200.0):
    return b.run(seconds, until=lambda s: not s.moving and s.az.mode in ("holding", "idle")
                 and (s.el is None or s.el.mode in ("holding", "idle")),
                 on_tick=lambda st: panel.update(st.t_s))


@pytest.mark.parametrize("adc", ["ads1115", "mcp3008"])
def test_sw7_turns_the_azimuth_to_p1_and_sw8_the_elevation_to_p2(bench, adc):
    b, panel, knobs = rig(bench, f'pots = 2\nadc = "{adc}"')
    try:
        el_before = b.truth("el")
        knobs.turn("P1", 0.25)            # a quarter of the knob: east
        knobs.turn("P2", 0.5)             # half: 45 of 0..90
        tap(panel, "preset_az")
        st = settle(b, panel)
        assert st.az_deg == pytest.approx(90.0, abs=0.6)
        assert b.truth("el") == pytest.approx(el_before, abs=0.5)    # SW7: azimuth only
        tap(panel, "preset_el")
        st = settle(b, panel)
        assert st.el_deg == pytest.approx(45.0, abs=0.6)
        assert st.az_deg == pytest.approx(90.0, abs=0.6)
        assert panel.beeper.played[-2:] == ["click", "click"]
    finally:
        panel.close()


def test_one_common_knob_sets_both_axes_each_over_its_own_span(bench):
    b, panel, knobs = rig(bench, "pots = 1")
    try:
        knobs.turn("P1", 0.5)
        for name in ("preset_az", "preset_el"):
            tap(panel, name)
            settle(b, panel)
        st = b.rot.status()
        assert st.az_deg == pytest.approx(180.0, abs=0.6) and st.el_deg == pytest.approx(45.0, abs=0.6)
    finally:
        panel.close()


def test_sw10_held_shows_where_sw7_and_sw8_would_turn_while_the_knob_moves(bench):
    b, panel, knobs = rig(bench)
    try:
        knobs.turn("P1", 0.5)
        knobs.turn("P2", 1.0)
        assert "PRESET" not in "".join(panel.display_rows())
        press(panel, "show_preset")
        assert [r.rstrip() for r in panel.display_rows()] == ["PRESET AZ 180", "PRESET EL 090"]
        knobs.turn("P1", 0.1)             # turning the knob: the display follows
        assert panel.display_rows()[0].rstrip() == "PRESET AZ 036"
        release(panel, "show_preset")
        assert "PRESET" not in "".join(panel.display_rows())
        assert not b.rot.status().moving   # showing moves nothing
    finally:
        panel.close()


def test_a_preset_while_the_position_is_unknown_is_refused_and_moves_nothing(bench):
    b, panel, knobs = rig(bench)
    try:
        b.rot.search_frame("az", 434.0)                  # a homing runs: position unknown
        b.run(0.1)
        knobs.turn("P1", 0.75)
        tap(panel, "preset_az")
        b.run(2.0, on_tick=lambda st: panel.update(st.t_s))
        st = b.rot.status()
        assert not st.moving and st.az.duty == 0.0 and st.target_az_deg is None
        assert panel.beeper.played[-1] == "refused" and "preset_az" in panel.controls.last_refusal
    finally:
        panel.close()


def test_an_unreadable_knob_supply_is_refused_never_a_direction(bench):
    b, panel, knobs = rig(bench)
    try:
        knobs.turn("P1", 0.5)
        knobs.chip.inputs[3] = lambda: 0.4            # the knobs' supply wire broken
        tap(panel, "preset_az")
        b.run(1.0, on_tick=lambda st: panel.update(st.t_s))
        assert not b.rot.status().moving and b.rot.status().target_az_deg is None
        assert panel.beeper.played[-1] == "refused" and "supply" in panel.controls.last_refusal
        press(panel, "show_preset")
        assert panel.display_rows()[0].rstrip() == "PRESET AZ ---"
    finally:
        panel.close()


def test_preset_config_is_checked():
    for text, key in (("[panel.buttons]\npreset_az = 5\n", "panel.buttons.preset_az"),
                      ("[panel.presets]\np1_channel = 3\n", "panel.presets.reference_channel"),
                      ('[panel.presets]\nadc = "ads1115"\np2_channel = 5\n', "panel.presets.p2_channel"),
                      ("[panel.presets]\npots = 3\n", "panel.presets.pots"),
                      ('[panel]\ntimezone = "Mars/Olympus"\n', "panel.timezone")):
        with pytest.raises(ConfigError) as exc:
            loads_config(text, "p.toml")
        assert exc.value.key == key, (text, exc.value.key)
    # one common knob: P2's input is free for anything
    loads_config("[panel.presets]\npots = 1\np2_channel = 3\n", "p.toml")


def test_clock_in_utc_or_local_time_with_summer_time(bench):
    summer = 1782820800.0            # 2026-06-30 12:00:00 UTC
    winter = 1767268800.0            # 2026-01-01 12:00:00 UTC
    assert clock_text(summer) == "UTC 12:00:00"
    assert clock_text(summer, "Europe/Budapest") == "CEST 14:00:00"
    assert clock_text(winter, "Europe/Budapest") == "CET 13:00:00"
    st = bench("bigras").rot.status()
    rows = status_rows(st, 0.0, 20, 4, summer, "Europe/Budapest", clock=True)
    assert rows[2].rstrip() == "CEST 14:00:00"
    assert "14:00" not in "".join(status_rows(st, 0.0, 20, 4, summer, "Europe/Budapest"))
    assert status_rows(st, 0.0, 21, 5, summer, "Europe/Budapest")[4].rstrip() == "CEST 14:00:00"


def test_panel_clock_follows_the_configured_zone(bench):
    cfg = loads_config('[panel]\nenabled = true\nemulate = true\nclock = true\ntimezone = "Asia/Tokyo"\n'
                       "[panel.lcd]\nrows = 4\n", "p.toml")
    b = bench("bigras")
    b.rot.set_position(b.truth("az"), b.truth("el"))
    b.run(0.1)
    panel = build_panel(cfg, b.rot)
    try:
        panel.wall_s = lambda: 1782820800.0
        assert panel.display_rows()[2].rstrip() == "JST 21:00:00"
    finally:
        panel.close()
