"""The ``gpio`` backend: the seed machines' real parts on a Raspberry Pi.

Pins through gpiozero's pin factory (lgpio on a Pi: ``pip install '.[pi]'`` from the clone), motor PWM
on the PWM peripheral where a pin has it (:mod:`.pwm`), I2C through smbus2 (a TCA9548A
mux where chips share an address), an MCP3008 through spidev (:mod:`.buses`). With ``emulate`` the same drivers run on gpiozero MockFactory pins and a
fake SMBus fed by the physics simulator (:mod:`.emulate`), and status carries
``simulator_truth``.

Options (from ``[hardware.gpio]``, see :class:`urc.config.GpioSection`): ``gpio`` (the
section), ``emulate`` (bool) plus the simulator's options when emulated.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ...caps import RotatorCaps
from ...clock import Clock
from ...config.issues import error_from_issues
from ...errors import ConfigError
from ..drivers import LimitSwitchInput, RelayBrake, SenseCurrent
from ..drivers.bts7960_sense import Bts7960Sense
from ..drivers.motors import sense_v_per_a
from ..interfaces import AxisHardware, Hardware, brake_on, motor_off
from .buses import Buses
from .enable_sense import EnableSenseInput, emulated_feed
from .feed import (EmulatedBrake, EmulatedHeartbeat, EmulatedMotor, Emulation, feed_current_sense, feed_sensor,
                   forget_output_history, limit_sync)
from .i2c import AdcInput, Lsm303dChip
from .kinds import MOTORS, SENSORS, AxisWiring, motor_kind_issue, sensor_kind_issue
from .pinmux import pin_functions, routing_note
from .pins import PinIn, PinOut, release_inputs
from . import lgwd
from . import pwm as pwm_mod
from .pwm import HardwarePwm, detect_pwm_chip, make_pwm, pwm_advice, pwm_plan

log = logging.getLogger(__name__)

# before anything imports lgpio: a notify FIFO directory of this process's own (LG_WD)
lgwd.install()


@dataclass
class GpioParts:
    """What the gpio backend built besides the axes (``Hardware.gpio``)."""

    #: gpiozero's pin factory the pins were made on (emulated: a MockFactory)
    pin_factory: Any
    #: I2C bus number -> the open bus (smbus2.SMBus; emulated: FakeSMBus)
    i2c_buses: dict[int, Any]
    emulated: bool
    #: emulated only: SPI0 chip select -> the fake MCP3008 behind it
    fake_spi: dict[int, Any] = field(default_factory=dict)
    #: emulated only: axis -> the emulated sensor part the simulator feeds
    emulation: dict[str, Any] = field(default_factory=dict)
    #: "az.pwm" -> (pin, what drives it as built: "hardware PWM0 (pwmchip0, routed to PWM0)",
    #: "software PWM", ...) for `urc hw check`
    pwm_outputs: dict[str, tuple[int, str]] = field(default_factory=dict)


def build_gpio_hardware(caps: RotatorCaps, clock: Clock, state_dir: Path,
                        options: dict[str, Any]) -> Hardware:
    gpio = options.get("gpio")
    if gpio is None:
        raise ConfigError("backend \"gpio\" needs a [hardware.gpio] section with the pin map",
                          key="hardware.gpio", expected="[hardware.gpio.az] and [hardware.gpio.el]",
                          found=None)
    # every kind known before anything is claimed (the configuration check says the same)
    unknown = [i for name in caps.axes if getattr(gpio, name) is not None
               for i in (motor_kind_issue(name, getattr(gpio, name).motor),
                         sensor_kind_issue(name, caps.axis(name).sensor.kind)) if i is not None]
    if unknown:
        raise error_from_issues(unknown, "<config>")
    emulate = bool(options.get("emulate", gpio.emulate))
    world = None
    if emulate:
        from ..sim import make_world
        from .emulate import EmulatedFactory
        sim_opts = {k: v for k, v in options.items() if k not in ("gpio", "emulate", "bridge")}
        if gpio.motor_enable_timeout_s is not None and gpio.heartbeat_pin is not None:
            sim_opts["motor_enable_timeout_s"] = gpio.motor_enable_timeout_s   # the part, modelled
        world, params = make_world(caps, clock, state_dir, sim_opts)
        factory = EmulatedFactory(clock.now_s)
    else:
        try:
            from gpiozero import Device
            factory = Device.pin_factory   # set by the user (GPIOZERO_PIN_FACTORY) or a test
            if factory is None:
                from gpiozero.pins.lgpio import LGPIOFactory
                factory = LGPIOFactory()
        except Exception as exc:  # no lgpio / not a Pi
            raise ConfigError(f"gpio backend: no GPIO here ({exc}); install urc with its [pi] extra (pip install '.[pi]' in the clone) on a Raspberry "
                              "Pi, or run with --emulate", key="hardware.gpio.emulate",
                              expected="true off a Pi", found=False) from exc

    parts_list: list[tuple[str, Any]] = []
    buses = Buses(gpio, emulate, parts_list)
    sys_pwm = pwm_mod.SYS_PWM
    pwm_chip, pwm_table = (0, None) if emulate else detect_pwm_chip(gpio, sys_pwm)
    plan = pwm_plan(gpio, pwm_table)   # (a Pi 5's own table, whatever hardware_pwm says)
    functions = None if emulate else pin_functions(factory)
    pwm_parts: list[HardwarePwm] = []
    pwm_outputs: dict[str, tuple[int, str]] = {}
    for note in pwm_advice(gpio, pwm_table):
        log.warning("%s", note)
    syncs: list[Any] = []
    emu = Emulation(world, syncs, buses.fake_spi, {}) if world is not None else None
    lsm: dict[tuple[int, int | None, int], Lsm303dChip] = {}
    axes: dict[str, AxisHardware] = {}
    for name in caps.axes:  # a single-axis rotator wires no elevation parts at all
        ax_caps = caps.axis(name)
        cfg = getattr(gpio, name)
        pins = cfg.pins

        def out(key: str, pins: dict[str, int] = pins, cfg: Any = cfg) -> PinOut:
            return PinOut(factory, pins[key], active_low=key in cfg.active_low)

        def fault_in(key: str, pins: dict[str, int] = pins) -> PinIn | None:
            return PinIn(factory, pins[key], now_s=clock.now_s) if key in pins else None

        def pwm(key: str, name: str = name, pins: dict[str, int] = pins, pwm_hz: float = cfg.pwm_frequency_hz) -> Any:
            pin, ch = plan[f"{name}.{key}"]
            part = make_pwm(factory, pin, ch, pwm_hz, emulated=emulate, chip=pwm_chip, functions=functions,
                            sys_pwm=sys_pwm, heartbeat_pin=gpio.heartbeat_pin)
            if isinstance(part, HardwarePwm):
                pwm_parts.append(part)
                parts_list.append((f"{name} {key}", part))
                fn = functions.function(pin) if functions is not None else None
                pwm_outputs[f"{name}.{key}"] = (pin, f"hardware PWM{part.channel} (pwmchip{pwm_chip}, "
                                                f"{routing_note(fn, part.channel)})")
            elif emulate:
                pwm_outputs[f"{name}.{key}"] = (pin, ("software PWM" if ch is None else f"hardware PWM{ch}")
                                                + " on iron (emulated here)")
            else:
                fn = functions.function(pin) if functions is not None and ch is not None else None
                pwm_outputs[f"{name}.{key}"] = (pin, "software PWM" + (
                    f" (planned hardware PWM{ch}: {routing_note(fn, ch)})" if ch is not None else ""))
            return part

        sk = ax_caps.sensor.kind
        bus_n = cfg.i2c_bus if cfg.i2c_bus is not None else gpio.i2c_bus
        mux_ch = cfg.i2c_mux_channel
        on_bus = f"bus {bus_n}" + ("" if mux_ch is None else f" mux ch{mux_ch}")
        pot_vref = sk == "pot" and cfg.adc_reference_channel is None
        cs: SenseCurrent | Bts7960Sense | None = None
        if cfg.current_sense_channel is not None:
            cs_chip = buses.adc(name, cfg, bus_n, pot_vref=pot_vref)
            cs_in = AdcInput(cs_chip, cfg.current_sense_channel)
            cs = Bts7960Sense(cs_in, sense_v_per_a(cfg), clock.now_s) if cfg.motor == "bts7960" \
                else SenseCurrent(cs_in, sense_v_per_a(cfg))
            where = f"SPI0 CE{cfg.spi_device}" if cfg.adc == "mcp3008" else on_bus
            parts_list.append((f"{name} current sense {cfg.adc.upper()} ch{cfg.current_sense_channel} "
                               f"({where})", cs_chip))
        def pulses(key: str, pins: dict[str, int] = pins) -> Any:
            if emulate:
                from .emulate_stepdir import EmulatedTxQueue
                return EmulatedTxQueue(clock.now_s, sink=lambda *a: None)   # the chip is fed in later
            from .stepdir import LgpioStepPulses
            return LgpioStepPulses(factory, pins[key])

        wiring = AxisWiring(name=name, caps=caps, ax_caps=ax_caps, cfg=cfg, clock=clock, factory=factory,
                            buses=buses, bus_n=bus_n, mux_ch=mux_ch, on_bus=on_bus, parts=parts_list, lsm=lsm,
                            current=cs, out=out, fault_in=fault_in, pwm=pwm, pulses=pulses)
        kind = cfg.motor
        motor = MOTORS[kind].build(wiring)
        own_sensor = MOTORS[kind].own_sensor
        sensor = own_sensor(wiring, motor) if own_sensor is not None else SENSORS[sk].build(wiring, motor)
        brake = RelayBrake(name, out("brake"), clock, release_s=ax_caps.brake_release_s) \
            if "brake" in pins else None
        lims = [LimitSwitchInput(f"{name} {side}", PinIn(factory, pins[f"limit_{side}"],
                                                         debounce_s=cfg.limit_debounce_s, now_s=clock.now_s,
                                                         urgent_level=not cfg.limit_active_low),
                                 active_low=cfg.limit_active_low) if f"limit_{side}" in pins else None
                for side in ("min", "max")]
        if world is not None:
            assert emu is not None
            brake_hw: Any = EmulatedBrake(brake, world, name) if brake is not None else None
            devices = buses.fake_devices(bus_n, mux_ch)
            motor_hw: Any
            if own_sensor is not None:
                from .emulate_stepdir import wire_emulated_stepper
                if sensor.check is not None:
                    feed_sensor(name, "as5600", sensor.check, devices, cfg, emu)
                motor_hw = wire_emulated_stepper(name, motor, sensor, world, emu, cfg)
            else:
                motor_hw = EmulatedMotor(motor, kind, world, name, ax_caps.drive_levels or (1.0,))
                feed_sensor(name, sk, sensor, devices, cfg, emu)
            if cs is not None:
                is_part = feed_current_sense(world.axes[name], cfg, devices, buses.fake_spi, motor,
                                             world.clock.now_s)
                if is_part is not None:
                    emu.parts[f"{name} current sense"] = is_part
            for side, sw in zip(("min", "max"), lims):
                sim_sw = world.limits[name][0 if side == "min" else 1]
                if sw is not None and sim_sw is not None:
                    syncs.append(limit_sync(sw, sim_sw))
        else:
            motor_hw, brake_hw = motor, brake
        axes[name] = AxisHardware(motor=motor_hw, sensor=sensor, brake=brake_hw,
                                  limit_min=lims[0], limit_max=lims[1])

    heartbeat: Any = PinOut(factory, gpio.heartbeat_pin) if gpio.heartbeat_pin is not None else None
    if heartbeat is not None and world is not None and world.enable is not None:
        heartbeat = EmulatedHeartbeat(heartbeat, world.enable)
    sense = None
    if gpio.motor_enable_sense_pin is not None:
        sense = EnableSenseInput(factory, gpio.motor_enable_sense_pin, point=gpio.motor_enable_sense_point,
                                 active_low=gpio.motor_enable_sense_active_low)
        if world is not None and world.enable is not None:
            sense.feed = emulated_feed(sense, world.enable, clock.now_s)
            syncs.append(sense.feed)       # (each poll, and each read between polls)
            sense.feed()
        parts_list.append(("safety chain read-back", sense))
    gpio_parts = GpioParts(pin_factory=factory, i2c_buses=buses.i2c, emulated=emulate, pwm_outputs=pwm_outputs)
    hw = Hardware(backend="gpio", az=axes["az"], el=axes.get("el"), heartbeat=heartbeat, parts=parts_list,
                  motor_enable_timeout_s=gpio.motor_enable_timeout_s if gpio.heartbeat_pin is not None else None,
                  enable_sense=sense, gpio=gpio_parts)
    if gpio.fram_address is not None:
        from ..fram import FramStore
        fram_bus = buses.bus(gpio.i2c_bus)
        if emulate:
            from .emulate import FakeFram
            buses.fake_devices(gpio.i2c_bus, None)[gpio.fram_address] = FakeFram(
                path=Path(state_dir) / "fram-emulated.bin")
        hw.state_store = FramStore(fram_bus, gpio.fram_address, state_dir=Path(state_dir))
        parts_list.append((f"FRAM 0x{gpio.fram_address:02x} (bus {gpio.i2c_bus})", hw.state_store))
    if gpio.power_fail_pin is not None:
        hw.power_fail = PowerFailInput(factory, gpio.power_fail_pin)
        parts_list.append(("power-fail input", hw.power_fail))
    if world is not None:
        assert emu is not None
        hw.world, gpio_parts.fake_spi, gpio_parts.emulation = world, buses.fake_spi, emu.parts
        hw.overcurrent_a = {n: 0.8 * params.axis(n).stall_current_a for n in ("az", "el")}
        syncs.append(forget_output_history(factory))

        def poll(now_s: float) -> None:
            with world.lock:   # (the chips see one state of the iron: see SimWorld.lock)
                world.advance_to(now_s)
                for s in syncs:
                    s()

        def truth() -> dict[str, Any]:
            out = world.truth()
            if world.enable is not None:
                out["motor_enable"] = world.enable.truth()
            return out

        def close() -> None:
            buses.close()
            world.close()
            release_inputs(factory)    # outputs stay driven at their safe level

        # inputs follow the start position before the first read
        for s in syncs:
            s()
        hw.poll_hook, hw.truth_hook, hw.close_hook = poll, truth, close
        return hw

    def close_real() -> None:
        # (force_safe, not set_drive: a hung tick may hold a driver, and closing must not
        # wait for it)
        for ax in axes.values():
            try:
                motor_off(ax.motor)
                if ax.brake is not None:
                    brake_on(ax.brake)
            except Exception:  # pragma: no cover - closing must go on
                log.exception("gpio: could not make %s safe", ax)
        for ax in axes.values():
            # held safe for after the process, every later drive refused (a bridge whose
            # off needs PWM high brakes another way; software PWM stopped too)
            close = getattr(ax.motor, "close", None)
            if close is not None:
                try:
                    close()
                except Exception:  # pragma: no cover - closing must go on
                    log.exception("gpio: could not hold %s braked", ax)
        buses.close()
        for p in pwm_parts:
            p.close()                  # duty 0 and the channel disabled
        release_inputs(factory)        # outputs stay driven at their safe level, never floated

    hw.close_hook = close_real
    return hw


class PowerFailInput:
    """BIG-RAS style power-fail line: a supply monitor pulls the pin low when the mains
    goes (the Pi runs on its hold-up capacitor for a moment). On that falling edge
    ``on_fail`` runs at once on the pin's callback thread (the app: motors off, brakes
    on, a ``power_fail`` fault, :meth:`urc.rotator.rotator.Rotator.power_fail`), then
    ``save`` on a thread of its own (``saver``): the state write waits for the disk,
    and the callback thread also serves the encoder edges while the axes coast."""

    def __init__(self, factory: Any, pin: int):
        self.on_fail: Any = None
        self.save: Any = None
        self.saver: threading.Thread | None = None
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
        if self.save is not None:
            self.saver = threading.Thread(target=self._save, name="power-fail save", daemon=True)
            self.saver.start()

    def _save(self) -> None:
        try:
            if not self.save():
                log.error("power-fail: the state was not written in time")
        except Exception:
            log.exception("power-fail save failed")

    def identify(self) -> str:
        return f"{self.input.pin}: {'supply ok' if self.supply_ok() else 'POWER FAIL (low)'}"

    def emulate_power_fail(self) -> None:
        """Emulation: the supply monitor's output drops."""
        self.input.pin.drive_low()

    def emulate_power_back(self) -> None:
        self.input.pin.drive_high()
