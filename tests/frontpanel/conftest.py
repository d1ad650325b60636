"""A front panel on gpiozero MockFactory pins, beside a simulated rotator on virtual time."""

from __future__ import annotations

import pytest
from gpiozero.pins.mock import MockFactory

from urc.frontpanel.panel import FrontPanel

BUTTONS = {"cw": 5, "ccw": 6, "up": 13, "down": 19, "stop": 26, "park": 21, "slow": 20}
LEDS = {"cw": 12, "ccw": 16, "up": 23, "down": 24, "fault": 25}
BEEPER = 18


class PanelRig:
    def __init__(self, bench, display=None, ir=None, power_on=True, held=(), buttons=None,
                 layout="labelled"):
        self.bench = bench
        self.rot = bench.rot
        self.factory = MockFactory()
        self.buttons = buttons or BUTTONS
        self.panel = FrontPanel(self.rot, pin_factory=self.factory, buttons=self.buttons, leds=LEDS,
                                beeper_pin=BEEPER, display=display, ir=ir, layout=layout)
        for name in held:  # buttons already down at power-on
            self.pin(name).drive_low()
        if power_on:
            self.panel.power_on()

    def pin(self, button: str):
        return self.factory.pin(self.buttons[button])

    def led(self, name: str) -> bool:
        return bool(self.factory.pin(LEDS[name]).state)

    def press(self, button: str):
        self.pin(button).drive_low()

    def release(self, button: str):
        self.pin(button).drive_high()

    def screens_while_held(self, button: str, chip, seconds: int = 4) -> list[list[str]]:
        """What ``chip`` shows (rows, trailing blanks off), once a second while ``button``
        is held; released afterwards."""
        self.press(button)
        screens = []
        for _ in range(seconds):
            self.run(1.0)
            self.panel.refresh_display()
            screens.append([row.rstrip() for row in chip.text()])
        self.release(button)
        return screens

    def run(self, seconds: float, until=None, on_tick=None):
        """Virtual time with the panel updated every tick, as run_panel does on a Pi."""
        def tick(st):
            self.panel.update(st.t_s)
            if on_tick is not None:
                on_tick(st)
        return self.bench.run(seconds, until=until, on_tick=tick)

    def settle(self, timeout_s: float = 60.0):
        return self.run(timeout_s, until=lambda s: not s.moving and all(
            a.mode in ("holding", "idle") for a in (s.az, s.el) if a is not None))


@pytest.fixture
def panel_rig(bench):
    rigs = []

    def make(profile: str = "tartu-urc", config: dict | None = None, **kw) -> PanelRig:
        rig = PanelRig(bench(profile, **(config or {})), **kw)
        rigs.append(rig)
        return rig
    yield make
    for rig in rigs:
        rig.panel.close()
