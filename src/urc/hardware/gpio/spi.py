"""SPI parts: an MCP3008 10-bit ADC reading a pot and its supply (G4JNT, G-5500 class).

The transfer goes through an ``xfer2(bytes) -> bytes`` SPI device: py-spidev's
``SpiDev`` on SPI0 on a Pi (``pip install '.[pi]'`` from the clone, SPI enabled with raspi-config), the
emulated chip (:class:`urc.hardware.gpio.emulate.FakeMcp3008`) elsewhere. The three-byte
MCP3008 frame is written here rather than through gpiozero's ``MCP3008``: gpiozero 2.0
caches its software SPI bus by pin names across pin factories, so two emulated
rotators in one process (every test run) could read each other's chip.
"""

from __future__ import annotations

from typing import Any

from ..parts import PartError
from .i2c import with_retries

#: SPI0's pins (BCM): SCLK, MOSI, MISO, and the chip select of each device (CE0, CE1)
SPI0_PINS = {"sclk": 11, "mosi": 10, "miso": 9}
SPI0_CE = {0: 8, 1: 7}
MCP3008_CHANNELS = 8


def open_spidev(device: int, speed_hz: int = 1_000_000) -> Any:
    """SPI0 chip select ``device`` through the kernel's spidev (mode 0; the MCP3008 runs
    up to 1.35 MHz at 2.7 V)."""
    import spidev

    spi = spidev.SpiDev()
    spi.open(0, device)
    spi.max_speed_hz = speed_hz
    spi.mode = 0
    return spi


class Mcp3008Chip:
    """One MCP3008 on SPI0 (chip select CE``device``), single-ended inputs.

    Frame (MSB first): MOSI 0000 0001 | S D2 D1 D0 xxxx | xxxx xxxx, the start bit
    aligned so that MISO's last ten bits are the result: ...x 0 B9 B8 | B7..B0 (a
    sample clock and a null bit after D0). ``vref_v``: what VREF is wired to."""

    COUNTS = 1024

    def __init__(self, spi: Any, device: int = 0, *, vref_v: float = 3.3, name: str = "MCP3008"):
        self.spi, self.device, self.vref_v, self.name = spi, device, vref_v, name

    @staticmethod
    def frame(channel: int, single: bool = True) -> list[int]:
        return [0x01, (0x80 if single else 0x00) | (channel & 7) << 4, 0x00]

    def convert(self, channel: int, single: bool = True) -> int:
        rx = with_retries(self.name, lambda: self.spi.xfer2(self.frame(channel, single)))
        # the null bit must be 0: MISO floating high (no chip, no pull-down) or noise. A
        # Pi pulls MISO low, so a missing chip there reads 0: Mcp3008Channel, the reference
        if len(rx) != 3 or rx[1] & 0x04:
            raise PartError(f"{self.name} (SPI0 CE{self.device}): no valid answer {list(rx)} "
                            "(chip missing, MISO floating or wiring)")
        return (rx[1] & 0x03) << 8 | rx[2]

    def volts(self, channel: int) -> float:
        return self.convert(channel) * self.vref_v / self.COUNTS

    def identify(self) -> str:
        counts = " ".join(f"ch{c}={self.convert(c)}" for c in range(MCP3008_CHANNELS))
        return f"MCP3008 on SPI0 CE{self.device}: {counts}"

    def close(self) -> None:
        close = getattr(self.spi, "close", None)
        if close is not None:
            close()


class Mcp3008Channel:
    """A pot on one MCP3008 input (see PotSensor). ``reference_channel`` None: the pot
    supply is the chip's VREF (ratiometric by wiring, counts = the G4JNT PIC's N; a dead
    supply is not seen); else the supply is read on that input and
    ``full_scale_counts`` is what it reads at ``reference_v``."""

    def __init__(self, chip: Mcp3008Chip, channel: int, reference_channel: int | None, *,
                 reference_v: float = 3.3):
        self.chip, self.channel, self.reference_channel = chip, channel, reference_channel
        self.full_scale_counts = Mcp3008Chip.COUNTS if reference_channel is None else \
            round(reference_v / chip.vref_v * Mcp3008Chip.COUNTS)

    def read_counts(self) -> int:
        counts = self.chip.convert(self.channel)
        if counts == 0 and self.reference_channel is None:
            # a Pi pulls MISO (GPIO9) low: with no chip every frame reads 0 with a valid
            # null bit, and 0 is also a pot at its end. Without a reference input that
            # cannot be told apart, so it is never taken for an angle
            raise PartError(f"{self.chip.name} (SPI0 CE{self.chip.device}) CH{self.channel} reads 0 counts: "
                            "no chip answers like that too (MISO pulled low); if the pot really sits at its "
                            "end, wire its supply to a spare input and set adc_reference_channel")
        return counts

    def read_reference_counts(self) -> int:
        if self.reference_channel is None:
            return self.full_scale_counts
        return self.chip.convert(self.reference_channel)
