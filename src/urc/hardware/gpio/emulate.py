"""Emulated iron: the simulator's physics behind gpiozero MockFactory pins and a fake
SMBus with the chips' register maps, so the real gpio drivers run on a laptop.

* outputs (PWM, INA/INB, DIR, relays, brake coil) are read back from the mock pins and
  decoded into the simulated motor's drive, as the bridge chip or relay would;
* encoder A/B edges and SPID pulses are driven on the mock input pins from the
  simulated shaft, edge by edge (the x4 decoder sees every transition);
* the fake bus answers at the chips' addresses with their registers filled from the
  simulator (AS5600 raw angle and status, LSM303D field and gravity, ADS1115
  conversions); an address with no chip NACKs (OSError 121), like the real bus; chips
  behind a TCA9548A answer only while the mux's control byte selects their channel.
"""

from __future__ import annotations

import collections
import math
import struct
import time
from typing import Any, Callable, Mapping

from gpiozero.pins.mock import MockFactory, MockPWMPin
from gpiozero.pins.pi import PiPin

from ..parts import MagnetStatus
from .pins import _FWD


class EmulatedPin(MockPWMPin):
    """A mock pin whose edge reports carry the simulator's time (as lgpio's carry the
    kernel's timestamp of the edge), not the wall time the emulation happens to run at."""

    def _call_when_changed(self) -> None:  # type: ignore[override]
        PiPin._call_when_changed(self, self._factory.event_ticks(), self._state)


class MuxedPin(MockPWMPin):
    """A mock pin that claims its line as lgpio does: made (``factory.pin``) it is a GPIO
    input, set to output a GPIO output, in the factory's :class:`.pinmux.PinFunctions`
    (so a pin the overlay routed to PWM is taken off it, for good)."""

    def __init__(self, factory: Any, info: Any, **kwargs: Any):
        super().__init__(factory, info, **kwargs)
        factory.pin_functions.claimed(int(info.name[len("GPIO"):]))

    def _set_function(self, value: str) -> None:
        super()._set_function(value)
        self._factory.pin_functions.claimed(int(self.info.name[len("GPIO"):]), value == "output")


class MuxedMockFactory(MockFactory):
    """gpiozero's MockFactory with the pins' function select modelled (``pin_functions``):
    ``routed`` {pin: function} is what the overlays set at boot (``{12: "PWM0_0"}``: a
    Pi 4's PWM0 on GPIO12)."""

    def __init__(self, routed: dict[int, str] | None = None):
        from .pinmux import PinFunctions
        self.pin_functions = PinFunctions(routed)
        super().__init__(pin_class=MuxedPin)


class EmulatedFactory(MockFactory):
    """gpiozero's MockFactory on the control loop's clock: ``ticks()`` is clock time,
    and a feed may stamp the edges it makes (``event_s``) with when they happened
    between two polls."""

    def __init__(self, now_s: Callable[[], float]):
        super().__init__(pin_class=EmulatedPin)
        self._now_s = now_s
        self.event_s: float | None = None

    def ticks(self) -> float:  # type: ignore[override]
        return self._now_s()

    @staticmethod
    def ticks_diff(later: float, earlier: float) -> float:  # type: ignore[override]
        return later - earlier

    def event_ticks(self) -> float:
        return self._now_s() if self.event_s is None else self.event_s


class FakeSMBus:
    """smbus2.SMBus's calls used by :mod:`.i2c`, over emulated chips; logs every
    transaction as (op, address, register, bytes). Chips behind a TCA9548A mux
    (:meth:`mux_channel`) answer only while their channel is selected."""

    def __init__(self) -> None:
        self.devices: dict[int, Any] = {}
        self.log: list[tuple[str, int, int, tuple[int, ...]]] = []
        self.keep_log = False

    def mux_channel(self, mux_address: int, channel: int) -> dict[int, Any]:
        """The devices on one channel of the mux at ``mux_address`` (made on first use)."""
        mux = self.devices.setdefault(mux_address, FakeTca9548a())
        return mux.channels[channel]

    def _dev(self, addr: int) -> Any:
        # (every transaction asks: plain loops, no comprehensions or lists made for
        # the one chip that usually answers)
        devices = self.devices
        found = [devices[addr]] if addr in devices else []
        for mux in devices.values():
            if isinstance(mux, FakeTca9548a) and mux.control:  # (no channel selected: none answers)
                found += mux.selected(addr)
        answering = []
        for d in found:
            # ``nack``: set by tests; ``dead``: the simulator's sensor_dead fault on the chip
            if not (getattr(d, "nack", False) or getattr(d, "dead", False)):
                answering.append(d)
        if not answering:
            raise OSError(121, "Remote I/O error")
        return answering[0] if len(answering) == 1 else _WiredAnd(answering)

    def _rec(self, op: str, addr: int, reg: int, data: Any) -> None:
        if self.keep_log:
            self.log.append((op, addr, reg, tuple(data)))

    def read_byte_data(self, addr: int, reg: int) -> int:
        v = self._dev(addr).read(reg, 1)[0]
        self._rec("r", addr, reg, [v])
        return v

    def read_i2c_block_data(self, addr: int, reg: int, n: int) -> list[int]:
        data = list(self._dev(addr).read(reg, n))
        self._rec("r", addr, reg, data)
        return data

    def write_byte_data(self, addr: int, reg: int, value: int) -> None:
        self._rec("w", addr, reg, [value])
        self._dev(addr).write(reg, [value])

    def write_i2c_block_data(self, addr: int, reg: int, data: list[int]) -> None:
        self._rec("w", addr, reg, data)
        self._dev(addr).write(reg, list(data))

    def write_byte(self, addr: int, value: int) -> None:
        """A bare data byte, no register (the TCA9548A's control byte)."""
        self._rec("wb", addr, -1, [value])
        self._dev(addr).raw_write([value])

    def read_byte(self, addr: int) -> int:
        v = self._dev(addr).read(None, 1)[0]
        self._rec("rb", addr, -1, [v])
        return v

    def close(self) -> None:
        pass


class FakeTca9548a:
    """TCA9548A I2C switch: one control register, written and read as a bare byte; bit n
    connects downstream channel n (SDn/SCn) to the bus. 0 at power-up: no channel."""

    def __init__(self) -> None:
        self.control = 0
        self.channels: dict[int, dict[int, Any]] = {ch: {} for ch in range(8)}
        self.nack = False

    def raw_write(self, data: list[int]) -> None:
        self.control = data[-1] & 0xFF

    def write(self, reg: int, data: list[int]) -> None:   # a register write is just bytes to it
        self.raw_write([reg, *data])

    def read(self, reg: Any, n: int) -> list[int]:
        return [self.control] * n

    def selected(self, addr: int) -> list[Any]:
        """The chips at ``addr`` on the channels selected, lowest channel first."""
        found = []
        control, ch = self.control, 0
        while control:  # (the set bits only: asked on every transaction on the bus)
            devs = self.channels.get(ch)
            if control & 1 and devs is not None and addr in devs:
                found.append(devs[addr])
            control, ch = control >> 1, ch + 1
        return found


class _WiredAnd:
    """Two chips answering at one address (two mux channels selected at once): both
    take every write; a read sees the AND of their bytes (open-drain SDA)."""

    def __init__(self, devs: list[Any]):
        self.devs = devs

    def read(self, reg: Any, n: int) -> list[int]:
        out = [0xFF] * n
        for d in self.devs:
            out = [a & b for a, b in zip(out, d.read(reg, n))]
        return out

    def write(self, reg: int, data: list[int]) -> None:
        for d in self.devs:
            d.write(reg, data)

    def raw_write(self, data: list[int]) -> None:
        for d in self.devs:
            d.raw_write(data)


class FakeAs5600:
    def __init__(self, raw: Callable[[], int]):
        self.raw = raw
        self.status = MagnetStatus(detected=True)
        self.nack = False

    def read(self, reg: int, n: int) -> list[int]:
        if reg == 0x0B:
            return [self.status.to_register()]
        if reg == 0x0C:
            r = self.raw() & 0x0FFF
            return [r >> 8, r & 0xFF][:n]
        return [0] * n

    def write(self, reg: int, data: list[int]) -> None:
        pass


class FakeLsm303d:
    """Registers: WHO_AM_I, CTRLx (kept), OUT_M / OUT_A from vector sources (gauss, g)."""

    def __init__(self, mag: Callable[[], tuple[float, float, float]],
                 accel: Callable[[], tuple[float, float, float]]):
        self.mag, self.accel = mag, accel
        self.regs = {0x0F: 0x49}
        self.nack = False

    @staticmethod
    def _pack(v: tuple[float, float, float], scale: float) -> list[int]:
        return list(struct.pack("<hhh", *(max(-32768, min(32767, round(c / scale))) for c in v)))

    def read(self, reg: int, n: int) -> list[int]:
        base = reg & 0x7F
        if base == 0x08:
            return self._pack(self.mag(), 0.080e-3)[:n]
        if base == 0x28:
            return self._pack(self.accel(), 0.061e-3)[:n]
        return [self.regs.get(base + i, 0) for i in range(n)]

    def write(self, reg: int, data: list[int]) -> None:
        for i, v in enumerate(data):
            self.regs[(reg & 0x7F) + i] = v


#: TI ADS1115 datasheet (SBAS444), Config register, PGA[2:0] (bits 11:9): the full-scale
#: range, +- volts, by code (101, 110 and 111 are all +-0.256 V); 010 at reset
ADS1115_PGA_FS_V = {0: 6.144, 1: 4.096, 2: 2.048, 3: 1.024, 4: 0.512, 5: 0.256, 6: 0.256, 7: 0.256}


class FakeAds1115:
    """Single-shot conversions; ``inputs[ch]()`` gives the input in volts. MUX 100-111
    (AINx against GND) converts that input, at the full-scale range the PGA bits select
    (:data:`ADS1115_PGA_FS_V`); beyond it the code clips at 7FFFh / 8000h, as the
    datasheet's output-code table has it."""

    def __init__(self, inputs: dict[int, Callable[[], float]]):
        self.inputs = inputs
        self.config = 0x8583                 # the reset value: PGA 010, +-2.048 V
        self.conv = 0
        self.nack = False

    def write(self, reg: int, data: list[int]) -> None:
        if reg == 0x01 and len(data) == 2:
            self.config = data[0] << 8 | data[1]
            if self.config & 0x8000:
                ch = (self.config >> 12 & 7) - 4
                v = self.inputs.get(ch, lambda: 0.0)() if ch >= 0 else 0.0
                fs_v = ADS1115_PGA_FS_V[self.config >> 9 & 7]
                self.conv = max(-32768, min(32767, round(v / fs_v * 32768)))
                self.config |= 0x8000        # conversion done at once

    def read(self, reg: int, n: int) -> list[int]:
        word = self.conv & 0xFFFF if reg == 0x00 else self.config
        return [word >> 8, word & 0xFF][:n]


#: the Gray sequence backwards
_BACK = {v: k for k, v in _FWD.items()}


class QuadDriver:
    """Drives mock A/B pins through the Gray sequence to follow a count, and the index
    pin Z high while ``index(count)`` (one state wide: the counter has counted into the
    state when Z rises, whichever way the shaft turns). ``miss``: that many of the next
    steps are made two states at once, A's edge unreported (as when an edge report is
    lost: the decoder sees B's report only, and A's next report with the level A
    already had, an error)."""

    def __init__(self, a: Any, b: Any, count: Callable[[], int], *, z: Any = None,
                 index: Callable[[int], bool] | None = None):
        self.a, self.b, self.count = a, b, count
        self.z, self.index = z, index
        self.pos = count()
        self.state = 0b00
        self.miss = 0
        self._apply()

    def _apply(self) -> None:
        for pin, bit in ((self.a, 2), (self.b, 1)):
            if bool(self.state & bit) != bool(pin.state):
                (pin.drive_high if self.state & bit else pin.drive_low)()
        if self.z is not None and self.index is not None:
            on = self.index(self.pos)
            if on != bool(self.z.state):
                (self.z.drive_high if on else self.z.drive_low)()

    def sync(self) -> None:
        target = self.count()
        back = _BACK
        while self.pos != target:
            step = 1 if target > self.pos else -1
            nxt = _FWD if step > 0 else back
            if self.miss and abs(target - self.pos) >= 2:
                # A and B change together (A's edge unseen): an illegal transition, two counts lost
                self.miss -= 1
                self.state, self.pos = nxt[nxt[self.state]], self.pos + 2 * step
                seen = self.a.when_changed
                self.a.when_changed = None
                (self.a.drive_high if self.state & 2 else self.a.drive_low)()
                self.a.when_changed = seen
            else:
                self.state, self.pos = nxt[self.state], self.pos + step
            self._apply()
        for pin in (self.a, self.b, self.z):
            if pin is not None:
                pin.clear_states()          # MockPin keeps a history: bound it


class PulseDriver:
    """One closure of the simulated reed contact per new pulse, on a mock pin: low for
    half the time between pulses, stamped evenly over the time since the last sync (the
    reports' timestamps are what the counter's debounce judges). ``bounce``: each
    closure comes with that many extra openings and re-closures right after it;
    ``bounce_open``: each opening with that many re-closures right after it (a reed
    bounces both ways), 0.2 ms apart."""

    BOUNCE_S = 0.0002

    def __init__(self, pin: Any, edges: Callable[[], int]):
        self.pin, self.edges = pin, edges
        self.seen = edges()
        self.bounce = 0
        self.bounce_open = 0
        factory = pin.factory
        self._now_s = factory.ticks if isinstance(factory, EmulatedFactory) else None
        self._last_s = self._now_s() if self._now_s is not None else 0.0
        pin.drive_high()

    def _edge(self, level: bool, t_s: float) -> None:
        if isinstance(self.pin.factory, EmulatedFactory):
            self.pin.factory.event_s = t_s
        (self.pin.drive_high if level else self.pin.drive_low)()

    def _settle(self, level: bool, t_s: float, bounces: int) -> None:
        """The line to ``level`` at ``t_s``, with ``bounces`` returns to the other level."""
        self._edge(level, t_s)
        for j in range(bounces):
            self._edge(not level, t_s + (2 * j + 1) * self.BOUNCE_S)
            self._edge(level, t_s + (2 * j + 2) * self.BOUNCE_S)

    def sync(self) -> None:
        target = self.edges()
        now_s = self._now_s() if self._now_s is not None else 0.0
        n = target - self.seen
        for k in range(max(0, n)):
            period_s = (now_s - self._last_s) / n
            close_s = self._last_s + (k + 0.25) * period_s
            self._settle(False, close_s, self.bounce)
            self._settle(True, close_s + 0.5 * period_s, self.bounce_open)
            self.seen += 1
        if isinstance(self.pin.factory, EmulatedFactory):
            self.pin.factory.event_s = None
        self._last_s = now_s
        self.pin.clear_states()


def tilted(v: tuple[float, float, float], el_deg: float) -> tuple[float, float, float]:
    """A vector on the level chip's axes (seed 001's mounting: X right of the
    boresight, Y along it, Z up) as the chip sees it on a boom raised by ``el_deg``:
    the chip turned about its X axis, Y (the boresight) up."""
    e = math.radians(el_deg)
    x, y, z = v
    return (x, y * math.cos(e) + z * math.sin(e), -y * math.sin(e) + z * math.cos(e))


class FakeFram:
    """MB85RC256V-class FRAM: 2-byte memory address, then data; reads continue from the
    address written last (the i2c_rdwr write+read pair)."""

    def __init__(self, size_bytes: int = 32768, path: Any = None):
        self.mem = bytearray(size_bytes)
        self.path = path             # emulation: the chip's contents outlive the process
        if path is not None and path.exists() and path.stat().st_size == size_bytes:
            self.mem[:] = path.read_bytes()
        self.ptr = 0
        self.nack = False
        self.fail_after_bytes: int | None = None   # power cut mid-write (tests)

    def write(self, reg: int, data: list[int]) -> None:
        # write_i2c_block_data(addr, hi, [lo, *bytes])
        self.raw_write([reg, *data])

    def raw_write(self, data: list[int]) -> None:
        a = (data[0] << 8 | data[1]) % len(self.mem)
        for b in data[2:]:
            if self.fail_after_bytes is not None:
                if self.fail_after_bytes <= 0:
                    raise OSError(121, "Remote I/O error")
                self.fail_after_bytes -= 1
            self.mem[a] = b
            a = (a + 1) % len(self.mem)
        self.ptr = a
        if self.path is not None and len(data) > 2:
            self.path.write_bytes(self.mem)

    def read(self, reg: int, n: int) -> list[int]:
        out = [self.mem[(self.ptr + i) % len(self.mem)] for i in range(n)]
        self.ptr = (self.ptr + n) % len(self.mem)
        return out


def _rdwr(self: FakeSMBus, *msgs: Any) -> None:
    """smbus2.SMBus.i2c_rdwr over the emulated devices (write then read messages)."""
    import ctypes
    for m in msgs:
        dev = self._dev(m.addr)
        if m.flags & 0x0001:        # I2C_M_RD
            data = bytes(dev.read(None, m.len))
            ctypes.memmove(m.buf, data, m.len)
            self._rec("rd", m.addr, -1, data)
        else:
            data = list(bytes(m))
            self._rec("wr", m.addr, -1, data)
            dev.raw_write(data)


FakeSMBus.i2c_rdwr = _rdwr  # type: ignore[attr-defined]


class FakeLsm303agr:
    """The LSM303AGR's two I2C devices: ``accel`` at 0x19, ``mag`` at 0x1E."""

    class _Dev:
        def __init__(self, who_reg: int, who: int, out_reg: int, source: Callable[[], tuple[float, float, float]],
                     scale: float):
            self.regs = {who_reg: who}
            self.out_reg, self.source, self.scale = out_reg, source, scale
            self.nack = False

        def read(self, reg: int, n: int) -> list[int]:
            base = reg & 0x7F
            if base == self.out_reg:
                return FakeLsm303d._pack(self.source(), self.scale)[:n]
            return [self.regs.get(base + i, 0) for i in range(n)]

        def write(self, reg: int, data: list[int]) -> None:
            for i, v in enumerate(data):
                self.regs[(reg & 0x7F) + i] = v

    def __init__(self, mag: Callable[[], tuple[float, float, float]],
                 accel: Callable[[], tuple[float, float, float]]):
        self.accel = self._Dev(0x0F, 0x33, 0x28, accel, 0.98e-3 / 16)
        self.mag = self._Dev(0x4F, 0x40, 0x68, mag, 1.5e-3)


class FakeMcp3008:
    """MCP3008 behind an SPI device's ``xfer2``, clock by clock as the chip works: after
    CS falls, leading zeros, a start bit, SGL/DIFF, D2 D1 D0; then one sample clock, a
    null bit and the 10-bit result MSB first on MISO (MISO low before). ``inputs[ch]()``
    gives CHch in volts; differential pairs as the datasheet: code 0 = CH0-CH1, 1 =
    CH1-CH0, ... (clamped at 0). ``dead``: no chip, MISO reads low (a Pi pulls GPIO9
    down); ``miso_floating``: no chip and no pull-down, MISO high."""

    def __init__(self, inputs: dict[int, Callable[[], float]], vref_v: float = 3.3):
        self.inputs, self.vref_v = inputs, vref_v
        self.dead = False
        self.miso_floating = False
        self.fail: OSError | None = None          # tests: the transfer fails (ioctl error)
        #: the last conversions as (single-ended, channel, code)
        self.transactions: collections.deque[tuple[bool, int, int]] = collections.deque(maxlen=64)
        #: with ``keep_frames``: each frame's (MOSI, MISO) bytes
        self.keep_frames = False
        self.frames: list[tuple[tuple[int, ...], tuple[int, ...]]] = []

    def _volts(self, ch: int) -> float:
        src = self.inputs.get(ch)
        return float(src()) if src is not None else 0.0

    def code(self, single: bool, ch: int) -> int:
        if single:
            v = self._volts(ch)
        else:
            plus, minus = (ch & 6) | (ch & 1), (ch & 6) | (1 - (ch & 1))
            v = self._volts(plus) - self._volts(minus)
        return max(0, min(1023, int(1024 * v / self.vref_v)))

    def xfer2(self, data: list[int]) -> list[int]:
        if self.fail is not None:
            raise self.fail
        mosi = [b >> (7 - i) & 1 for b in data for i in range(8)]
        miso = [1 if self.dead and self.miso_floating else 0] * len(mosi)
        if not self.dead and 1 in mosi:
            start = mosi.index(1)
            cmd = mosi[start + 1:start + 5]
            if len(cmd) == 4:
                single, ch = bool(cmd[0]), cmd[1] << 2 | cmd[2] << 1 | cmd[3]
                code = self.code(single, ch)
                self.transactions.append((single, ch, code))
                out = start + 7                   # after D0: the sample clock, the null bit
                for k in range(10):
                    if out + k < len(miso):
                        miso[out + k] = code >> (9 - k) & 1
        rx = []
        for j in range(0, len(miso), 8):  # MSB first (shifted in, not a sum of powers: runs every tick)
            byte = 0
            for bit in miso[j:j + 8]:
                byte = byte << 1 | bit
            rx.append(byte)
        if self.keep_frames:
            self.frames.append((tuple(data), tuple(rx)))
        return rx

    def close(self) -> None:
        pass


class FaultedView:
    """A simulated axis as an emulated sensor part senses it, with the sensor faults
    injected into the simulator (``SimWorld.inject``) acting on the part as they would
    on iron: ``sensor_stuck`` and ``sensor_dead`` freeze what the part senses (a jammed
    magnet or wiper, encoder or reed lines that carry nothing any more), ``sensor_jump``
    (deg) offsets it (a slipped coupling; the encoder/reed lines carry the extra edges).
    A dead chip NACKs instead (see ``feed_sensor``); ``slow_read`` stalls a chip's bus
transactions (:meth:`bus_wait`; pins have no bus to stall). Everything else is the axis'."""

    def __init__(self, phys: Any, faults: Callable[[], Mapping[str, Mapping[str, Any]]],
                 slow_s: Callable[[], float] | None = None):
        self._phys, self._faults, self._slow_s = phys, faults, slow_s
        self._frozen: dict[str, float] = {}

    def bus_wait(self) -> None:
        """A chip's read through a bus that stalls (``slow_read``: clock stretching, a
        timeout): the transaction takes that long in wall time."""
        delay_s = self._slow_s() if self._slow_s is not None else 0.0
        if delay_s > 0.0:
            time.sleep(delay_s)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.__dict__["_phys"], name)

    def _sensed(self, what: str, live: float) -> tuple[float, float]:
        """``live``, or what it was when a stuck/dead fault came, while it lasts; and
        the jump (deg) on top."""
        f = self._faults()
        if "sensor_stuck" in f or "sensor_dead" in f:
            live = self._frozen.setdefault(what, live)
        else:
            self._frozen.pop(what, None)
        return live, float(f["sensor_jump"].get("deg", 10.0)) if "sensor_jump" in f else 0.0

    def sensor_side_deg(self) -> float:
        deg, jump_deg = self._sensed("deg", self._phys.sensor_side_deg())
        return deg + jump_deg

    @property
    def pulse_edges(self) -> int:
        edges, jump_deg = self._sensed("edges", self._phys.pulse_edges)
        res = self._phys.pulse_res_deg
        return int(edges) + (round(abs(jump_deg) / res) if jump_deg and res else 0)

    def dead(self) -> bool:
        return "sensor_dead" in self._faults()
