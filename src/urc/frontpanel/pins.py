"""Where the front panel's gpiozero devices get their pins.

One small function so that the gpio backend can later own the choice (``[hardware.gpio]
emulate``): real pins through lgpio on a Raspberry Pi, gpiozero's own MockFactory when
emulated (a laptop, the tests). The devices never learn which: gpiozero's pin-factory
seam is exactly that.
"""

from __future__ import annotations

from typing import Any

from ..errors import HardwareError


def pin_factory(emulate: bool) -> Any:
    """A gpiozero pin factory: MockFactory when ``emulate`` (pins that can PWM, as a
    passive beeper's needs), else lgpio's."""
    if emulate:
        from gpiozero.pins.mock import MockFactory, MockPWMPin

        return MockFactory(pin_class=MockPWMPin)
    try:
        from gpiozero.pins.lgpio import LGPIOFactory

        return LGPIOFactory()
    except Exception as exc:  # no lgpio module, no /dev/gpiochip, not a Pi
        raise HardwareError(f"front panel: no GPIO pins here ({exc}); install urc with its [pi] extra (pip install '.[pi]' in the clone) on a Raspberry "
                            "Pi, or set [panel] emulate = true") from exc
