"""The takeover's build: every motor, relay, brake and heartbeat output claimed at its
safe level, and nothing else.

When the control process dies or freezes, the I/O process kills it and takes its
output lines. The full backend build opens the I2C and SPI buses, reads the ADCs,
FRAM and sensors, and builds each motor after its axis' ADC: one bus error (the very
thing a hung control process may have been stuck in) and no output was driven at all.
This build does no bus I/O: it claims each output line on its own, at the level that
stops the motor without needing PWM, so one line that cannot be claimed (still held by
a process the kernel has not let go of) does not keep the others from being made safe.

Safe levels (logical: ``active_low`` outputs are driven the other way):

* VNH5019: INA = INB = 1, PWM low — brake to VCC (ST VNH5019A-E §2.4; the row that
  brakes whatever the PWM input does);
* LMD18200: BRAKE high, PWM high (a plain high level), DIR low — brake (TI Table 1);
* BTS7960: RPWM = LPWM = 0, EN high where wired — both low sides on, braking;
* PWM + DIR boards: PWM low; relays (CW, CCW, fast, UP, DOWN): off;
* brake coils: off (engaged); heartbeat: low (no edges: the safety chain drops).

A motor PWM pin claimed as a plain output is taken from the PWM peripheral (lgpio
re-muxes it); the sysfs channel is then also disabled, best effort
(:func:`.pwm.sysfs_pwm_off`), so it does not come back on a pin re-muxed later.
"""

from __future__ import annotations

import logging
from typing import Any

from ...errors import ConfigError
from .pins import PinOut

log = logging.getLogger(__name__)

#: motor kind -> {pin key: safe logical level}
SAFE_LEVELS: dict[str, dict[str, bool]] = {
    "vnh5019": {"ina": True, "inb": True, "pwm": False},
    "lmd18200": {"pwm": True, "dir": False, "bridge_brake": True},
    "bts7960": {"rpwm": False, "lpwm": False, "en": True},
    "pwm_dir": {"pwm": False, "dir": False},
    "relay": {"cw": False, "ccw": False, "fast": False},
}


class OutputsHeld:
    """The output lines held at their safe levels. ``failed``: (what, why) for each
    line that could not be claimed (reported, never silently skipped)."""

    def __init__(self, factory: Any):
        self.factory = factory
        self.outputs: dict[str, tuple[PinOut, bool]] = {}
        self.failed: list[tuple[str, str]] = []

    def claim(self, what: str, pin: int, level: bool, active_low: bool) -> None:
        try:
            self.outputs[what] = (PinOut(self.factory, pin, initial=level, active_low=active_low), level)
        except Exception as exc:
            self.failed.append((what, f"GPIO{pin}: {exc}"))
            log.error("takeover: could not claim %s (GPIO%d) to make it safe: %s", what, pin, exc)

    def levels(self) -> dict[str, bool]:
        """What each claimed output reads back (logical)."""
        return {what: out.read_back() for what, (out, _) in self.outputs.items()}

    def drive_safe(self) -> None:
        """(Safe since the claim; written again for callers of the Hardware API.)"""
        for what, (out, level) in self.outputs.items():
            try:
                out.write(level)
            except Exception:
                log.exception("takeover: %s could not be written", what)

    def close(self) -> None:
        """Nothing to let go: the lines stay claimed at their safe levels until the
        process ends (gpiozero's close would float them)."""


def take_gpio_outputs(gpio: Any, axes: tuple[str, ...], factory: Any = None) -> OutputsHeld:
    """Claim every motor, relay, brake and heartbeat output of ``gpio`` (the
    ``[hardware.gpio]`` section) for ``axes`` at its safe level."""
    if factory is None:
        try:
            from gpiozero import Device
            factory = Device.pin_factory
            if factory is None:
                from gpiozero.pins.lgpio import LGPIOFactory
                factory = LGPIOFactory()
        except Exception as exc:  # no lgpio / not a Pi
            raise ConfigError(f"gpio takeover: no GPIO here ({exc})", key="hardware.gpio.emulate",
                              expected="true off a Pi", found=False) from exc
    held = OutputsHeld(factory)
    for name in axes:
        cfg = getattr(gpio, name, None)
        if cfg is None:
            continue
        for key, level in SAFE_LEVELS.get(cfg.motor, {}).items():
            if key in cfg.pins:
                held.claim(f"{name} {cfg.motor} {key}", cfg.pins[key], level, key in cfg.active_low)
        if "brake" in cfg.pins:
            held.claim(f"{name} brake", cfg.pins["brake"], False, "brake" in cfg.active_low)
    if gpio.heartbeat_pin is not None:
        held.claim("heartbeat", gpio.heartbeat_pin, False, False)
    _pwm_channels_off(gpio)
    return held


def _pwm_channels_off(gpio: Any) -> None:
    from .pwm import detect_pwm_chip, pwm_plan, sysfs_pwm_off
    try:
        chip, table = detect_pwm_chip(gpio)
        for _pin, channel in pwm_plan(gpio, table).values():
            if channel is not None:
                sysfs_pwm_off(chip, channel)
    except Exception:  # best effort: the pins are claimed already
        log.exception("takeover: could not disable the hardware PWM channels")
