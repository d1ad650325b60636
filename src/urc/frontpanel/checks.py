"""``[panel]`` checks beside the panel they describe (run by urc.config whenever a
configuration is validated): each GPIO used once, IR keys mapped to known actions, one
display. The panel's pins against the gpio backend's are checked there
(:mod:`urc.hardware.gpio.checks`)."""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from ..config.issues import Issue, suggest
from ..config.owners import register_check
from .controls import ACTIONS
from .settings import presets_issues, timezone_issues

if TYPE_CHECKING:
    from ..config import Config


def panel_issues(cfg: Config) -> list[Issue]:
    """[panel]: each GPIO used once, IR keys mapped to known actions, one display."""
    p = cfg.panel
    issues: list[Issue] = []
    used: dict[int, str] = {}
    pins = [(f"panel.buttons.{k}", v) for k, v in p.buttons.model_dump().items()] + \
        [(f"panel.leds.{k}", v) for k, v in p.leds.model_dump().items()] + [("panel.beeper", p.beeper)]
    if p.ir is not None:
        pins.append(("panel.ir.gpio_pin", p.ir.gpio_pin))
    for key, pin in pins:
        if pin is None:
            continue
        if pin in used:
            issues.append((key, f"a GPIO not already used by {used[pin]}", pin, ""))
        used.setdefault(pin, key)
    if p.lcd is not None and p.oled is not None:
        issues.append(("panel.oled", "one display: [panel.lcd] or [panel.oled], not both", "both", ""))
    issues += presets_issues(p.presets, p.buttons.model_dump()) + timezone_issues(p.timezone)
    if p.ir is not None:
        for name, action in p.ir.keys.items():
            if action not in ACTIONS:
                issues.append((f"panel.ir.keys.{name}", "one of " + ", ".join(ACTIONS), action,
                               suggest(action, list(ACTIONS))))
            if not (re.fullmatch(r"(KEY|BTN)_[A-Z0-9_]+", name) or re.fullmatch(r"0x[0-9a-fA-F]+|[0-9]+", name)):
                issues.append((f"panel.ir.keys.{name}", "an evdev key name such as KEY_LEFT, or a key code",
                               name, ""))
    return issues


# [panel] is checked whenever a configuration is validated (urc.registrations imports this)
register_check("panel", lambda cfg, _caps: panel_issues(cfg))
