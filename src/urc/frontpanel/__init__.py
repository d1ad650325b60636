"""The local front panel (issue 11): push-buttons, IR remote, status LEDs, beeper and an
LCD or OLED, all through the rotator service's command gate. See :mod:`.panel`.

Heavy imports (gpiozero, RPLCD, luma, evdev) happen only in :func:`build_panel`, so the
core stays importable without them.
"""

from __future__ import annotations

from typing import Any, Callable


def build_panel(cfg, rotator, dispatch: Callable[..., None] | None = None):
    """The FrontPanel ``[panel]`` describes, or None when it is not enabled."""
    p = cfg.panel
    if not p.enabled:
        return None
    from .ir import DEFAULT_KEYS, EmulatedKeys, key_codes, open_device
    from .panel import FrontPanel
    from .pins import pin_factory

    display: Any = None
    if p.lcd is not None:
        from .lcd import CharLcd, Pcf8574Hd44780

        bus = Pcf8574Hd44780(p.lcd.address, p.lcd.cols, p.lcd.rows) if p.emulate else _smbus(p.lcd.bus)
        display = CharLcd(bus, p.lcd.address, p.lcd.cols, p.lcd.rows)
    elif p.oled is not None:
        from .oled import Oled, Ssd1306Bus

        bus = Ssd1306Bus(p.oled.address, p.oled.width, p.oled.height) if p.emulate else _smbus(p.oled.bus)
        display = Oled(bus, p.oled.address, p.oled.width, p.oled.height, contrast=p.oled.contrast)
    ir = None
    if p.ir is not None:
        source = EmulatedKeys() if p.emulate else open_device(p.ir.device)
        ir = (source, key_codes(p.ir.keys or DEFAULT_KEYS))
    presets = None
    if p.presets is not None:
        from .presets import build_knobs

        presets, presets_bus = build_knobs(p.presets, p.emulate)
    buttons = {k: v for k, v in p.buttons.model_dump().items() if v is not None}
    leds = {k: v for k, v in p.leds.model_dump().items() if v is not None}
    panel = FrontPanel(rotator, pin_factory=pin_factory(p.emulate), buttons=buttons, leds=leds,
                       beeper_pin=p.beeper, display=display, ir=ir, layout=p.layout, jog_speed=p.jog_speed,
                       slow_speed=p.slow_speed, bounce_time_s=None if p.emulate or not p.bounce_s else p.bounce_s,
                       dispatch=dispatch, beeper_type=p.beeper_type, beep_on_command=p.beep_on_command,
                       backlight_pct=p.backlight_pct, screensaver_s=p.screensaver_s, autoturn=p.autoturn,
                       presets=presets, clock=p.clock, timezone=p.timezone)
    if presets is not None:
        panel.presets_bus = presets_bus      # closed with the panel; emulated: the knobs' chip
    panel.power_on()
    return panel


def _smbus(bus: int):
    from smbus2 import SMBus

    return SMBus(bus)


async def serve_panel(cfg, rotator, stop) -> None:
    """``urc run``'s front panel, beside the control loop until ``stop`` is set. Button
    callbacks (lgpio's thread) are carried onto this event loop, where every protocol
    session talks to the rotator too. A panel that cannot start is reported and left
    out: the controller runs on without it."""
    import asyncio

    if not cfg.panel.enabled:
        return
    from .panel import run_panel  # (lazy: a urc run without a panel never loads it)

    loop = asyncio.get_running_loop()

    def dispatch(fn: Callable[..., object], *args: object) -> None:
        loop.call_soon_threadsafe(fn, *args)

    try:
        # built in a worker thread: imports and the LCD's power-on sequence take long
        # enough to make the control loop miss its deadline
        panel = await asyncio.to_thread(build_panel, cfg, rotator, dispatch)
    except Exception as exc:
        print(f"urc: front panel not started: {exc}", flush=True)
        return
    print("urc: front panel on " + ("emulated pins" if cfg.panel.emulate else "GPIO"), flush=True)
    try:
        await run_panel(panel, stop, cfg.panel.refresh_hz)
    finally:
        panel.close()
