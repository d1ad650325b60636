"""The BIG-RAS preset knobs (seed 002): potentiometers P1/P2 read through an ADC.

A knob is a potentiometer across the knobs' supply, its wiper on an ADC input: the
reading over the supply's (on another ADS1115 input, or the MCP3008's VREF) is where
the knob stands, 0..1, whatever the supply. urc's choice where the document is silent:
a knob's travel spans the azimuth as bearings 0..360 (the rotator's routing picks the
turn, overturn included) and the elevation over its limits (0..90, or 0..180 on an
over-the-top rotator); presets are whole degrees, so a knob's last-bit jitter does not
make the display flicker.

With one knob (``pots = 1``) P1 sets both axes, each over its own span. A reading that
cannot be trusted (no answer from the ADC, a supply that reads wrong) is an error, never
a direction: the preset button that asked moves nothing.
"""

from __future__ import annotations

from typing import Any

from ..hardware.parts import PartError

#: a supply reading outside this share of full scale is a wiring fault, not a knob
REFERENCE_RANGE = (0.8, 1.05)


class PresetKnob:
    """One knob on an ADC input (an ``Ads1115Channel`` or ``Mcp3008Channel``:
    ``read_counts``, ``read_reference_counts``, ``full_scale_counts``)."""

    def __init__(self, name: str, adc: Any):
        self.name, self.adc = name, adc

    def fraction(self) -> float:
        """Where the knob stands, 0 (fully anticlockwise) .. 1."""
        try:
            ref = self.adc.read_reference_counts()
            counts = self.adc.read_counts()
        except OSError as exc:
            raise PartError(f"preset knob {self.name}: ADC does not answer ({exc})") from exc
        full = self.adc.full_scale_counts
        lo, hi = REFERENCE_RANGE
        if not lo * full <= ref <= hi * full:
            raise PartError(f"preset knob {self.name}: supply reads {ref} counts, expected "
                            f"{lo * full:.0f}..{hi * full:.0f} (knob supply or wiring)")
        return min(max(counts / ref, 0.0), 1.0)


class PresetKnobs:
    """P1 (and P2) and the direction each axis' preset names now."""

    def __init__(self, p1: PresetKnob, p2: PresetKnob | None = None):
        self.p1, self.p2 = p1, p2

    def knob(self, axis: str) -> PresetKnob:
        return self.p2 if axis == "el" and self.p2 is not None else self.p1

    def preset_deg(self, axis: str, st: Any) -> float:
        """The azimuth bearing 0..359 or the elevation the knob for ``axis`` names, in
        whole degrees; ``st``: the rotator's status (its elevation limits)."""
        f = self.knob(axis).fraction()
        if axis == "az":
            return float(round(f * 360.0) % 360)
        lo, hi = st.limits.get("el", (0.0, 90.0))
        off = st.offsets.get("el", 0.0)
        return float(round(lo + off + f * (hi - lo)))


def build_knobs(presets: Any, emulate: bool) -> tuple[PresetKnobs, Any]:
    """The knobs ``[panel.presets]`` describes, and the bus or SPI device they are
    read through (emulated: the fake chip, whose inputs :class:`EmulatedKnobs` turns)."""
    from ..hardware.gpio.i2c import Ads1115Chip, Ads1115Channel
    from ..hardware.gpio.spi import Mcp3008Channel, Mcp3008Chip, open_spidev

    channels = [("P1", presets.p1_channel)] + ([("P2", presets.p2_channel)] if presets.pots == 2 else [])
    if presets.adc == "mcp3008":
        if emulate:
            from ..hardware.gpio.emulate import FakeMcp3008
            dev: Any = FakeMcp3008({}, vref_v=3.3)
        else:
            dev = open_spidev(presets.spi_device)
        chip: Any = Mcp3008Chip(dev, presets.spi_device, vref_v=3.3, name="preset MCP3008")
        knobs = [PresetKnob(n, Mcp3008Channel(chip, ch, None)) for n, ch in channels]
    else:
        if emulate:
            from ..hardware.gpio.emulate import FakeAds1115, FakeSMBus
            dev = FakeSMBus()
            dev.devices[presets.address] = FakeAds1115({presets.reference_channel: lambda: 3.3})
        else:
            from smbus2 import SMBus
            dev = SMBus(presets.bus)
        chip = Ads1115Chip(dev, presets.address, "preset ADS1115")
        knobs = [PresetKnob(n, Ads1115Channel(chip, ch, presets.reference_channel)) for n, ch in channels]
    return PresetKnobs(*knobs), dev


class EmulatedKnobs:
    """Turn the emulated knobs (tests, a laptop): the wiper's share of the 3.3 V supply
    on the fake ADC's input."""

    SUPPLY_V = 3.3

    def __init__(self, presets: Any, dev: Any):
        self.presets = presets
        self.chip = dev if presets.adc == "mcp3008" else dev.devices[presets.address]

    def turn(self, knob: str, fraction: float) -> None:
        ch = self.presets.p1_channel if knob == "P1" else self.presets.p2_channel
        v = min(max(float(fraction), 0.0), 1.0) * self.SUPPLY_V
        self.chip.inputs[ch] = lambda: v
