"""One real smbus2 bus, two threads: the control tick reading a chip and the FRAM state
writer saving a record (an AS5600 and an MB85RC256V FRAM on bus 1: the Tartu design's
FRAM beside any I2C sensor a gpio configuration puts on the same bus).

smbus2 sets the slave address on the file descriptor (``ioctl(I2C_SLAVE)``) and then
transfers (``ioctl(I2C_SMBUS)``) in two steps; between them the other thread can set its
own address. Here the real smbus2 code runs against a stand-in for the kernel's ioctl
that keeps the descriptor's slave address and records where every transfer went. The
interleaving is forced: the FRAM writer is held just after setting its address while
the tick reads.
"""

from __future__ import annotations

import threading

import pytest
import smbus2.smbus2 as smbus2_module

from urc.hardware.fram import FramStore
from urc.hardware.gpio.buses import Buses
from urc.hardware.gpio.i2c import SerialisedBus

FRAM, AS5600 = 0x50, 0x36


class KernelI2c:
    """The i2c-dev driver as far as smbus2 sees it: a slave address per open file, and
    transfers that go to it. Holds the first thread named ``fram`` just after it sets
    its address, until another thread has made a transfer or is waiting for the bus'
    lock (``other_went``)."""

    def __init__(self):
        self.slave: int | None = None
        self.transfers: list[tuple[str, int | None]] = []  # (thread, slave address used)
        self.other_went = threading.Event()
        self.held = threading.Event()

    def ioctl(self, fd, request, arg):
        me = threading.current_thread().name
        if request in (smbus2_module.I2C_SLAVE, smbus2_module.I2C_SLAVE_FORCE):
            self.slave = arg
            if me == "fram" and not self.held.is_set():
                self.held.set()
                assert self.other_went.wait(10.0), "the other thread neither transferred nor waited"
        elif request in (smbus2_module.I2C_SMBUS, smbus2_module.I2C_RDWR):
            self.transfers.append((me, self.slave))
            if me != "fram":
                self.other_went.set()
        return 0


def race(bus, kernel: KernelI2c) -> list[tuple[str, int | None]]:
    """The FRAM writer saves a record while the tick reads the AS5600's STATUS once,
    right after the writer has set its address."""
    store = FramStore(bus, FRAM)
    writer = threading.Thread(target=lambda: store._write(0x0010, b"URCF" + bytes(8)), name="fram")
    writer.start()
    assert kernel.held.wait(5.0)
    tick = threading.Thread(target=lambda: bus.read_byte_data(AS5600, 0x0B), name="tick")
    tick.start()
    tick.join(5.0)
    writer.join(5.0)
    assert not tick.is_alive() and not writer.is_alive()
    return kernel.transfers


def wrong(transfers: list[tuple[str, int | None]]) -> list[tuple[str, int | None]]:
    meant = {"fram": FRAM, "tick": AS5600}
    return [(who, addr) for who, addr in transfers if addr != meant[who]]


class LockSpy:
    """The SerialisedBus' lock, telling the kernel stand-in when the tick asks for it
    (it then waits: the writer holds it)."""

    def __init__(self, kernel: KernelI2c):
        self._lock, self.kernel = threading.Lock(), kernel

    def __enter__(self):
        if threading.current_thread().name != "fram":
            self.kernel.other_went.set()
        self._lock.acquire()

    def __exit__(self, *exc):
        self._lock.release()


@pytest.fixture
def kernel(monkeypatch):
    k = KernelI2c()
    monkeypatch.setattr(smbus2_module, "ioctl", k.ioctl)
    return k


def test_a_bare_smbus2_bus_sends_the_fram_write_to_the_encoder(kernel):
    # the hazard itself: without a lock the record's first chunk is written to 0x36
    assert wrong(race(smbus2_module.SMBus(), kernel)) == [("fram", AS5600)]


def test_a_serialised_bus_sends_every_transfer_to_its_own_chip(kernel):
    bus = SerialisedBus(smbus2_module.SMBus())
    bus.lock = LockSpy(kernel)  # type: ignore[assignment]
    transfers = race(bus, kernel)
    assert not wrong(transfers), transfers
    assert [who for who, _ in transfers] == ["fram", "tick"]   # (the tick waited for the chunk)


def test_the_gpio_backend_opens_its_buses_serialised(monkeypatch):
    opened = []
    monkeypatch.setattr(smbus2_module.SMBus, "__init__", lambda self, n=None, force=False: opened.append(n))
    buses = Buses(gpio=None, emulate=False, parts=[])
    assert isinstance(buses.bus(1), SerialisedBus) and opened == [1]
    assert buses.bus(1) is buses.bus(1)   # (one bus, one lock, for every part on it)
    # emulated too, so that a bus call the wrapper lacks fails in the emulated runs
    emulated = Buses(gpio=None, emulate=True, parts=[])
    assert isinstance(emulated.bus(1), SerialisedBus) and emulated.fake_devices(1, None) == {}
