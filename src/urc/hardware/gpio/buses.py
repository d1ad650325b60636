"""The buses the gpio backend's chips talk on: I2C buses (smbus2; a TCA9548A mux on a
bus where chips share an address) and SPI0's chip selects (spidev), or their emulated
stand-ins. Each is opened on first use and shared by every part on it."""

from __future__ import annotations

from typing import Any

from ...errors import ConfigError
from .i2c import Ads1115Chip, SerialisedBus, Tca9548aMux
from .spi import Mcp3008Chip, open_spidev


class Buses:
    def __init__(self, gpio: Any, emulate: bool, parts: list[tuple[str, Any]]):
        self.gpio, self.emulate, self.parts = gpio, emulate, parts
        #: I2C bus number -> smbus2.SMBus (emulated: FakeSMBus), as opened
        self.i2c: dict[int, Any] = {}
        #: ... and as every part uses it: one transaction at a time (see SerialisedBus;
        #: the emulated buses too, so that a bus call the wrapper lacks fails in the tests)
        self._serialised: dict[int, SerialisedBus] = {}
        self.muxes: dict[int, Tca9548aMux] = {}
        #: SPI0 chip select -> the MCP3008 on it; emulated, the fake chips behind them
        self.mcp3008: dict[int, Mcp3008Chip] = {}
        self.fake_spi: dict[int, Any] = {}

    def bus(self, n: int) -> SerialisedBus:
        """Bus ``n`` as the parts on it use it (the tick's chips and the FRAM's state
        writer share it: see SerialisedBus)."""
        if n not in self._serialised:
            if self.emulate:
                from .emulate import FakeSMBus
                self.i2c[n] = FakeSMBus()
            else:
                import smbus2
                try:
                    self.i2c[n] = smbus2.SMBus(n)
                except OSError as exc:
                    raise ConfigError(f"I2C bus {n}: {exc} (enable I2C with raspi-config)",
                                      key="hardware.gpio.i2c_bus", expected="an I2C bus", found=n) from exc
            self._serialised[n] = SerialisedBus(self.i2c[n])
        return self._serialised[n]

    def chip_bus(self, n: int, channel: int | None) -> Any:
        """The bus a chip talks on: bus ``n`` itself, or one channel of its TCA9548A."""
        if channel is None:
            return self.bus(n)
        if n not in self.muxes:
            addr = self.gpio.i2c_mux_address
            self.muxes[n] = Tca9548aMux(self.bus(n), addr)
            self.parts.append((f"TCA9548A 0x{addr:02x} (bus {n})", self.muxes[n]))
        return self.muxes[n].channel(channel)

    def fake_devices(self, n: int, channel: int | None) -> dict[int, Any]:
        """Emulation: the fake chips answering where a chip on bus ``n`` (mux
        ``channel``) sits, by address."""
        self.bus(n)
        fake = self.i2c[n]
        return fake.devices if channel is None else fake.mux_channel(self.gpio.i2c_mux_address, channel)

    def _spi_dev(self, device: int) -> Any:
        if self.emulate:
            from .emulate import FakeMcp3008
            return self.fake_spi.setdefault(device, FakeMcp3008({}))
        try:
            return open_spidev(device)
        except (ImportError, OSError) as exc:
            raise ConfigError(f"SPI0 CE{device}: {exc} (install urc's [pi] extra: pip install '.[pi]' in the clone; enable SPI with raspi-config)",
                              key="hardware.gpio.spi_device", expected="an SPI device", found=device) from exc

    def adc(self, axis: str, cfg: Any, bus_n: int, *, pot_vref: bool) -> Any:
        """An axis' ADC (its pot and/or its bridge's current sense): the MCP3008 on its
        chip select (one per chip select; VREF the pot supply when ``pot_vref``, else
        the 3.3 V rail) or the ADS1115 at its address."""
        if cfg.adc == "mcp3008":
            if cfg.spi_device not in self.mcp3008:
                self.mcp3008[cfg.spi_device] = Mcp3008Chip(
                    self._spi_dev(cfg.spi_device), cfg.spi_device, vref_v=cfg.adc_reference_v if pot_vref else 3.3)
            return self.mcp3008[cfg.spi_device]
        return Ads1115Chip(self.chip_bus(bus_n, cfg.i2c_mux_channel), cfg.i2c_address or 0x48, f"{axis} ADS1115")

    def close(self) -> None:
        for b in self._serialised.values():
            b.close()
        for c in self.mcp3008.values():
            c.close()
