"""Checks of the BIG-RAS preset knobs (``[panel.presets]``; its model is config's,
:class:`urc.config.panel_sections.PanelPresets`) and the panel clock's time zone, with no
heavy imports so that checking a configuration loads neither gpiozero nor smbus2.

Seed 002: potentiometers P1 and P2 set a direction; SW7 turns the azimuth there, SW8 the
elevation, SW10 shows the knobs' direction on the display. ``pots = 1``: one knob (P1)
for both axes, ``pots = 2``: P1 azimuth, P2 elevation (the firmware's ``pot`` parameter).
"""

from __future__ import annotations

from typing import Any

from ..config.panel_sections import PanelPresets

#: inputs per converter (as the axes' ADCs: urc.config)
ADC_INPUTS = {"ads1115": 4, "mcp3008": 8}


def presets_issues(presets: PanelPresets | None, pots_buttons: dict[str, Any]) -> list[tuple[str, str, Any, str]]:
    """``[panel.presets]`` against itself and the panel's buttons: inputs that exist and
    are used once, and a knob for each preset button fitted."""
    issues: list[tuple[str, str, Any, str]] = []
    fitted = [k for k in ("preset_az", "preset_el", "show_preset") if pots_buttons.get(k) is not None]
    if presets is None:
        for key in fitted:
            issues.append((f"panel.buttons.{key}", "a [panel.presets] section (the knobs it reads)",
                           pots_buttons[key], ""))
        return issues
    n = ADC_INPUTS[presets.adc]
    inputs = [("p1_channel", presets.p1_channel)]
    if presets.pots == 2:
        inputs.append(("p2_channel", presets.p2_channel))
    if presets.adc == "ads1115":
        inputs.append(("reference_channel", presets.reference_channel))
    seen: dict[int, str] = {}
    for key, ch in inputs:
        if ch >= n:
            issues.append((f"panel.presets.{key}", f"an {presets.adc.upper()} input 0..{n - 1}", ch, ""))
        elif ch in seen:
            issues.append((f"panel.presets.{key}", f"an input not already used (it is {seen[ch]})", ch, ""))
        seen.setdefault(ch, key)
    return issues


def timezone_issues(name: str) -> list[tuple[str, str, Any, str]]:
    """``[panel] timezone``: a name the system's time-zone database knows."""
    from zoneinfo import ZoneInfo

    try:
        ZoneInfo(name)
    except (ValueError, OSError, KeyError):
        return [("panel.timezone", "a time zone such as \"UTC\" or \"Europe/Budapest\" (IANA name)", name, "")]
    return []
