"""Which function each GPIO is routed to (its mux), and why urc must not take a pin off
the PWM peripheral.

A hardware PWM output exists only while its pin's function select says PWM. The
overlay (``dtoverlay=pwm-2chan,...`` or ``pwm``) routes the pin when the PWM driver
probes, at boot. Claiming the pin as a GPIO line (lgpio's ``gpio_claim_input`` or
``gpio_claim_output``: what gpiozero's ``factory.pin()`` does) re-muxes it to a GPIO
(Linux ``drivers/pinctrl/bcm/pinctrl-bcm2835.c``, ``bcm2835_pmx_gpio_set_direction``),
and freeing the line leaves it a GPIO input (``bcm2835_pmx_free``; an output where
``persist_gpio_outputs`` keeps it): nothing in the kernel routes it back to PWM before
the next boot. So a motor PWM pin that the overlay routed is driven only through its
sysfs PWM channel, never claimed as a line (:mod:`.pwm`, :mod:`.outputs_only`).

On iron the routing is read with Raspberry Pi's ``pinctrl get <gpio>`` (raspi-utils,
installed with Raspberry Pi OS; it reads /dev/gpiomem, group ``gpio``), whose line
ends ``// GPIO12 = <function>``. The names of the PWM functions differ per chip
(raspberrypi/utils ``pinctrl/gpiochip_bcm2835.c``, ``gpiochip_rp1.c``): ``PWM0`` /
``PWM1`` on a BCM2835/7 (Pi 3, Zero 2 W), ``PWM0_0`` / ``PWM0_1`` on a BCM2711 (Pi 4),
``PWM0_CHAN0`` .. ``PWM0_CHAN3`` on the RP1 (Pi 5). Emulated and in tests,
:class:`PinFunctions` models the same registers.
"""

from __future__ import annotations

import logging
import re
import shutil
import subprocess
from typing import Any, Callable, Protocol

log = logging.getLogger(__name__)

_PWM_FUNCTION = re.compile(r"^PWM(?:0_(?:CHAN)?(\d)|([01]))$")


def pwm_channel_of(function: str | None) -> int | None:
    """The PWM channel a pin's function name gives it (``PWM0_1`` -> 1), or None for
    anything else (``input``, ``output``, another peripheral, unknown)."""
    m = _PWM_FUNCTION.match(function or "")
    if m is None:
        return None
    return int(m.group(1) if m.group(1) is not None else m.group(2))


class PinFunctionReader(Protocol):
    def function(self, pin: int) -> str | None:
        """The pin's function name as ``pinctrl`` prints it, or None if it cannot be told."""


class Pinctrl:
    """The routing on iron, read with ``pinctrl get N``. ``function`` gives None when the
    tool is missing or fails (then urc assumes the pin may be routed to PWM)."""

    def __init__(self, exe: str | None = None, run: Callable[..., Any] = subprocess.run):
        self.exe = exe if exe is not None else shutil.which("pinctrl")
        self.run = run

    def function(self, pin: int) -> str | None:
        if self.exe is None:
            return None
        try:
            done = self.run([self.exe, "get", str(pin)], capture_output=True, text=True, timeout=5.0)
        except (OSError, subprocess.SubprocessError) as exc:
            log.warning("pinctrl get %d failed: %s", pin, exc)
            return None
        out = (done.stdout or "").strip()
        if done.returncode != 0 or "=" not in out:
            return None
        return out.rsplit("=", 1)[1].strip() or None


class PinFunctions:
    """The function select of each pin, modelled (emulation and tests): ``routed`` pins
    start on their peripheral function (the overlay's work at boot); claiming a pin as a
    GPIO line makes it ``input`` or ``output``, as the bcm2835 pinctrl driver does, and
    only :meth:`route` (a reboot, or ``pinctrl set``) gives it back."""

    def __init__(self, routed: dict[int, str] | None = None):
        self.functions: dict[int, str] = dict(routed or {})
        #: pins claimed as GPIO lines, in order
        self.claims: list[int] = []

    def function(self, pin: int) -> str:
        return self.functions.get(pin, "input")

    def claimed(self, pin: int, output: bool = False) -> None:
        self.claims.append(pin)
        self.functions[pin] = "output" if output else "input"

    def route(self, pin: int, function: str) -> None:
        self.functions[pin] = function


def pin_functions(factory: Any) -> PinFunctionReader | None:
    """The routing reader for the pins of ``factory``: its own model if it has one
    (``pin_functions``), ``pinctrl`` on lgpio (iron), else None (not known)."""
    model = getattr(factory, "pin_functions", None)
    if model is not None:
        return model  # type: ignore[no-any-return]
    if type(factory).__name__ == "LGPIOFactory":
        return Pinctrl()
    return None


def routing_note(function: str | None, channel: int) -> str:
    """What ``urc hw check`` and the log say about a pin planned for PWM ``channel``."""
    if function is None:
        return "routing not checked (no pinctrl)"
    got = pwm_channel_of(function)
    return f"routed to PWM{channel}" if got == channel else f"NOT routed to PWM{channel} (pinctrl: {function})"
