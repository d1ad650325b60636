"""The ``gpio`` backend: the seed machines' real parts on a Raspberry Pi.

Pins through gpiozero's pin factory (lgpio on a Pi: ``pip install urc[pi]``), I2C
through smbus2. With ``emulate`` the same drivers run on gpiozero MockFactory pins and a
fake SMBus fed by the physics simulator (:mod:`.emulate`), and status carries
``simulator_truth``.

Options (from ``[hardware.gpio]``, see :class:`urc.config.GpioSection`): ``gpio`` (the
section), ``emulate`` (bool) plus the simulator's options when emulated.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

from ...caps import RotatorCaps
from ...clock import Clock
from ...errors import ConfigError
from ..drivers import (As5600Sensor, Bts7960Motor, CompassSensor, LimitSwitchInput, Lmd18200Motor,
                       PotSensor, PwmDirMotor, QuadratureEncoder, RelayBrake, RelayMotor,
                       SenseCurrent, SpidPulseSensor, TiltSensor, Vnh5019Motor)
from ..interfaces import AxisHardware, Hardware
from .i2c import (AdcInput, Ads1115Channel, Ads1115Chip, As5600Chip, Lsm303Accel, Lsm303agrChip, Lsm303dChip,
                  Lsm303Mag, Tca9548aMux)
from ..sim.params import PHYSICS, physics_for
from .pins import PinIn, PinOut, PinPulseCounter, PinQuadrature
from .pwm import HardwarePwm, make_pwm, pwm_advice, pwm_plan
from .spi import Mcp3008Channel, Mcp3008Chip, open_spidev

log = logging.getLogger(__name__)

#: pins each motor driver needs (besides brake / limit_min / limit_max)
MOTOR_PINS = {"vnh5019": ("ina", "inb", "pwm"), "lmd18200": ("pwm", "dir", "bridge_brake"),
              "bts7960": ("rpwm", "lpwm"), "pwm_dir": ("pwm", "dir"), "relay": ("cw", "ccw")}
OPTIONAL_PINS = {"relay": ("fast",), "encoder": ("enc_z",)}
SENSOR_PINS = {"encoder": ("enc_a", "enc_b"), "pulse": ("pulse",)}
#: what each profile's sensor kind is on the bus
I2C_SENSORS = {"as5600": "as5600", "magnetometer": "lsm303d", "pot": "ads1115"}


def _emulated_motor_duty(kind: str, motor: Any, levels: tuple[float, ...]) -> float:
    """What the bridge / relays really put on the motor, read back from the pins."""
    if kind == "vnh5019":
        d = int(motor.ina.read_back()) - int(motor.inb.read_back())
        return d * motor.pwm.read_back()
    if kind == "lmd18200":
        if motor.brake_out.read_back():
            return 0.0
        return (1.0 if motor.dir_out.read_back() else -1.0) * motor.pwm_out.read_back()
    if kind == "bts7960":
        return motor.rpwm.read_back() - motor.lpwm.read_back()
    if kind == "pwm_dir":
        return (1.0 if motor.dir_out.read_back() else -1.0) * motor.pwm_out.read_back()
    # relay: a speed relay selects the slow winding; without one the driver pulses
    d = int(motor.cw.read_back()) - int(motor.ccw.read_back())
    slow = motor.fast is not None and not motor.fast.read_back()
    return d * (min(levels) if slow else 1.0)


class _EmulatedMotor:
    """The driver on mock pins; after each drive the pins are decoded into the
    simulated motor (after the world has caught up with the present)."""

    def __init__(self, driver: Any, kind: str, world: Any, axis: str, levels: tuple[float, ...]):
        self.driver, self.kind, self.world, self.axis, self.levels = driver, kind, world, axis, levels

    def set_drive(self, duty: float) -> None:
        self.world.catch_up()
        self.driver.set_drive(duty)
        self.world.axes[self.axis].set_command(_emulated_motor_duty(self.kind, self.driver, self.levels))

    def read_current_a(self) -> float:
        # through the current-sense part when one is wired (0 without, as on iron)
        return self.driver.read_current_a()

    def __getattr__(self, name: str) -> Any:
        return getattr(self.__dict__["driver"], name)


class _EmulatedBrake:
    def __init__(self, driver: RelayBrake, world: Any, axis: str):
        self.driver, self.world, self.axis = driver, world, axis

    def set_released(self, released: bool) -> None:
        self.driver.set_released(released)
        self.world.command_brake(self.axis, self.driver.coil.read_back())

    def is_released(self) -> bool:
        return self.driver.is_released()


def build_gpio_hardware(caps: RotatorCaps, clock: Clock, state_dir: Path,
                        options: dict[str, Any]) -> Hardware:
    gpio = options.get("gpio")
    if gpio is None:
        raise ConfigError("backend \"gpio\" needs a [hardware.gpio] section with the pin map",
                          key="hardware.gpio", expected="[hardware.gpio.az] and [hardware.gpio.el]",
                          found=None)
    emulate = bool(options.get("emulate", gpio.emulate))
    world = None
    buses: dict[int, Any] = {}
    fake_spi: dict[int, Any] = {}

    if emulate:
        from gpiozero.pins.mock import MockFactory, MockPWMPin

        from ..sim import make_world
        from .emulate import FakeSMBus
        sim_opts = {k: v for k, v in options.items() if k not in ("gpio", "emulate", "bridge")}
        world, params = make_world(caps, clock, state_dir, sim_opts)
        factory = MockFactory(pin_class=MockPWMPin)

        def bus(n: int) -> Any:
            return buses.setdefault(n, FakeSMBus())

        def spi_dev(device: int) -> Any:
            from .emulate import FakeMcp3008
            return fake_spi.setdefault(device, FakeMcp3008({}))
    else:
        try:
            from gpiozero import Device
            factory = Device.pin_factory   # set by the user (GPIOZERO_PIN_FACTORY) or a test
            if factory is None:
                from gpiozero.pins.lgpio import LGPIOFactory
                factory = LGPIOFactory()
        except Exception as exc:  # no lgpio / not a Pi
            raise ConfigError(f"gpio backend: no GPIO here ({exc}); install urc[pi] on a Raspberry "
                              "Pi, or run with --emulate", key="hardware.gpio.emulate",
                              expected="true off a Pi", found=False) from exc
        import smbus2

        def bus(n: int) -> Any:
            if n not in buses:
                try:
                    buses[n] = smbus2.SMBus(n)
                except OSError as exc:
                    raise ConfigError(f"I2C bus {n}: {exc} (enable I2C with raspi-config)",
                                      key="hardware.gpio.i2c_bus", expected="an I2C bus", found=n) from exc
            return buses[n]

        def spi_dev(device: int) -> Any:
            try:
                return open_spidev(device)
            except (ImportError, OSError) as exc:
                raise ConfigError(f"SPI0 CE{device}: {exc} (install urc[pi]; enable SPI with raspi-config)",
                                  key="hardware.gpio.spi_device", expected="an SPI device", found=device) from exc

    muxes: dict[int, Tca9548aMux] = {}

    def chip_bus(n: int, channel: int | None) -> Any:
        """The bus a chip talks on: the bus itself, or one channel of its TCA9548A."""
        if channel is None:
            return bus(n)
        if n not in muxes:
            muxes[n] = Tca9548aMux(bus(n), gpio.i2c_mux_address)
            parts_list.append((f"TCA9548A 0x{gpio.i2c_mux_address:02x} (bus {n})", muxes[n]))
        return muxes[n].channel(channel)

    spi_chips: dict[int, Mcp3008Chip] = {}
    plan = pwm_plan(gpio)
    pwm_parts: list[HardwarePwm] = []
    for note in pwm_advice(gpio):
        log.warning("%s", note)
    syncs: list[Any] = []
    emu = _Emulation(world, syncs, fake_spi, {}) if world is not None else None
    lsm: dict[tuple[int, int | None, int], Lsm303dChip] = {}
    axes: dict[str, AxisHardware] = {}
    parts_list: list[tuple[str, Any]] = []
    for name in caps.axes:  # a single-axis rotator wires no elevation parts at all
        ax_caps = caps.axis(name)
        cfg = getattr(gpio, name)
        pins = cfg.pins
        pwm_hz = cfg.pwm_frequency_hz

        def out(key: str) -> PinOut:
            return PinOut(factory, pins[key])

        def pwm(key: str) -> Any:
            part = make_pwm(factory, pins[key], plan[f"{name}.{key}"][1], pwm_hz, emulated=emulate)
            if isinstance(part, HardwarePwm):
                pwm_parts.append(part)
                parts_list.append((f"{name} {key}", part))
            return part

        bus_n = cfg.i2c_bus if cfg.i2c_bus is not None else gpio.i2c_bus
        mux_ch = cfg.i2c_mux_channel
        on_bus = f"bus {bus_n}" + ("" if mux_ch is None else f" mux ch{mux_ch}")

        def adc_chip() -> Any:
            """The axis' ADC (pot and/or current sense): one MCP3008 per chip select,
            or the ADS1115 at its address."""
            if cfg.adc == "mcp3008":
                if cfg.spi_device not in spi_chips:
                    # VREF: the pot supply when no input reads it, else the 3.3 V rail
                    pot_vref = sk == "pot" and cfg.adc_reference_channel is None
                    spi_chips[cfg.spi_device] = Mcp3008Chip(
                        spi_dev(cfg.spi_device), cfg.spi_device, vref_v=cfg.adc_reference_v if pot_vref else 3.3)
                return spi_chips[cfg.spi_device]
            return Ads1115Chip(chip_bus(bus_n, mux_ch), cfg.i2c_address or 0x48, f"{name} ADS1115")

        sk = ax_caps.sensor.kind
        cs = None
        if cfg.current_sense_channel is not None:
            cs_chip = adc_chip()
            cs = SenseCurrent(AdcInput(cs_chip, cfg.current_sense_channel), cfg.current_sense_v_per_a)
            where = f"SPI0 CE{cfg.spi_device}" if cfg.adc == "mcp3008" else on_bus
            parts_list.append((f"{name} current sense {cfg.adc.upper()} ch{cfg.current_sense_channel} "
                               f"({where})", cs_chip))
        kind = cfg.motor
        if kind == "vnh5019":
            motor: Any = Vnh5019Motor(name, out("ina"), out("inb"), pwm("pwm"), current=cs)
        elif kind == "lmd18200":
            motor = Lmd18200Motor(name, pwm("pwm"), out("dir"), out("bridge_brake"), current=cs)
        elif kind == "bts7960":
            motor = Bts7960Motor(name, pwm("rpwm"), pwm("lpwm"), current=cs)
        elif kind == "pwm_dir":
            motor = PwmDirMotor(name, pwm("pwm"), out("dir"))
        else:
            motor = RelayMotor(name, out("cw"), out("ccw"), clock,
                               fast=out("fast") if "fast" in pins else None,
                               levels=ax_caps.drive_levels or (1.0,),
                               reverse_dead_time_s=cfg.relay_dead_time_s)
        sensor: Any
        if sk == "encoder":
            counter = PinQuadrature(factory, pins["enc_a"], pins["enc_b"], pins.get("enc_z"))
            sensor = QuadratureEncoder(ax_caps.sensor, name, counter, motor=motor,
                                       index_deg=cfg.encoder_index_deg,
                                       index_period_deg=cfg.encoder_index_period_deg,
                                       drift_counts=cfg.encoder_drift_counts, clock=clock)
            parts_list.append((f"{name} encoder", counter))
        elif sk == "pulse":
            counter = PinPulseCounter(factory, pins["pulse"])
            sensor = SpidPulseSensor(ax_caps.sensor, name, counter, motor)
            parts_list.append((f"{name} pulse counter", counter))
        elif sk == "as5600":
            chip = As5600Chip(chip_bus(bus_n, mux_ch), cfg.i2c_address or As5600Chip.ADDRESS, f"{name} AS5600")
            sensor = As5600Sensor(ax_caps.sensor, name, chip, zero_deg=cfg.zero_deg)
            parts_list.append((f"{name} AS5600 ({on_bus})", chip))
        elif sk == "magnetometer":
            if cfg.compass == "lsm303agr":
                key = (bus_n, mux_ch, Lsm303agrChip.MAG)
                chip = lsm.get(key) or lsm.setdefault(key, Lsm303agrChip(chip_bus(bus_n, mux_ch)))
            else:
                key = (bus_n, mux_ch, cfg.i2c_address or Lsm303dChip.ADDRESS)
                chip = lsm.get(key) or lsm.setdefault(key, Lsm303dChip(chip_bus(bus_n, mux_ch), key[2]))
            if name == "az":
                sensor = CompassSensor(ax_caps.sensor, name, Lsm303Mag(chip), Lsm303Accel(chip),
                                       declination_deg=cfg.declination_deg)
            else:
                sensor = TiltSensor(ax_caps.sensor, name, Lsm303Accel(chip))
            parts_list.append((f"{name} {cfg.compass.upper()} ({on_bus})", chip))
        elif cfg.adc == "mcp3008":  # pot through an MCP3008 on SPI0
            spi_chip = adc_chip()
            adc = Mcp3008Channel(spi_chip, cfg.adc_channel, cfg.adc_reference_channel,
                                 reference_v=cfg.adc_reference_v)
            sensor = _pot_sensor(caps, name, ax_caps, cfg, adc)
            parts_list.append((f"{name} MCP3008 ch{cfg.adc_channel} (SPI0 CE{cfg.spi_device})", spi_chip))
        else:  # pot through an ADS1115
            chip = adc_chip()
            adc = Ads1115Channel(chip, cfg.adc_channel, _ads_reference(cfg),
                                 reference_v=cfg.adc_reference_v)
            sensor = _pot_sensor(caps, name, ax_caps, cfg, adc)
            parts_list.append((f"{name} ADS1115 ch{cfg.adc_channel} ({on_bus})", chip))
        brake = RelayBrake(name, out("brake"), clock, release_s=ax_caps.brake_release_s) \
            if "brake" in pins else None
        lims = [LimitSwitchInput(f"{name} {side}", PinIn(factory, pins[f"limit_{side}"]),
                                 active_low=cfg.limit_active_low) if f"limit_{side}" in pins else None
                for side in ("min", "max")]
        if world is not None:
            motor_hw: Any = _EmulatedMotor(motor, kind, world, name, ax_caps.drive_levels or (1.0,))
            brake_hw: Any = _EmulatedBrake(brake, world, name) if brake is not None else None
            fake_bus = buses.get(bus_n)
            devices = (fake_bus.devices if mux_ch is None else
                       fake_bus.mux_channel(gpio.i2c_mux_address, mux_ch)) if fake_bus is not None else {}
            assert emu is not None
            _feed_sensor(name, sk, sensor, devices, cfg, emu)
            if cs is not None:
                _feed_current_sense(world.axes[name], cfg, devices, fake_spi)
            for side, sw in zip(("min", "max"), lims):
                sim_sw = world.limits[name][0 if side == "min" else 1]
                if sw is not None and sim_sw is not None:
                    syncs.append(_limit_sync(sw, sim_sw))
        else:
            motor_hw, brake_hw = motor, brake
        axes[name] = AxisHardware(motor=motor_hw, sensor=sensor, brake=brake_hw,
                                  limit_min=lims[0], limit_max=lims[1])

    heartbeat = PinOut(factory, gpio.heartbeat_pin) if gpio.heartbeat_pin is not None else None
    extra: dict[str, Any] = {"parts": parts_list, "buses": buses, "pin_factory": factory,
                             "emulated": emulate, "spi_chips": spi_chips}
    if gpio.fram_address is not None:
        from ..fram import FramStore
        fram_bus = bus(gpio.i2c_bus)
        if emulate:
            from .emulate import FakeFram
            fram_bus.devices[gpio.fram_address] = FakeFram(path=Path(state_dir) / "fram-emulated.bin")
        extra["state_store"] = FramStore(fram_bus, gpio.fram_address, state_dir=Path(state_dir))
        parts_list.append((f"FRAM 0x{gpio.fram_address:02x} (bus {gpio.i2c_bus})", extra["state_store"]))
    if gpio.power_fail_pin is not None:
        pf = PowerFailInput(factory, gpio.power_fail_pin)
        extra["power_fail"] = pf
        parts_list.append(("power-fail input", pf))
    if world is not None:
        extra["world"], extra["fake_spi"], extra["emulation"] = world, fake_spi, emu.parts
        extra["overcurrent_a"] = {n: 0.8 * params.axis(n).stall_current_a for n in ("az", "el")}

        def poll(now_s: float) -> None:
            world.advance_to(now_s)
            for s in syncs:
                s()

        def close() -> None:
            for c in spi_chips.values():
                c.close()
            world.close()
            factory.close()

        # inputs follow the start position before the first read
        for s in syncs:
            s()
        return Hardware(backend="gpio", az=axes["az"], el=axes.get("el"), poll_hook=poll,
                        truth_hook=world.truth, close_hook=close, heartbeat=heartbeat, extra=extra)

    def close_real() -> None:
        for ax in axes.values():
            try:
                ax.motor.set_drive(0.0)
                if ax.brake is not None:
                    ax.brake.set_released(False)
            except Exception:  # pragma: no cover - closing must go on
                log.exception("gpio: could not make %s safe", ax)
        for b in buses.values():
            b.close()
        for c in [*spi_chips.values(), *pwm_parts]:
            c.close()
        factory.close()

    return Hardware(backend="gpio", az=axes["az"], el=axes.get("el"), close_hook=close_real,
                    heartbeat=heartbeat, extra=extra)


def _pot_sensor(caps: RotatorCaps, name: str, ax_caps: Any, cfg: Any, adc: Any) -> PotSensor:
    """The pot driver on an ADC channel; M and C from the config, else from the
    profile's simulated pot (its span over the law's full scale, its start)."""
    sp = physics_for(caps.name).axis(name).sensor if caps.name in PHYSICS else None
    law = sp.pot_law if sp is not None else "linear"
    full = 4096.0 if law == "ratiometric" else 1023.0
    m = cfg.pot_m if cfg.pot_m is not None else (sp.pot_span_deg / full if sp else ax_caps.span_deg / full)
    c = cfg.pot_c if cfg.pot_c is not None else (sp.pot_start_deg if sp else ax_caps.min_deg)
    return PotSensor(ax_caps.sensor, name, adc, law=cfg.pot_law or law, m=m, c=c)


def _feed_current_sense(phys: Any, cfg: Any, devices: dict[int, Any], fake_spi: dict[int, Any]) -> None:
    """Emulation: the bridge's current-sense output (magnitude only, clipped at the
    ADC's range) from the simulated motor current, on the configured ADC input."""
    from .emulate import FakeAds1115
    if cfg.adc == "mcp3008":
        dev = fake_spi[cfg.spi_device]
    else:
        addr = cfg.i2c_address or 0x48
        dev = devices.get(addr) or devices.setdefault(addr, FakeAds1115({}))
    dev.inputs[cfg.current_sense_channel] = lambda: abs(phys.current_a()) * cfg.current_sense_v_per_a


def _ads_reference(cfg: Any) -> int:
    """The ADS1115 input reading the pot supply (input 3 unless configured)."""
    return 3 if cfg.adc_reference_channel is None else cfg.adc_reference_channel


class PowerFailInput:
    """BIG-RAS style power-fail line: a supply monitor pulls the pin low when the mains
    goes (the Pi runs on on its hold-up capacitor for a moment). On that falling edge
    ``on_fail`` runs at once, from the pin's callback thread: the app stops the motors,
    engages the brakes, latches a ``power_fail`` fault and saves the state there
    (:meth:`urc.service.rotator.Rotator.power_fail`), not at the next tick or save."""

    def __init__(self, factory: Any, pin: int):
        self.on_fail: Any = None
        self.events = 0
        self.input = PinIn(factory, pin, on_edge=self._edge)

    def supply_ok(self) -> bool:
        return self.input.read()

    def _edge(self, level: bool) -> None:
        if level:
            log.warning("power-fail input high again: supply back (the fault stays until cleared)")
            return
        self.events += 1
        log.warning("power-fail input went low: stopping the motors and saving the state now")
        if self.on_fail is not None:
            try:
                self.on_fail()
            except Exception:  # the callback thread must survive
                log.exception("power-fail handling failed")

    def identify(self) -> str:
        return f"{self.input.pin}: {'supply ok' if self.supply_ok() else 'POWER FAIL (low)'}"

    def emulate_power_fail(self) -> None:
        """Emulation: the supply monitor's output drops."""
        self.input.pin.drive_low()

    def emulate_power_back(self) -> None:
        self.input.pin.drive_high()


def _limit_sync(sw: LimitSwitchInput, sim_sw: Any) -> Any:
    pin = sw.pin.pin

    def sync() -> None:
        level = sim_sw.is_active() != sw.active_low
        if level != bool(pin.state):
            (pin.drive_high if level else pin.drive_low)()
            pin.clear_states()
    return sync


class _Emulation:
    """What the emulated sensors are fed from and where their parts are left: the world,
    per-axis views of it carrying the injected sensor faults, the sync hooks run before
    each tick's reads, the fake SPI chips, and each axis' emulated sensor part (tests)."""

    def __init__(self, world: Any, syncs: list, fake_spi: dict[int, Any], parts: dict[str, Any]):
        from .emulate import FaultedView
        self.world, self.syncs, self.fake_spi, self.parts = world, syncs, fake_spi, parts
        self.views = {n: FaultedView(world.axes[n], lambda n=n: world.faults()[n]) for n in ("az", "el")}

    def dead_chip(self, dev: Any, *axes: str) -> None:
        """``dev`` NACKs while a sensor_dead fault is on any of ``axes`` (its chip)."""
        def sync() -> None:
            dev.dead = any(self.views[a].dead() for a in axes)
        self.syncs.append(sync)


def _feed_sensor(name: str, kind: str, sensor: Any, devices: dict[int, Any], cfg: Any, emu: _Emulation) -> None:
    """Emulation: connect the simulator to the pins / chip registers the sensor reads
    (``devices``: the fake I2C chips answering where the sensor's chip sits, by address)."""
    import random

    from ..sim.sensors import SimAccelerometer, SimAs5600, SimMagnetometer, SimPotAdc, SimQuadratureCounter
    from .emulate import FakeAds1115, FakeAs5600, FakeLsm303agr, FakeLsm303d, PulseDriver, QuadDriver, tilted

    world, syncs = emu.world, emu.syncs
    phys = emu.views[name]
    p = world.params.axis(name).sensor
    caps = world.caps.axis(name).sensor
    rng = random.Random(f"urc-emu:{world.seed}:{name}")
    part = (phys, p, rng, True)
    if kind == "encoder":
        cpd = round(1.0 / caps.resolution_deg)
        sim = SimQuadratureCounter(*part, counts_per_deg=cpd)
        counter = sensor.counter
        index = None
        if counter.z is not None and cfg.encoder_index_deg is not None:
            # the Z pulse: one quadrature state wide, at the configured angle and every
            # period after it, on the shaft's absolute count
            c0 = sim.absolute_count() - sim.count()
            idx0 = math.floor(cfg.encoder_index_deg * cpd + 1e-9) - c0
            period = round(cfg.encoder_index_period_deg * cpd)

            def index(pos: int) -> bool:
                return (pos - idx0) % period == 0
        d: Any = QuadDriver(counter.a, counter.b, sim.count, z=counter.z, index=index)
        syncs.append(d.sync)
        emu.parts[name] = d
        # the encoder starts referenced to the true angle, as on a fresh sim rotator
        sensor.set_reference_deg(phys.sensor_side_deg())
    elif kind == "pulse":
        d = PulseDriver(sensor.counter.pin, lambda: phys.pulse_edges)
        syncs.append(d.sync)
        emu.parts[name] = d
        sensor.set_reference_deg(phys.sensor_side_deg())
    elif kind == "as5600":
        chip = sensor.part
        dev = devices[chip.address] = FakeAs5600(SimAs5600(*part).read_raw_angle)
        emu.parts[name] = dev
        emu.dead_chip(dev, name)
    elif kind == "magnetometer":
        chip = sensor.accel.chip if hasattr(sensor, "accel") and sensor.accel is not None else sensor.mag.chip
        if chip.address in devices:
            emu.parts[name] = devices[chip.address]
            return
        az_view, el_view = emu.views["az"], emu.views["el"]
        az_p = world.params.axis("az").sensor
        mag = SimMagnetometer(az_view, az_p, random.Random(f"urc-emu:{world.seed}:mag"), True,
                              noise_deg=world.caps.az.sensor.noise_deg, board=world.board)
        acc = SimAccelerometer(el_view, world.params.axis("el").sensor,
                               random.Random(f"urc-emu:{world.seed}:acc"), True,
                               noise_deg=world.caps.el.sensor.noise_deg, board=world.board)
        dip = math.radians(az_p.dip_deg)
        h_gauss, z_gauss = 0.2, 0.2 * math.tan(dip)

        def field() -> tuple[float, float, float]:
            if world.board.held:      # off the boom: the board's own 3-D reading
                return tuple(c * h_gauss for c in mag.read_vector())  # type: ignore[return-value]
            bx, by, _ = mag.read_vector()
            # hard iron sits in the sensor: put it on after tilting the earth's field
            level = ((bx - az_p.hard_iron_x) * h_gauss, (by - az_p.hard_iron_y) * h_gauss, z_gauss)
            v = tilted(level, el_view.sensor_side_deg())
            return (v[0] + az_p.hard_iron_x * h_gauss, v[1] + az_p.hard_iron_y * h_gauss, v[2])

        if isinstance(chip, Lsm303agrChip):
            agr = FakeLsm303agr(field, acc.read_vector)
            devices[Lsm303agrChip.ACCEL], devices[Lsm303agrChip.MAG] = agr.accel, agr.mag
            emu.dead_chip(agr.accel, "az", "el")
            emu.dead_chip(agr.mag, "az", "el")
            emu.parts[name] = agr
        else:
            dev = devices[chip.address] = FakeLsm303d(field, acc.read_vector)
            emu.dead_chip(dev, "az", "el")      # one chip senses both axes
            emu.parts[name] = dev
        if name == "az":   # the shipped calibration, in this field's units (gauss)
            sensor.hard_iron_x, sensor.hard_iron_y = az_p.hard_iron_x * h_gauss, az_p.hard_iron_y * h_gauss
            sensor.declination_deg = az_p.declination_deg
    else:  # pot on an ADS1115 or an MCP3008
        adc = SimPotAdc(*part)
        ref_v = cfg.adc_reference_v
        ref_ch = _ads_reference(cfg)
        if cfg.adc == "mcp3008":
            dev = emu.fake_spi[cfg.spi_device]
            dev.vref_v = sensor.adc.chip.vref_v
            ref_ch = cfg.adc_reference_channel
        else:
            dev = devices.get(sensor.adc.chip.address) or FakeAds1115({})
            devices[sensor.adc.chip.address] = dev
        # sensor_dead: the wiper open, the input pulled to 0 V
        dev.inputs[cfg.adc_channel] = lambda: 0.0 if phys.dead() else ref_v * adc.read_counts() / 1024.0
        if ref_ch is not None:
            dev.inputs[ref_ch] = lambda: ref_v
        emu.parts[name] = dev
