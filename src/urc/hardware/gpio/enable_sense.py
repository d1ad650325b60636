"""The safety chain's read-back input (``motor_enable_sense_pin``): what the chain
gives the motors, read on a GPIO, so urc can see the chain cut (the start-up self-test,
:mod:`urc.hardware.safety_test`) instead of trusting it.

It reads one of two points (``motor_enable_sense_point``, docs/hardware.md "Safety
chain"): the relay's contact ("contact": a force-guided relay's normally-closed
auxiliary contact to GND, a dry contact at the Pi's 3.3 V, so a welded main contact
shows too) or the monostable's Q ("q": pin 6 through 1 kOhm; a Q1 failed shorted or a
welded contact does not show there). Emulated, the pin is driven from the modelled
chain (:mod:`..sim.safety`) before each read.
"""

from __future__ import annotations

from typing import Any, Callable

from .pins import PinIn

#: the points the read-back can be wired to
SENSE_POINTS = ("contact", "q")


class EnableSenseInput:
    """``read()``: True while the chain gives the motors power (the enable is on)."""

    def __init__(self, factory: Any, pin: int, *, active_low: bool = False, point: str = "contact"):
        if point not in SENSE_POINTS:
            raise ValueError(f"motor_enable_sense_point must be one of {', '.join(SENSE_POINTS)}, got {point!r}")
        # pulled up: a broken wire or an open contact reads high
        self.input = PinIn(factory, pin, pull="up")
        self.active_low = bool(active_low)
        self.point = point
        #: set when emulated: drives the mock pin from the modelled chain before a read
        self.feed: Callable[[], None] | None = None

    def read(self) -> bool:
        if self.feed is not None:
            self.feed()
        return self.input.read() != self.active_low

    def identify(self) -> str:
        what = "the relay's contact" if self.point == "contact" else "the monostable's Q"
        return (f"GPIO{self.input.number}, reads {what}: motor power "
                f"{'ON' if self.read() else 'off'}")


def emulated_feed(sense: EnableSenseInput, enable: Any, now_s: Callable[[], float]) -> Callable[[], None]:
    """The mock pin at the level the modelled chain puts on it now."""
    pin = sense.input.pin

    def feed() -> None:
        t_s = now_s()
        on = enable.powered_at(t_s) if sense.point == "contact" else enable.q_at(t_s)
        level = on != sense.active_low
        if level != bool(pin.state):
            (pin.drive_high if level else pin.drive_low)()
            pin.clear_states()
    return feed
