"""Emulated iron, wired: the gpio backend's real drivers connected to the physics
simulator when ``[hardware.gpio] emulate`` is on. Motor and brake outputs are read back
from the mock pins into the simulated axis; sensor pins and fake chips (:mod:`.emulate`)
are fed from the simulated axis, with the simulator's injected faults acting on them as
on iron; limit switch pins follow the simulated switches."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

from ...errors import HardwareError
from ..drivers import LimitSwitchInput, RelayBrake
# (at the top, not in emulated_bridge_open: an import statement there ran on every drive)
from ..drivers.motors import lmd18200_state, vnh5019_state
from .i2c import Lsm303agrChip


def emulated_motor_duty(kind: str, motor: Any, levels: tuple[float, ...]) -> float:
    """What the bridge / relays really put on the motor, read back from the pins (a
    bridge with every switch off reads 0 here: see :func:`emulated_bridge_open`)."""
    if kind == "vnh5019":
        # VNH5019_TRUTH_TABLE: one of INA/INB high drives; both equal brake
        d = int(motor.ina.read_back()) - int(motor.inb.read_back())
        return d * motor.pwm.read_back()
    if kind == "lmd18200":
        # LMD18200_TRUTH_TABLE, per level of the PWM input: BRAKE low drives for the
        # PWM's high time (braked through the high sides in its low time)
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


def emulated_bridge_open(kind: str, motor: Any) -> bool:
    """Whether the bridge has every switch off (the winding open: the motor coasts):
    the LMD18200 with BRAKE high and its PWM input low (LMD18200_TRUTH_TABLE), the
    VNH5019 with INA = INB = 0 and its PWM input low (ST VNH5019A-E §2.4: PWM low turns
    both low sides off). A PWM input partly high in those rows brakes in its high time:
    read as braked."""
    if kind == "vnh5019":
        return vnh5019_state(motor.ina.read_back(), motor.inb.read_back(), motor.pwm.read_back() > 0.0) == "coast"
    if kind != "lmd18200" or not motor.brake_out.read_back():
        return False
    return lmd18200_state(motor.pwm_out.read_back() > 0.0, motor.dir_out.read_back(), True) == "coast"


class RelayContacts:
    """The CW and CCW relays' contacts as iron has them: a contact opens ``RELEASE_S``
    after its coil is switched off (the relay's release time, 5-15 ms), so a coil
    energised sooner after the other one's went off closes both contacts at once — the
    phase capacitor shorted: :meth:`update` returns that as a fault."""

    RELEASE_S = 0.015

    def __init__(self, name: str):
        self.name = name
        self._on = {"CW": False, "CCW": False}
        self._off_at_s = {"CW": -math.inf, "CCW": -math.inf}

    def update(self, cw_on: bool, ccw_on: bool, now_s: float) -> str | None:
        for coil, on in (("CW", cw_on), ("CCW", ccw_on)):
            if self._on[coil] and not on:
                self._off_at_s[coil] = now_s
            self._on[coil] = on
        closed = [c for c in ("CW", "CCW") if self._on[c] or now_s - self._off_at_s[c] < self.RELEASE_S - 1e-12]
        if len(closed) < 2:
            return None
        return (f"{self.name} relays: CW and CCW contacts closed at once (a coil energised within "
                f"{self.RELEASE_S * 1e3:.0f} ms of the other's release): the phase capacitor is shorted")


class EmulatedMotor:
    """The driver on mock pins; after each drive the pins are decoded into the
    simulated motor (after the world has caught up with the present). Relay drives: both
    direction contacts closed at once (:class:`RelayContacts`) is a fault, not a drive
    of 0."""

    def __init__(self, driver: Any, kind: str, world: Any, axis: str, levels: tuple[float, ...]):
        self.driver, self.kind, self.world, self.axis, self.levels = driver, kind, world, axis, levels
        self.contacts = RelayContacts(axis) if kind == "relay" else None

    def set_drive(self, duty: float) -> None:
        self._drive(lambda: self.driver.set_drive(duty))

    def force_safe(self) -> None:
        """The driver's force_safe (``Hardware.drive_safe``), fed to the simulator."""
        self._drive(self.driver.force_safe)

    def _drive(self, write: Any) -> None:
        with self.world.lock:   # (one step of the iron: see SimWorld.lock)
            self.world.catch_up()
            write()
            phys = self.world.axes[self.axis]
            phys.bridge_open = emulated_bridge_open(self.kind, self.driver)
            if self.contacts is not None:
                shorted = self.contacts.update(self.driver.cw.read_back(), self.driver.ccw.read_back(),
                                               self.world.clock.now_s())
                if shorted is not None:
                    phys.set_command(0.0)
                    raise HardwareError(shorted)
            phys.set_command(emulated_motor_duty(self.kind, self.driver, self.levels))

    def read_current_a(self) -> float:
        # through the current-sense part when one is wired (0 without, as on iron)
        return self.driver.read_current_a()

    def __getattr__(self, name: str) -> Any:
        return getattr(self.__dict__["driver"], name)


class EmulatedBrake:
    def __init__(self, driver: RelayBrake, world: Any, axis: str):
        self.driver, self.world, self.axis = driver, world, axis

    def set_released(self, released: bool) -> None:
        self.driver.set_released(released)
        self._command()

    def force_safe(self) -> None:
        self.driver.force_safe()
        self._command()

    def _command(self) -> None:
        self.world.command_brake(self.axis, self.driver.coil.read_back())

    def is_released(self) -> bool:
        return self.driver.is_released()


class EmulatedHeartbeat:
    """The heartbeat pin wired to the safety chain's monostable (:mod:`..sim.safety`):
    the part sees the pin's level after each write, as the CD4538B's trigger input would."""

    def __init__(self, out: Any, enable: Any):
        self.out, self.enable = out, enable

    def write(self, value: bool) -> None:
        self.out.write(value)
        self.enable.heartbeat(self.out.read_back())

    def __getattr__(self, name: str) -> Any:
        return getattr(self.__dict__["out"], name)


def limit_sync(sw: LimitSwitchInput, sim_sw: Any) -> Any:
    pin = sw.pin.pin

    def sync() -> None:
        level = sim_sw.is_active() != sw.active_low
        if level != bool(pin.state):
            (pin.drive_high if level else pin.drive_low)()
            pin.clear_states()
    return sync


def forget_output_history(factory: Any) -> Any:
    """gpiozero's MockPin keeps every level change of a pin for tests to assert on; an
    output's is never read here, and the heartbeat toggles it every tick (30 000 entries,
    ~3.5 MB, per 10 min of ``urc run --emulate``). Forget it each tick, as the input feeds
    do for theirs."""
    def sync() -> None:
        for pin in factory.pins.values():
            # (the length first: MockPin's function is a property, looked up every tick)
            if len(pin.states) > 1 and pin.function == "output":
                pin.clear_states()
    return sync


class Emulation:
    """What the emulated sensors are fed from and where their parts are left: the world,
    per-axis views of it carrying the injected sensor faults, the sync hooks run before
    each tick's reads, the fake SPI chips, and each axis' emulated sensor part (tests)."""

    def __init__(self, world: Any, syncs: list, fake_spi: dict[int, Any], parts: dict[str, Any]):
        from .emulate import FaultedView
        self.world, self.syncs, self.fake_spi, self.parts = world, syncs, fake_spi, parts
        self.views = {n: FaultedView(world.axes[n], lambda n=n: world.axis_faults(n),
                                     lambda n=n: self._take_slow_read(n)) for n in ("az", "el")}

    def _take_slow_read(self, axis: str) -> float:
        """One of the reads a ``slow_read`` fault stalls (the simulator keeps the count)."""
        s = self.world.sensors[axis]
        if s.fault_slow_reads <= 0:
            return 0.0
        s.fault_slow_reads -= 1
        return s.fault_slow_s

    def dead_chip(self, dev: Any, *axes: str) -> None:
        """``dev`` NACKs while a sensor_dead fault is on any of ``axes`` (its chip)."""
        def sync() -> None:
            dev.dead = any(self.views[a].dead() for a in axes)
        self.syncs.append(sync)


def feed_sensor(name: str, kind: str, sensor: Any, devices: dict[int, Any], cfg: Any, emu: Emulation) -> None:
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
        cpd = cfg.encoder_counts_per_deg or round(1.0 / caps.resolution_deg)
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
        raw = SimAs5600(*part).read_raw_angle
        # as5600_reversed: the emulated chip's DIR is tied to VDD (it counts the other way)
        flip = cfg.as5600_reversed

        def raw_angle() -> int:
            phys.bus_wait()
            r = raw()
            return -r & 0x0FFF if flip else r
        dev = devices[chip.address] = FakeAs5600(raw_angle)
        emu.parts[name] = dev
        emu.dead_chip(dev, name)
    elif kind == "magnetometer":
        chip = sensor.accel.chip if hasattr(sensor, "accel") and sensor.accel is not None else sensor.mag.chip
        if chip.address in devices:
            emu.parts[name] = devices[chip.address]
            return
        az_view, el_view = emu.views["az"], emu.views["el"]
        az_p = world.params.axis("az").sensor
        if name == "az":
            # the configured declination is the emulated site's: the earth's field is
            # turned by it, and the compass keeps it (the simulator's own 12.5 deg
            # used to replace the configuration's value)
            az_p = replace(az_p, declination_deg=sensor.declination_deg)
        mag = SimMagnetometer(az_view, az_p, random.Random(f"urc-emu:{world.seed}:mag"), True,
                              noise_deg=world.caps.az.sensor.noise_deg, board=world.board)
        acc = SimAccelerometer(el_view, world.params.axis("el").sensor,
                               random.Random(f"urc-emu:{world.seed}:acc"), True,
                               noise_deg=world.caps.el.sensor.noise_deg, board=world.board)
        dip = math.radians(az_p.dip_deg)
        # the field dips below the horizon by dip_deg (north of the magnetic equator):
        # down, against the chip's Z
        h_gauss, z_gauss = 0.2, -0.2 * math.tan(dip)

        def gravity() -> tuple[float, float, float]:
            el_view.bus_wait()
            return acc.read_vector()

        def field() -> tuple[float, float, float]:
            az_view.bus_wait()
            if world.board.held:      # off the boom: the board's own 3-D reading
                return tuple(c * h_gauss for c in mag.read_vector())  # type: ignore[return-value]
            bx, by, _ = mag.read_vector()
            # hard iron sits in the sensor: put it on after tilting the earth's field
            level = ((bx - az_p.hard_iron_x) * h_gauss, (by - az_p.hard_iron_y) * h_gauss, z_gauss)
            v = tilted(level, el_view.sensor_side_deg())
            return (v[0] + az_p.hard_iron_x * h_gauss, v[1] + az_p.hard_iron_y * h_gauss, v[2])

        if isinstance(chip, Lsm303agrChip):
            agr = FakeLsm303agr(field, gravity)
            devices[Lsm303agrChip.ACCEL], devices[Lsm303agrChip.MAG] = agr.accel, agr.mag
            emu.dead_chip(agr.accel, "az", "el")
            emu.dead_chip(agr.mag, "az", "el")
            emu.parts[name] = agr
        else:
            dev = devices[chip.address] = FakeLsm303d(field, gravity)
            emu.dead_chip(dev, "az", "el")      # one chip senses both axes
            emu.parts[name] = dev
        if name == "az":   # the shipped calibration, in this field's units (gauss)
            sensor.hard_iron_x, sensor.hard_iron_y = az_p.hard_iron_x * h_gauss, az_p.hard_iron_y * h_gauss
    else:  # pot on an ADS1115 or an MCP3008
        adc = SimPotAdc(*part)
        ref_v = cfg.adc_reference_v
        ref_ch = ads_reference(cfg)
        if cfg.adc == "mcp3008":
            dev = emu.fake_spi[cfg.spi_device]
            dev.vref_v = sensor.adc.chip.vref_v
            ref_ch = cfg.adc_reference_channel
        else:
            dev = devices.get(sensor.adc.chip.address) or FakeAds1115({})
            devices[sensor.adc.chip.address] = dev
        def wiper_v() -> float:
            phys.bus_wait()
            return 0.0 if phys.dead() else ref_v * adc.read_counts() / 1024.0   # dead: the wiper open
        dev.inputs[cfg.adc_channel] = wiper_v
        if ref_ch is not None:
            dev.inputs[ref_ch] = lambda: ref_v
        emu.parts[name] = dev


def feed_current_sense(phys: Any, cfg: Any, devices: dict[int, Any], fake_spi: dict[int, Any],
                       motor: Any = None, now_s: Any = None) -> Any:
    """Emulation: the bridge's current-sense output (magnitude only, clipped at the
    ADC's range) from the simulated motor current, on the configured ADC input. A
    BTS7960's is its IS pins as the data sheet has them (:mod:`.emulate_bts7960`),
    returned so a test can set its grade or a fault."""
    from .emulate import FakeAds1115
    if cfg.adc == "mcp3008":
        dev = fake_spi[cfg.spi_device]
    else:
        addr = cfg.i2c_address or 0x48
        dev = devices.get(addr) or devices.setdefault(addr, FakeAds1115({}))
    if cfg.motor == "bts7960" and motor is not None:
        from .emulate_bts7960 import EmulatedBts7960Is
        part = EmulatedBts7960Is(motor.rpwm, motor.lpwm, phys.driven_side_current_a, now_s=now_s)
        dev.inputs[cfg.current_sense_channel] = part.volts
        return part
    from ..drivers.motors import sense_v_per_a
    v_per_a = sense_v_per_a(cfg)
    dev.inputs[cfg.current_sense_channel] = lambda: abs(phys.current_a()) * v_per_a
    return None


def ads_reference(cfg: Any) -> int:
    """The ADS1115 input reading the pot supply (input 3 unless configured)."""
    return 3 if cfg.adc_reference_channel is None else cfg.adc_reference_channel
