"""I2C chip parts over an smbus2-style bus: AS5600, LSM303D, ADS1115, the TCA9548A mux.

Each transaction is retried a bounded number of times; a NACK or timeout that
persists becomes :class:`urc.hardware.parts.PartError` (a sensor fault, never a
reading).
"""

from __future__ import annotations

import struct
import threading
from typing import Any, Callable, TypeVar

from ..parts import MagnetStatus, PartError

T = TypeVar("T")
#: attempts per transaction (the first plus retries)
ATTEMPTS = 3


def with_retries(what: str, fn: Callable[[], T]) -> T:
    last: Exception | None = None
    for _ in range(ATTEMPTS):
        try:
            return fn()
        except OSError as exc:    # smbus2: errno 121 NACK, 110 timeout
            last = exc
    raise PartError(f"{what}: I2C failed {ATTEMPTS} times ({last})")


class As5600Chip:
    """AS5600 at 0x36: STATUS 0x0B (MD 0x20, ML 0x10, MH 0x08), RAW ANGLE 0x0C..0x0D."""

    ADDRESS = 0x36
    REG_STATUS, REG_RAW_ANGLE = 0x0B, 0x0C

    def __init__(self, bus: Any, address: int = ADDRESS, name: str = "AS5600"):
        self.bus, self.address, self.name = bus, address, name

    def magnet_status(self) -> MagnetStatus:
        return MagnetStatus.from_register(with_retries(
            self.name, lambda: self.bus.read_byte_data(self.address, self.REG_STATUS)))

    def read_raw_angle(self) -> int:
        hi, lo = with_retries(self.name, lambda: self.bus.read_i2c_block_data(
            self.address, self.REG_RAW_ANGLE, 2))
        return (hi & 0x0F) << 8 | lo

    def identify(self) -> str:
        st = self.magnet_status()
        return f"AS5600 at 0x{self.address:02x}: magnet {'ok' if st.detected and not (st.too_weak or st.too_strong) else st}"


class Lsm303dChip:
    """LSM303D at 0x1D: WHO_AM_I 0x0F = 0x49; magnetometer OUT_X_L_M 0x08, accelerometer
    OUT_X_L_A 0x28, six bytes each, little-endian int16, address auto-increment (0x80).
    Set up for accelerometer 50 Hz +-2 g and magnetometer continuous, high resolution,
    +-2 gauss."""

    ADDRESS = 0x1D
    WHO_AM_I, ID = 0x0F, 0x49
    OUT_M, OUT_A = 0x08, 0x28
    MAG_GAUSS_PER_LSB = 0.080e-3
    ACC_G_PER_LSB = 0.061e-3
    SETUP = ((0x20, 0x57), (0x24, 0x64), (0x25, 0x00), (0x26, 0x00))  # CTRL1, 5, 6, 7

    def __init__(self, bus: Any, address: int = ADDRESS, name: str = "LSM303D"):
        self.bus, self.address, self.name = bus, address, name
        self._ready = False

    def _setup(self) -> None:
        if self._ready:
            return
        who = with_retries(self.name, lambda: self.bus.read_byte_data(self.address, self.WHO_AM_I))
        if who != self.ID:
            raise PartError(f"{self.name} at 0x{self.address:02x}: WHO_AM_I 0x{who:02x}, expected 0x{self.ID:02x}")
        for reg, val in self.SETUP:
            with_retries(self.name, lambda: self.bus.write_byte_data(self.address, reg, val))
        self._ready = True

    def _vector(self, reg: int, scale: float) -> tuple[float, float, float]:
        self._setup()
        data = with_retries(self.name, lambda: self.bus.read_i2c_block_data(self.address, reg | 0x80, 6))
        x, y, z = struct.unpack("<hhh", bytes(data))
        return (x * scale, y * scale, z * scale)

    def magnetic(self) -> tuple[float, float, float]:
        return self._vector(self.OUT_M, self.MAG_GAUSS_PER_LSB)

    def acceleration(self) -> tuple[float, float, float]:
        return self._vector(self.OUT_A, self.ACC_G_PER_LSB)

    def identify(self) -> str:
        who = with_retries(self.name, lambda: self.bus.read_byte_data(self.address, self.WHO_AM_I))
        return f"LSM303D at 0x{self.address:02x}: WHO_AM_I 0x{who:02x} ({'ok' if who == self.ID else 'WRONG'})"


class Lsm303Mag:
    def __init__(self, chip: Lsm303dChip):
        self.chip = chip

    def read_vector(self) -> tuple[float, float, float]:
        return self.chip.magnetic()


class Lsm303Accel:
    def __init__(self, chip: Lsm303dChip):
        self.chip = chip

    def read_vector(self) -> tuple[float, float, float]:
        return self.chip.acceleration()


class Ads1115Chip:
    """ADS1115 at 0x48..0x4B: single-shot conversions of one input against ground.

    Config 0x01 (big-endian): OS=1 start, MUX 100+ch (AINch vs GND), PGA 001
    (+-4.096 V), MODE 1 single shot, DR 111 (860 SPS), comparator off; then poll OS
    and read conversion 0x00 (big-endian int16).
    """

    REG_CONV, REG_CONFIG = 0x00, 0x01
    FS_V = 4.096
    MAX_POLLS = 20

    def __init__(self, bus: Any, address: int = 0x48, name: str = "ADS1115"):
        self.bus, self.address, self.name = bus, address, name

    @staticmethod
    def config_word(channel: int) -> int:
        return 0x8000 | (4 + channel) << 12 | 1 << 9 | 1 << 8 | 7 << 5 | 3

    def convert(self, channel: int) -> int:
        cfg = self.config_word(channel)
        with_retries(self.name, lambda: self.bus.write_i2c_block_data(
            self.address, self.REG_CONFIG, [cfg >> 8, cfg & 0xFF]))
        for _ in range(self.MAX_POLLS):
            hi, _lo = with_retries(self.name, lambda: self.bus.read_i2c_block_data(
                self.address, self.REG_CONFIG, 2))
            if hi & 0x80:
                break
        else:
            raise PartError(f"{self.name}: conversion did not finish")
        hi, lo = with_retries(self.name, lambda: self.bus.read_i2c_block_data(
            self.address, self.REG_CONV, 2))
        return struct.unpack(">h", bytes((hi, lo)))[0]

    def volts(self, channel: int) -> float:
        return self.convert(channel) * self.FS_V / 32768


class Ads1115Channel:
    """A pot on one ADS1115 input, its supply on another (ratiometric; see PotSensor)."""

    def __init__(self, chip: Ads1115Chip, channel: int, reference_channel: int, *,
                 reference_v: float = 3.3):
        self.chip, self.channel, self.reference_channel = chip, channel, reference_channel
        self.full_scale_counts = round(reference_v / Ads1115Chip.FS_V * 32768)

    def read_counts(self) -> int:
        return self.chip.convert(self.channel)

    def read_reference_counts(self) -> int:
        return self.chip.convert(self.reference_channel)


class Lsm303agrChip:
    """LSM303AGR: accelerometer at 0x19 (WHO_AM_I_A 0x0F = 0x33; CTRL_REG1_A 0x20 = 0x57
    100 Hz xyz, CTRL_REG4_A 0x23 = 0x88 block update + high resolution; OUT_X_L_A 0x28
    with the auto-increment bit, 12 bits left-justified, ~1 mg per count) and
    magnetometer at 0x1E (WHO_AM_I_M 0x4F = 0x40; CFG_REG_A_M 0x60 = 0x8C temperature
    compensated, 100 Hz, continuous; CFG_REG_C_M 0x62 = 0x10 block update; OUTX_L_REG_M
    0x68, 1.5 mgauss per count). Same vectors as :class:`Lsm303dChip`."""

    ACCEL, MAG = 0x19, 0x1E
    ACC_G_PER_LSB = 0.98e-3 / 16
    MAG_GAUSS_PER_LSB = 1.5e-3
    SETUP = ((0x19, 0x20, 0x57), (0x19, 0x23, 0x88), (0x1E, 0x60, 0x8C), (0x1E, 0x62, 0x10))
    IDS = ((0x19, 0x0F, 0x33), (0x1E, 0x4F, 0x40))

    def __init__(self, bus: Any, name: str = "LSM303AGR"):
        self.bus, self.name = bus, name
        self.address = self.MAG
        self._ready = False

    def _setup(self) -> None:
        if self._ready:
            return
        for addr, reg, want in self.IDS:
            who = with_retries(self.name, lambda: self.bus.read_byte_data(addr, reg))
            if who != want:
                raise PartError(f"{self.name} at 0x{addr:02x}: WHO_AM_I 0x{who:02x}, expected 0x{want:02x}")
        for addr, reg, val in self.SETUP:
            with_retries(self.name, lambda: self.bus.write_byte_data(addr, reg, val))
        self._ready = True

    def _vector(self, addr: int, reg: int, scale: float) -> tuple[float, float, float]:
        self._setup()
        data = with_retries(self.name, lambda: self.bus.read_i2c_block_data(addr, reg, 6))
        x, y, z = struct.unpack("<hhh", bytes(data))
        return (x * scale, y * scale, z * scale)

    def magnetic(self) -> tuple[float, float, float]:
        return self._vector(self.MAG, 0x68, self.MAG_GAUSS_PER_LSB)

    def acceleration(self) -> tuple[float, float, float]:
        return self._vector(self.ACCEL, 0x28 | 0x80, self.ACC_G_PER_LSB)

    def identify(self) -> str:
        self._ready = False
        self._setup()
        return "LSM303AGR at 0x19/0x1e: WHO_AM_I 0x33/0x40 (ok)"


class SerialisedBus:
    """An smbus2 bus (or the emulation's stand-in) shared by threads, one transaction at
    a time.

    smbus2 keeps the slave address per file descriptor: ``read_byte_data(0x36, ...)``
    is ``ioctl(I2C_SLAVE, 0x36)`` (skipped when the address is unchanged), then
    ``ioctl(I2C_SMBUS, ...)``. Two threads on one bus (the tick reading an AS5600, the
    state writer saving to the FRAM at 0x50) can interleave those two steps: the FRAM's
    block write then goes to the encoder's registers (ZPOS, CONF: a silently moved zero)
    or a reading comes from the wrong chip. Every call here holds the bus' lock over both
    steps. ``i2c_rdwr`` addresses each message itself but shares the lock all the same.
    """

    def __init__(self, bus: Any):
        self._bus = bus
        self.lock = threading.Lock()

    def read_byte(self, addr: int) -> int:
        with self.lock:
            return self._bus.read_byte(addr)

    def write_byte(self, addr: int, value: int) -> None:
        with self.lock:
            self._bus.write_byte(addr, value)

    def read_byte_data(self, addr: int, reg: int) -> int:
        with self.lock:
            return self._bus.read_byte_data(addr, reg)

    def write_byte_data(self, addr: int, reg: int, value: int) -> None:
        with self.lock:
            self._bus.write_byte_data(addr, reg, value)

    def read_i2c_block_data(self, addr: int, reg: int, n: int) -> list[int]:
        with self.lock:
            return self._bus.read_i2c_block_data(addr, reg, n)

    def write_i2c_block_data(self, addr: int, reg: int, data: list[int]) -> None:
        with self.lock:
            self._bus.write_i2c_block_data(addr, reg, data)

    def i2c_rdwr(self, *msgs: Any) -> None:
        with self.lock:
            self._bus.i2c_rdwr(*msgs)

    def close(self) -> None:
        # (not under the lock: closing follows drive_safe past a tick hung in a bus read,
        # and must not wait for that read)
        self._bus.close()


class Tca9548aMux:
    """TCA9548A I2C switch (0x70..0x77): a single control byte, bit n connects channel n
    to the bus. Two chips with one fixed address (the Berkeley rotor's two AS5600 at
    0x36) sit on two channels; the channel is selected before each of their transactions
    (written only when it changes). No library covers the mux with smbus2, and it is one
    byte."""

    def __init__(self, bus: Any, address: int = 0x70, name: str = "TCA9548A"):
        self.bus, self.address, self.name = bus, address, name
        self.lock = threading.RLock()
        self._selected: int | None = None

    def select(self, channel: int) -> None:
        if self._selected != channel:
            self._selected = None
            self.bus.write_byte(self.address, 1 << channel)
            self._selected = channel

    def forget(self) -> None:
        """A transaction failed: the mux may have been reset; select again next time."""
        self._selected = None

    def channel(self, channel: int) -> "MuxChannelBus":
        return MuxChannelBus(self, channel)

    def identify(self) -> str:
        with self.lock:
            ctrl = with_retries(self.name, lambda: self.bus.read_byte(self.address))
        chans = [str(c) for c in range(8) if ctrl >> c & 1]
        sel = f"channel {', '.join(chans)} selected" if chans else "no channel selected yet"
        return f"TCA9548A at 0x{self.address:02x}: {sel}"


class MuxChannelBus:
    """The bus as a chip on one mux channel sees it: the smbus2 calls the chip parts use,
    each preceded by the channel select, under the mux's lock (one channel at a time)."""

    def __init__(self, mux: Tca9548aMux, channel: int):
        self.mux, self.channel = mux, channel

    def _on(self, op: str, *args: Any) -> Any:
        with self.mux.lock:
            try:
                self.mux.select(self.channel)
                return getattr(self.mux.bus, op)(*args)
            except OSError:
                self.mux.forget()
                raise

    def read_byte_data(self, addr: int, reg: int) -> int:
        return self._on("read_byte_data", addr, reg)

    def read_i2c_block_data(self, addr: int, reg: int, n: int) -> list[int]:
        return self._on("read_i2c_block_data", addr, reg, n)

    def write_byte_data(self, addr: int, reg: int, value: int) -> None:
        self._on("write_byte_data", addr, reg, value)

    def write_i2c_block_data(self, addr: int, reg: int, data: list[int]) -> None:
        self._on("write_i2c_block_data", addr, reg, data)

    def close(self) -> None:
        pass


class AdcInput:
    """One input of an ADC chip (ADS1115 here, MCP3008 in :mod:`.spi`) as a
    :class:`urc.hardware.parts.VoltageIn`."""

    def __init__(self, chip: Any, channel: int):
        self.chip, self.channel = chip, channel

    def read_volts(self) -> float:
        return self.chip.volts(self.channel)
