"""urc's own ADC parts as a received-power source (urc.pointing.adc.AdcPower), with the
saturation set from the chip's full scale: the code a clipped input reads."""

from __future__ import annotations

from typing import Any

from ...pointing.adc import AdcPower
from .i2c import AdcInput


def ads1115_power(chip: Any, channel: int, **kw: Any) -> AdcPower:
    """Input ``channel`` of an :class:`~urc.hardware.gpio.i2c.Ads1115Chip`; saturated
    at its full-scale code 7FFFh (4.096 V at urc's gain)."""
    kw.setdefault("ceiling_v", chip.FS_V * 32767 / 32768)
    kw.setdefault("name", f"ADS1115 AIN{channel}")
    return AdcPower(AdcInput(chip, channel), **kw)


def mcp3008_power(chip: Any, channel: int, **kw: Any) -> AdcPower:
    """Input ``channel`` of an :class:`~urc.hardware.gpio.spi.Mcp3008Chip`; saturated
    at code 1023 (VREF)."""
    kw.setdefault("ceiling_v", chip.vref_v * 1023 / 1024)
    kw.setdefault("name", f"MCP3008 CH{channel}")
    return AdcPower(AdcInput(chip, channel), **kw)
