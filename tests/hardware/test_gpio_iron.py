"""The gpio backend's non-emulated path (what runs on a Pi) on mock pins, with the
Pi-only libraries' classes standing in for the kernel devices (rpi-hardware-pwm's
sysfs PWM, spidev, smbus2): hardware PWM pin selection (also at config level), SPI0
for the MCP3008, the TCA9548A on a real bus object."""

from __future__ import annotations

import logging
import sys
import types
from pathlib import Path

import pytest
from click.testing import CliRunner
from gpiozero import Device
from gpiozero.pins.mock import MockFactory, MockPWMPin

from urc.assembly import hardware_options, settings_from_config
from urc.cli import main
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.errors import ConfigError
from urc.hardware import build_hardware
from urc.hardware.gpio.pins import PinPwm
from urc.hardware.gpio.pwm import HardwarePwm, pwm_advice, pwm_plan

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def gpio_of(name: str, **section):
    data = load_config(EXAMPLES / f"{name}.toml").to_dict()
    data["hardware"]["gpio"].update(section)
    return Config.from_dict(data)


def test_plan_gives_each_channel_to_one_pin():
    assert pwm_plan(gpio_of("tartu-urc").hardware.gpio) == {"az.pwm": (12, 0), "el.pwm": (13, 1)}
    # the IBT-2's four PWM inputs: a Pi 3/4 has two channels (12 and 18 are both PWM0)
    assert pwm_plan(gpio_of("bigras").hardware.gpio) == {
        "az.rpwm": (12, 0), "az.lpwm": (13, 1), "el.rpwm": (18, None), "el.lpwm": (19, None)}
    assert pwm_plan(gpio_of("bigras", hardware_pwm="4chan").hardware.gpio) == {
        "az.rpwm": (12, 0), "az.lpwm": (13, 1), "el.rpwm": (18, 2), "el.lpwm": (19, 3)}
    assert all(ch is None for _, ch in pwm_plan(gpio_of("tartu-urc", hardware_pwm="off").hardware.gpio).values())
    assert pwm_plan(gpio_of("g5500").hardware.gpio) == {}              # relays: no PWM


def test_advice_warns_about_software_pwm_and_config_check_shows_it(tmp_path):
    assert pwm_advice(gpio_of("tartu-urc").hardware.gpio) == []
    notes = pwm_advice(gpio_of("bigras").hardware.gpio)
    assert len(notes) == 2 and notes[0].startswith("hardware.gpio.el.pins.rpwm: GPIO18 shares PWM0 with az.rpwm")
    data = load_config(EXAMPLES / "tartu-urc.toml").to_dict()
    data["hardware"]["gpio"]["az"]["pins"]["pwm"] = 6    # (GPIO5 is the safety chain's read-back)
    notes = pwm_advice(Config.from_dict(data).hardware.gpio)
    assert notes == ["hardware.gpio.az.pins.pwm: GPIO6 has no hardware PWM; software PWM jitters under CPU "
                     "load (hardware PWM pins: GPIO12, GPIO13, GPIO18, GPIO19)"]
    path = tmp_path / "c.toml"
    path.write_text((EXAMPLES / "tartu-urc.toml").read_text().replace("pwm = 12", "pwm = 6"))
    r = CliRunner().invoke(main, ["config", "check", str(path)])
    assert r.exit_code == 0 and "warning: hardware.gpio.az.pins.pwm: GPIO6 has no hardware PWM" in r.output
    notes = pwm_advice(gpio_of("bigras", hardware_pwm="4chan").hardware.gpio)
    assert notes == []
    data = load_config(EXAMPLES / "bigras.toml").to_dict()
    data["hardware"]["gpio"]["el"]["pwm_frequency_hz"] = 20000.0     # inaudible, but el is software PWM
    notes = pwm_advice(Config.from_dict(data).hardware.gpio)
    assert "hardware.gpio.el.pwm_frequency_hz: 20000 Hz, but GPIO18 runs software PWM" in notes[0]
    with pytest.raises(ConfigError, match=r"hardware.gpio.hardware_pwm.*2chan"):
        gpio_of("tartu-urc", hardware_pwm="3chan")


class FakeHardwarePWM:
    """rpi_hardware_pwm.HardwarePWM's calls, recorded (no sysfs here)."""
    made: list["FakeHardwarePWM"] = []
    missing: set[int] = set()

    def __init__(self, pwm_channel: int, hz: float, chip: int = 0):
        if pwm_channel in self.missing:
            raise OSError(2, f"No such file or directory: '/sys/class/pwm/pwmchip{chip}'")
        self.channel, self.hz, self.chip = pwm_channel, hz, chip
        self.calls: list[tuple] = []
        self.made.append(self)

    def start(self, duty: float) -> None:
        self.calls.append(("start", duty))

    def change_duty_cycle(self, duty: float) -> None:
        self.calls.append(("duty", duty))

    def stop(self) -> None:
        self.calls.append(("stop",))


@pytest.fixture
def iron(monkeypatch):
    """The gpio backend's non-emulated path on mock pins and a fake PWM peripheral."""
    factory = MockFactory(pin_class=MockPWMPin)
    monkeypatch.setattr(Device, "pin_factory", factory)
    FakeHardwarePWM.made, FakeHardwarePWM.missing = [], set()
    monkeypatch.setitem(sys.modules, "rpi_hardware_pwm", types.SimpleNamespace(HardwarePWM=FakeHardwarePWM))

    def build(name: str, tmp_path: Path, **section):
        cfg = gpio_of(name, **section)
        caps = settings_from_config(cfg).caps
        return build_hardware("gpio", caps, VirtualClock(1000.0), tmp_path, hardware_options(cfg))
    yield build
    factory.close()


def test_iron_uses_hardware_pwm_where_the_pin_has_a_channel(iron, tmp_path):
    hw = iron("bigras", tmp_path)
    az, el = hw.az.motor, hw.el.motor
    assert isinstance(az.rpwm, HardwarePwm) and isinstance(az.lpwm, HardwarePwm)
    assert [(f.channel, f.hz, f.chip) for f in FakeHardwarePWM.made] == [(0, 1000.0, 0), (1, 1000.0, 0)]
    assert isinstance(el.rpwm, PinPwm) and el.rpwm.pin.frequency == 1000.0
    az.set_drive(-0.4)
    el.set_drive(0.7)
    # a channel is disabled at once (a killed urc may have left it running), enabled
    # only with the first non-zero duty
    assert FakeHardwarePWM.made[1].calls == [("stop",), ("start", pytest.approx(40.0))]   # LPWM: reverse
    assert FakeHardwarePWM.made[0].calls == [("stop",)]                                   # RPWM stays off
    az.set_drive(-0.4)                                                         # unchanged: no write
    assert len(FakeHardwarePWM.made[1].calls) == 2
    assert el.rpwm.pin.state == pytest.approx(0.7) and el.lpwm.pin.state == 0.0
    labels = [label for label, _ in hw.parts]
    assert "az rpwm" in labels and "el rpwm" not in labels
    hw.close()
    assert all(f.calls[-1] == ("stop",) for f in FakeHardwarePWM.made)


@pytest.mark.usefixtures("iron")
def test_hardware_pwm_that_cannot_open_falls_back_to_software(tmp_path, caplog):
    FakeHardwarePWM.missing = {1}                    # el's channel not routed by the overlay
    data = load_config(EXAMPLES / "tartu-urc.toml").to_dict()
    for a in ("az", "el"):                           # no MCP3008 here: no SPI device on this machine
        del data["hardware"]["gpio"][a]["adc"], data["hardware"]["gpio"][a]["current_sense_channel"]
    cfg = Config.from_dict(data)
    with caplog.at_level(logging.WARNING):
        hw = build_hardware("gpio", settings_from_config(cfg).caps, VirtualClock(1000.0), tmp_path,
                            hardware_options(cfg))
    assert isinstance(hw.az.motor.pwm, HardwarePwm) and isinstance(hw.el.motor.pwm, PinPwm)
    assert "GPIO13: hardware PWM1 unavailable" in caplog.text
    hw.el.motor.set_drive(0.5)
    assert hw.el.motor.pwm.pin.state == pytest.approx(0.5)
    hw.close()


class FakeSpiDev:
    """py-spidev's SpiDev, answering as the MCP3008 emulation does."""
    opened: list["FakeSpiDev"] = []

    def __init__(self):
        from urc.hardware.gpio.emulate import FakeMcp3008
        self.chip = FakeMcp3008({0: lambda: 1.0, 1: lambda: 2.0})
        self.port = self.device = self.max_speed_hz = self.mode = None
        self.closed = False
        self.opened.append(self)

    def open(self, port, device):
        self.port, self.device = port, device

    def xfer2(self, data):
        return self.chip.xfer2(list(data))

    def close(self):
        self.closed = True


class SharedFakeSMBus:
    """smbus2.SMBus(n) on iron: one fake bus per number, with the Berkeley chips behind a mux."""
    buses: dict = {}

    def __new__(cls, n):
        from urc.hardware.gpio.emulate import FakeAs5600, FakeSMBus
        if n not in cls.buses:
            bus = FakeSMBus()
            # az: 90 deg (raw 270: the example's az chip counts the other way, as5600_reversed)
            bus.mux_channel(0x70, 0)[0x36] = FakeAs5600(lambda: 3072)
            bus.mux_channel(0x70, 1)[0x36] = FakeAs5600(lambda: 512)     # el: 45 deg
            cls.buses[n] = bus
        return cls.buses[n]


def test_iron_opens_spi0_and_the_i2c_mux_through_their_libraries(iron, tmp_path, monkeypatch):
    """The non-emulated wiring of the MCP3008 (spidev) and the TCA9548A (smbus2), with
    the libraries' classes standing in for the kernel devices."""
    import smbus2
    FakeSpiDev.opened = []
    monkeypatch.setitem(sys.modules, "spidev", types.SimpleNamespace(SpiDev=FakeSpiDev))
    SharedFakeSMBus.buses = {}
    monkeypatch.setattr(smbus2, "SMBus", SharedFakeSMBus)
    hw = iron("g4jnt", tmp_path)
    (spi,) = FakeSpiDev.opened                       # one chip for both pots, on CE0, mode 0, 1 MHz
    assert (spi.port, spi.device, spi.mode, spi.max_speed_hz) == (0, 0, 0, 1_000_000)
    assert hw.az.sensor.adc.read_counts() == int(1024 * 1.0 / 3.3)
    assert hw.el.sensor.adc.read_counts() == int(1024 * 2.0 / 3.3)
    hw.close()
    assert spi.closed
    hw = iron("berkeley", tmp_path / "b")
    assert hw.az.sensor.read_deg() == pytest.approx(90.0) and hw.el.sensor.read_deg() == pytest.approx(45.0)
    assert SharedFakeSMBus.buses[1].devices[0x70].control == 0x02      # el read last: channel 1
    hw.close()


def test_exit_holds_the_brake_without_pwm_also_on_software_pwm(iron, tmp_path, monkeypatch):
    """Review 20 #12: the exit step ran only when some output had hardware PWM, so a
    software-PWM LMD18200 exited with lgpio's tx_pwm at 100 % and BRAKE high (its level
    undefined once the thread stops). Now the PWM is stopped and BRAKE written low with
    PWM low: the table's other braking row (TI Table 1), whatever PWM the pin had."""
    from urc.hardware.drivers.motors import lmd18200_state, vnh5019_state
    monkeypatch.setitem(sys.modules, "spidev", types.SimpleNamespace(SpiDev=FakeSpiDev))
    data = load_config(EXAMPLES / "tartu-urc.toml").to_dict()
    data["hardware"]["gpio"]["hardware_pwm"] = "off"
    data["hardware"]["gpio"]["az"].update(motor="lmd18200", pins={
        "pwm": 12, "dir": 24, "bridge_brake": 25, "enc_a": 17, "enc_b": 27, "brake": 16},
        current_sense_v_per_a=377e-6 * 2200)
    cfg = Config.from_dict(data)
    hw = build_hardware("gpio", settings_from_config(cfg).caps, VirtualClock(1000.0), tmp_path,
                        hardware_options(cfg))
    m = hw.az.motor
    assert isinstance(m.pwm_out, PinPwm) and m.pwm_out.pin.frequency is not None
    hw.close()
    assert m.pwm_out.pin.frequency is None and m.pwm_out.pin.state == 0     # tx_pwm stopped, low
    assert lmd18200_state(False, m.dir_out.read_back(), m.brake_out.read_back()) == "brake"
    assert m.brake_out.read_back() is False
    # the VNH5019 (hardware PWM, idling low once disabled): INA = INB = 1, brake to VCC
    hw = iron("tartu-urc", tmp_path / "t")
    m = hw.el.motor
    hw.close()
    assert FakeHardwarePWM.made[-1].calls[-1] == ("stop",)
    assert vnh5019_state(m.ina.read_back(), m.inb.read_back(), False) == "brake"
