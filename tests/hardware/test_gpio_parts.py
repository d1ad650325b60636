"""gpio parts at the pin and register level: x4 decoding edge by edge (glitches, missed
edges), byte-exact I2C transactions, bounded retries."""

from __future__ import annotations

import pytest
from gpiozero.pins.mock import MockFactory, MockPWMPin

from urc.caps import SensorCaps
from urc.errors import SensorError
from urc.hardware.drivers import PotSensor
from urc.hardware.gpio.emulate import FakeAds1115, FakeAs5600, FakeLsm303d, FakeSMBus
from urc.hardware.gpio.i2c import ATTEMPTS, Ads1115Channel, Ads1115Chip, As5600Chip, Lsm303dChip
from urc.hardware.gpio.pins import PinPulseCounter, PinPwm, PinQuadrature, quad_decode
from urc.hardware.parts import MagnetStatus

SEQ = [0b00, 0b01, 0b11, 0b10]   # forward Gray order (A<<1 | B)


@pytest.fixture
def factory():
    f = MockFactory(pin_class=MockPWMPin)
    yield f
    f.close()


def drive(q: PinQuadrature, state: int) -> None:
    for pin, bit in ((q.a, 2), (q.b, 1)):
        if bool(state & bit) != bool(pin.state):
            (pin.drive_high if state & bit else pin.drive_low)()


def at_zero(q: PinQuadrature) -> int:
    """Walk the (pulled-up, 11) inputs to state 00; the count there."""
    drive(q, SEQ[0])
    return q.count()


def test_decode_table():
    for i, s in enumerate(SEQ):
        assert quad_decode(s, SEQ[(i + 1) % 4]) == 1
        assert quad_decode(SEQ[(i + 1) % 4], s) == -1
        assert quad_decode(s, s) == 0
        assert quad_decode(s, SEQ[(i + 2) % 4]) is None      # both changed: missed edge


def test_x4_counts_every_edge_both_ways(factory):
    q = PinQuadrature(factory, 17, 27)
    c0 = at_zero(q)
    for k in range(1, 41):                # ten full cycles forward = 40 counts
        drive(q, SEQ[k % 4])
    assert q.count() - c0 == 40
    for k in range(39, 14, -1):           # 25 back
        drive(q, SEQ[k % 4])
    assert q.count() - c0 == 15 and q.errors() == 0


def test_glitch_on_one_channel_cancels(factory):
    q = PinQuadrature(factory, 17, 27)
    c0 = at_zero(q)
    drive(q, SEQ[1])
    for _ in range(5):                    # contact bounce on A: up, down, up, down ...
        drive(q, SEQ[2])
        drive(q, SEQ[1])
    assert q.count() - c0 == 1 and q.errors() == 0


def test_missed_edge_is_counted_as_an_error_not_guessed(factory):
    q = PinQuadrature(factory, 17, 27)
    c0 = at_zero(q)
    drive(q, SEQ[1])
    q.a.drive_high()                      # 01 -> 11 (+1), then 11 -> 10 (+1)
    q.b.drive_low()
    assert q.count() - c0 == 3
    # a report of A at the level A already had: A's previous edge was lost; an error,
    # not a guess
    q._edge(2, q.a, True)
    assert q.errors() == 1 and q.count() - c0 == 3


def test_index_latches_the_count(factory):
    q = PinQuadrature(factory, 17, 27, z=22)
    c0 = at_zero(q)
    for k in range(1, 8):
        drive(q, SEQ[k % 4])
    q.z.drive_low()
    q.z.drive_high()
    assert q.index_count() - c0 == 7


def test_pulse_counter_counts_falling_edges(factory):
    c = PinPulseCounter(factory, 17)
    c.pin.drive_high()
    for _ in range(12):
        c.pin.drive_low()
        c.pin.drive_high()
    assert c.count() == 12


def test_pwm_pin(factory):
    p = PinPwm(factory, 12, frequency_hz=20000)
    p.write_duty(0.37)
    assert p.pin.frequency == 20000 and p.read_back() == pytest.approx(0.37)
    p.write_duty(3.0)
    assert p.read_back() == 1.0


def test_as5600_transactions_byte_exact():
    bus = FakeSMBus()
    bus.keep_log = True
    dev = FakeAs5600(lambda: 0x0ABC)
    bus.devices[0x36] = dev
    chip = As5600Chip(bus)
    assert chip.magnet_status() == MagnetStatus(True)
    assert chip.read_raw_angle() == 0x0ABC
    assert bus.log == [("r", 0x36, 0x0B, (0x20,)), ("r", 0x36, 0x0C, (0x0A, 0xBC))]
    dev.status = MagnetStatus(True, too_strong=True)
    assert chip.magnet_status().too_strong


def test_lsm303d_setup_and_vectors_byte_exact():
    bus = FakeSMBus()
    bus.keep_log = True
    bus.devices[0x1D] = FakeLsm303d(lambda: (0.1, -0.2, 0.3), lambda: (0.0, 0.5, 1.0))
    chip = Lsm303dChip(bus)
    m = chip.magnetic()
    assert bus.log[:5] == [("r", 0x1D, 0x0F, (0x49,)), ("w", 0x1D, 0x20, (0x57,)), ("w", 0x1D, 0x24, (0x64,)),
                           ("w", 0x1D, 0x25, (0x00,)), ("w", 0x1D, 0x26, (0x00,))]
    # 0.1 gauss / 0.080 mgauss = 1250 = 0x04E2, little-endian; auto-increment bit set
    assert bus.log[5] == ("r", 0x1D, 0x88, (0xE2, 0x04, 0x3C, 0xF6, 0xA6, 0x0E))
    assert m == pytest.approx((0.1, -0.2, 0.3), abs=1e-4)
    a = chip.acceleration()
    assert bus.log[-1][2] == 0xA8 and a == pytest.approx((0.0, 0.5, 1.0), abs=1e-4)


def test_lsm303d_wrong_id_is_an_error():
    bus = FakeSMBus()
    dev = FakeLsm303d(lambda: (0, 0, 0), lambda: (0, 0, 1))
    dev.regs[0x0F] = 0x33                 # an LSM303DLHC answering at this address
    bus.devices[0x1D] = dev
    with pytest.raises(SensorError, match="WHO_AM_I 0x33"):
        Lsm303dChip(bus).magnetic()


def test_ads1115_single_shot_byte_exact():
    bus = FakeSMBus()
    bus.keep_log = True
    bus.devices[0x48] = FakeAds1115({0: lambda: 1.0, 3: lambda: 3.3})
    adc = Ads1115Channel(Ads1115Chip(bus), 0, 3)
    assert adc.read_counts() == round(1.0 / 4.096 * 32768)
    # config: OS | MUX=100 (AIN0) | PGA 001 | single shot | 860 SPS | comparator off
    assert bus.log[0] == ("w", 0x48, 0x01, (0xC3, 0xE3))
    assert bus.log[1][:3] == ("r", 0x48, 0x01)
    assert bus.log[2] == ("r", 0x48, 0x00, (0x1F, 0x40))
    assert adc.read_reference_counts() == 26400 == adc.full_scale_counts
    assert bus.log[3] == ("w", 0x48, 0x01, (0xF3, 0xE3))       # MUX=111: AIN3


@pytest.mark.parametrize("pga, fs_v", [(0b000, 6.144), (0b001, 4.096), (0b010, 2.048), (0b011, 1.024),
                                       (0b100, 0.512), (0b101, 0.256), (0b110, 0.256), (0b111, 0.256)])
def test_fake_ads1115_converts_at_the_full_scale_its_pga_bits_select(pga, fs_v):
    """TI ADS1115 datasheet, Config register PGA[2:0] and the full-scale-range table
    (values typed here): the code is volts / FSR x 32768, clipped at 7FFFh / 8000h."""
    bus = FakeSMBus()
    volts = {"v": 0.2}
    bus.devices[0x48] = FakeAds1115({1: lambda: volts["v"]})

    def convert() -> int:
        word = 0x8000 | (4 + 1) << 12 | pga << 9 | 1 << 8 | 0x83   # OS, AIN1 vs GND, single shot
        bus.write_i2c_block_data(0x48, 0x01, [word >> 8, word & 0xFF])
        hi, lo = bus.read_i2c_block_data(0x48, 0x00, 2)
        return int.from_bytes(bytes((hi, lo)), "big", signed=True)
    assert convert() == round(0.2 / fs_v * 32768)
    volts["v"] = 7.0                                   # beyond every range: the top code
    assert convert() == 0x7FFF
    volts["v"] = -7.0
    assert convert() == -0x8000


def test_nack_retries_are_bounded_then_an_error():
    bus = FakeSMBus()
    calls = []
    orig = bus.read_byte_data

    def counting(addr, reg):
        calls.append(reg)
        return orig(addr, reg)
    bus.read_byte_data = counting         # nothing at 0x36: every attempt NACKs
    with pytest.raises(SensorError, match="I2C failed"):
        As5600Chip(bus).magnet_status()
    assert len(calls) == ATTEMPTS


def test_lsm303agr_two_devices_byte_exact():
    from urc.hardware.gpio.emulate import FakeLsm303agr
    from urc.hardware.gpio.i2c import Lsm303agrChip
    bus = FakeSMBus()
    bus.keep_log = True
    agr = FakeLsm303agr(lambda: (0.15, 0.0, -0.3), lambda: (0.0, 0.0, 1.0))
    bus.devices[0x19], bus.devices[0x1E] = agr.accel, agr.mag
    chip = Lsm303agrChip(bus)
    m = chip.magnetic()
    assert bus.log[:6] == [("r", 0x19, 0x0F, (0x33,)), ("r", 0x1E, 0x4F, (0x40,)),
                           ("w", 0x19, 0x20, (0x57,)), ("w", 0x19, 0x23, (0x88,)),
                           ("w", 0x1E, 0x60, (0x8C,)), ("w", 0x1E, 0x62, (0x10,))]
    # 0.15 gauss / 1.5 mgauss = 100 = 0x0064; -0.3 -> -200 = 0xFF38
    assert bus.log[6] == ("r", 0x1E, 0x68, (0x64, 0x00, 0x00, 0x00, 0x38, 0xFF))
    assert m == pytest.approx((0.15, 0.0, -0.3))
    assert chip.acceleration() == pytest.approx((0.0, 0.0, 1.0), abs=1e-3)
    assert bus.log[-1][1:3] == (0x19, 0xA8)


def test_two_as5600_at_0x36_through_a_tca9548a_byte_exact():
    from urc.hardware.gpio.i2c import Tca9548aMux
    bus = FakeSMBus()
    bus.keep_log = True
    bus.mux_channel(0x70, 0)[0x36] = FakeAs5600(lambda: 0x0123)
    bus.mux_channel(0x70, 1)[0x36] = FakeAs5600(lambda: 0x0ABC)
    with pytest.raises(OSError):            # power-up: no channel selected, nobody at 0x36
        bus.read_byte_data(0x36, 0x0B)
    bus.log.clear()
    mux = Tca9548aMux(bus, 0x70)
    az, el = As5600Chip(mux.channel(0)), As5600Chip(mux.channel(1))
    assert az.read_raw_angle() == 0x0123 and az.read_raw_angle() == 0x0123
    assert el.read_raw_angle() == 0x0ABC and az.read_raw_angle() == 0x0123
    # the control byte (bit n = channel n) is written only when the channel changes
    assert bus.log == [("wb", 0x70, -1, (0x01,)), ("r", 0x36, 0x0C, (0x01, 0x23)),
                       ("r", 0x36, 0x0C, (0x01, 0x23)),
                       ("wb", 0x70, -1, (0x02,)), ("r", 0x36, 0x0C, (0x0A, 0xBC)),
                       ("wb", 0x70, -1, (0x01,)), ("r", 0x36, 0x0C, (0x01, 0x23))]
    assert "channel 0 selected" in mux.identify()
    # both channels at once: the two chips answer together (wired-AND on SDA)
    bus.write_byte(0x70, 0x03)
    assert bus.read_i2c_block_data(0x36, 0x0C, 2) == [0x01 & 0x0A, 0x23 & 0xBC]
    # a mux reset (glitch) behind the driver's back: the retry selects the channel again
    bus.devices[0x70].control = 0
    mux._selected = 1
    assert el.read_raw_angle() == 0x0ABC
    assert bus.devices[0x70].control == 0x02


def test_mux_nack_is_retried_then_a_sensor_error():
    from urc.hardware.gpio.i2c import Tca9548aMux
    bus = FakeSMBus()
    bus.mux_channel(0x70, 2)[0x36] = FakeAs5600(lambda: 7)
    bus.devices[0x70].nack = True          # the mux itself does not answer
    with pytest.raises(SensorError, match="I2C failed"):
        As5600Chip(Tca9548aMux(bus, 0x70).channel(2)).read_raw_angle()


def test_mcp3008_spi_frame_bit_exact():
    """The three-byte frame: 7 leading zeros, the start bit, SGL=1, D2..D0; the emulated
    chip answers clock by clock: the sample clock, the null bit, B9..B0."""
    from urc.hardware.gpio.emulate import FakeMcp3008
    from urc.hardware.gpio.spi import Mcp3008Channel, Mcp3008Chip
    fake = FakeMcp3008({5: lambda: 2.0, 3: lambda: 3.3})
    fake.keep_frames = True
    adc = Mcp3008Channel(Mcp3008Chip(fake, 0), 5, 3)
    code = int(1024 * 2.0 / 3.3)                                 # 620 = 0b10_0110_1100
    assert adc.read_counts() == code
    (mosi, miso), = fake.frames
    assert mosi == (0b0000_0001, 0b1101_0000, 0x00)               # start | single, channel 5
    assert miso == (0x00, 0b0000_0010, 0b0110_1100)               # ..x 0 B9 B8 | B7..B0
    assert fake.transactions[-1] == (True, 5, code)
    assert adc.read_reference_counts() == 1023 and adc.full_scale_counts == 1024
    # the chip does not care how many leading zeros come before the start bit
    assert fake.xfer2([0x00, 0x00, 0x01, 0x80, 0x00, 0x00])[-2:] == [0x00, 0x00]
    assert fake.transactions[-1] == (True, 0, 0)


def test_mcp3008_differential_vref_reference_and_failures():
    from urc.hardware.gpio.emulate import FakeMcp3008
    from urc.hardware.gpio.spi import Mcp3008Channel, Mcp3008Chip
    fake = FakeMcp3008({2: lambda: 1.5, 3: lambda: 0.5, 6: lambda: 3.0})
    chip = Mcp3008Chip(fake, 1)
    assert chip.convert(2, single=False) == int(1024 * 1.0 / 3.3)      # CH2 - CH3
    assert chip.convert(3, single=False) == 0                          # CH3 - CH2 < 0: clamped
    # no reference input: VREF is the pot supply, the counts are N as they come
    pot = Mcp3008Channel(chip, 6, None)
    assert pot.read_reference_counts() == pot.full_scale_counts == 1024
    assert pot.read_counts() == int(1024 * 3.0 / 3.3)
    fake.dead = fake.miso_floating = True  # no chip, MISO floating high: the null bit is 1
    with pytest.raises(SensorError, match="no valid answer"):
        pot.read_counts()
    fake.miso_floating = False             # no chip on a Pi: GPIO9 pulled low, all zeros
    with pytest.raises(SensorError, match="reads 0 counts.*adc_reference_channel"):
        pot.read_counts()
    referenced = Mcp3008Channel(chip, 6, 7)
    with pytest.raises(SensorError, match="reference"):   # the reference reads 0: out of range
        PotSensor(SensorCaps(kind="pot", resolution_deg=0.5, absolute=True), "az", referenced,
                  law="linear", m=1.0, c=0.0).read_n()
    fake.dead, fake.fail = False, OSError(5, "Input/output error")
    with pytest.raises(SensorError, match=f"failed {ATTEMPTS} times"):
        pot.read_counts()


def test_magnet_status_is_what_every_register_value_says():
    """MagnetStatus.from_register keeps one value per pattern of its three bits (it is
    asked before every AS5600 angle): each is what that register value says."""
    for reg in range(256):
        st = MagnetStatus.from_register(reg)
        assert st == MagnetStatus(detected=bool(reg & 0x20), too_weak=bool(reg & 0x10),
                                  too_strong=bool(reg & 0x08))
        assert st.to_register() == reg & 0x38 and type(st) is MagnetStatus
