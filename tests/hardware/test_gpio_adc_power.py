"""urc.hardware.gpio.adc_power: urc's own ADC parts as a received-power source, over the
emulated chips (the ADS1115's registers on a fake I²C bus, the MCP3008's SPI frames).
Saturation is the code a clipped input reads: 7FFFh for the ADS1115 (TI SBAS444, the
output-code table: +FS and above, at urc's PGA 001 +4.096 V), 3FFh for the MCP3008
(Microchip DS21295: VIN >= VREF); the emulated chips clip so."""

from __future__ import annotations

import pytest

from urc.hardware.gpio.adc_power import ads1115_power, mcp3008_power
from urc.hardware.gpio.emulate import FakeAds1115, FakeMcp3008, FakeSMBus
from urc.hardware.gpio.i2c import Ads1115Chip
from urc.hardware.gpio.spi import Mcp3008Chip
from urc.pointing.sources import SignalRefused


def _ads(volts):
    bus = FakeSMBus()
    bus.devices[0x48] = FakeAds1115({2: lambda: volts()})
    return bus, Ads1115Chip(bus)


def test_an_ads1115_input_reads_volts_and_its_clipped_code_is_saturated():
    level = [1.25]
    _bus, chip = _ads(lambda: level[0])
    source = ads1115_power(chip, 2, clock=lambda: 5.0)
    s = source.read()
    assert s.t_s == 5.0 and s.unit == "V" and s.value == pytest.approx(1.25, abs=4.096 / 32768)
    assert source.name == "ADS1115 AIN2"
    level[0] = 5.0   # above full scale: the chip reads 7FFFh
    with pytest.raises(SignalRefused) as exc:
        source.read()
    assert exc.value.reason == "saturated"


def test_an_ads1115_that_does_not_answer_is_missing():
    bus, chip = _ads(lambda: 1.0)
    bus.devices[0x48].nack = True
    with pytest.raises(SignalRefused) as exc:
        ads1115_power(chip, 2).read()
    assert exc.value.reason == "missing"


def test_an_mcp3008_input_reads_volts_and_vref_is_saturated():
    level = [1.1]
    chip = Mcp3008Chip(FakeMcp3008({4: lambda: level[0]}), 0, vref_v=3.3)
    source = mcp3008_power(chip, 4, clock=lambda: 2.0)
    s = source.read()
    assert s.t_s == 2.0 and s.value == pytest.approx(1.1, abs=3.3 / 1024) and source.name == "MCP3008 CH4"
    level[0] = 3.3
    with pytest.raises(SignalRefused) as exc:
        source.read()
    assert exc.value.reason == "saturated"
