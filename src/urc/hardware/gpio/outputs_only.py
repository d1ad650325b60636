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
* step/dir drivers: STEP and DIR low, ENABLE off at the chip's own polarity (active low
  on all four, :mod:`..drivers.stepdir_chips`; ``enable_active_low`` overrides), never
  ``active_low``'s;
* brake coils: off (engaged); heartbeat: low (no edges: the safety chain drops).

A motor PWM pin routed to the PWM peripheral is never claimed as a line: that would
make it a GPIO until the next boot (:mod:`.pinmux`), and every later start would find
its hardware PWM dead. Its channel is set through sysfs instead
(:class:`.pwm.PwmChannelLevel`): duty 0 and disabled for a low level (the pin idles
low), duty = period for the LMD18200's high. A PWM pin that is a GPIO already (software
PWM, or not routed by the overlay) is claimed like any output.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from ...errors import ConfigError
from .pins import PinOut

log = logging.getLogger(__name__)

#: motor kind -> {pin key: safe logical level}
SAFE_LEVELS: dict[str, dict[str, bool]] = {
    "vnh5019": {"ina": True, "inb": True, "pwm": False},
    # (BRAKE first: with BRAKE high the PWM input only chooses brake or coast, never drive)
    "lmd18200": {"bridge_brake": True, "dir": False, "pwm": True},
    "bts7960": {"rpwm": False, "lpwm": False, "en": True},
    "pwm_dir": {"pwm": False, "dir": False},
    "relay": {"cw": False, "ccw": False, "fast": False},
    "stepdir": {"step": False, "dir": False, "enable": False},
}


class OutputsHeld:
    """The output lines held at their safe levels. ``failed``: (what, why) for each
    line that could not be claimed (reported, never silently skipped)."""

    def __init__(self, factory: Any):
        self.factory = factory
        #: what -> (a PinOut, or a PwmChannelLevel for a pin left on its PWM channel; its level)
        self.outputs: dict[str, tuple[Any, bool]] = {}
        self.failed: list[tuple[str, str]] = []

    def claim(self, what: str, pin: int, level: bool, active_low: bool) -> None:
        try:
            self.outputs[what] = (PinOut(self.factory, pin, initial=level, active_low=active_low), level)
        except Exception as exc:
            self.failed.append((what, f"GPIO{pin}: {exc}"))
            log.error("takeover: could not claim %s (GPIO%d) to make it safe: %s", what, pin, exc)

    def hold_channel(self, what: str, channel: Any, level: bool) -> None:
        """A motor PWM pin routed to its hardware channel: the level set through sysfs
        (:class:`.pwm.PwmChannelLevel`), the pin never claimed. A high level that cannot
        be set (the LMD18200's PWM) falls back to low: BRAKE high with PWM low coasts
        (TI LMD18200 Table 1), it never drives."""
        try:
            channel.write(level)
        except OSError as exc:
            self.failed.append((what, f"{channel!r}: {exc}"))
            log.error("takeover: could not set %s (%r) %s through sysfs: %s", what, channel,
                      "high" if level else "low", exc)
            if level:
                try:
                    channel.write(False)
                except OSError:
                    pass
        self.outputs[what] = (channel, level)

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
        """Every claimed line let go at its safe level, for the restarted control process
        to claim: the I/O process lives on after a takeover, and a line it still requests
        is EBUSY to any other (gpiozero's LGPIOFactory has no ``__del__`` and lg closes no
        handle when it is collected; review of the takeover, outputs_only.py). Freed
        with ``lgpio.gpio_free``, never gpiozero's close (that reclaims it as an input,
        floating): on Raspberry Pi OS a freed output keeps its level
        (``persist_gpio_outputs``). Mock pins hold no kernel line; a pin on its PWM
        channel was never claimed."""
        for what, (out, _) in self.outputs.items():
            pin: Any = getattr(out, "pin", None)
            handle = getattr(getattr(pin, "factory", None), "_handle", None)
            if type(pin).__name__ != "LGPIOPin" or handle is None:
                continue
            try:
                import lgpio
                lgpio.gpio_free(handle, pin._number)
            except Exception:
                log.exception("takeover: could not let go of %s", what)


def take_gpio_outputs(gpio: Any, axes: tuple[str, ...], factory: Any = None, *,
                      sys_pwm: Path | None = None, functions: Any = None) -> OutputsHeld:
    """Claim every motor, relay, brake and heartbeat output of ``gpio`` (the
    ``[hardware.gpio]`` section) for ``axes`` at its safe level; a motor PWM pin routed
    to its hardware channel is set through sysfs instead. ``functions``: the pins'
    routing (:func:`.pinmux.pin_functions` of the factory unless given)."""
    from . import pwm as pwm_mod
    from .pinmux import pin_functions
    from .pwm import PwmChannelLevel, detect_pwm_chip, pwm_plan, routed_to_pwm

    sys_pwm = pwm_mod.SYS_PWM if sys_pwm is None else sys_pwm

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
    if functions is None:
        functions = pin_functions(factory)
    try:
        chip, table = detect_pwm_chip(gpio, sys_pwm)
        plan = pwm_plan(gpio, table)
    except Exception:  # (the plan is config arithmetic; detection reads sysfs)
        log.exception("takeover: could not tell the hardware PWM channels; every PWM pin is claimed")
        chip, plan = 0, {}
    held = OutputsHeld(factory)
    for name in axes:
        cfg = getattr(gpio, name, None)
        if cfg is None:
            continue
        for key, level in SAFE_LEVELS.get(cfg.motor, {}).items():
            if key not in cfg.pins:
                continue
            what, pin = f"{name} {cfg.motor} {key}", cfg.pins[key]
            channel = plan.get(f"{name}.{key}", (pin, None))[1]
            if channel is not None and routed_to_pwm(functions, pin, channel, chip, sys_pwm):
                held.hold_channel(what, PwmChannelLevel(pin, chip, channel, frequency_hz=cfg.pwm_frequency_hz,
                                                        sys_pwm=sys_pwm), level)
            else:
                held.claim(what, pin, level, _active_low(cfg, key))
                if channel is not None:     # a GPIO already: its channel (routed elsewhere, if anywhere) off
                    _channel_off(chip, channel, sys_pwm)
        if "brake" in cfg.pins:
            held.claim(f"{name} brake", cfg.pins["brake"], False, "brake" in cfg.active_low)
    if gpio.heartbeat_pin is not None:
        held.claim("heartbeat", gpio.heartbeat_pin, False, False)
    return held


def _active_low(cfg: Any, key: str) -> bool:
    if cfg.motor == "stepdir" and key == "enable":
        from .stepdir import STEPDIR_CHIPS
        if cfg.enable_active_low is not None:
            return bool(cfg.enable_active_low)
        chip = STEPDIR_CHIPS.get(cfg.stepper_driver)
        return chip.enable_active_low if chip is not None else True     # (all four chips')
    return key in cfg.active_low


def _channel_off(chip: int, channel: int, sys_pwm: Path) -> None:
    from .pwm import sysfs_pwm_off
    try:
        sysfs_pwm_off(chip, channel, sys_pwm)
    except Exception:  # best effort: the pin is claimed already
        log.exception("takeover: could not disable pwmchip%d/pwm%d", chip, channel)
