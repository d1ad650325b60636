"""The gpio backend's kinds of motor driver and position sensor: ONE table each, read by
the builder (:func:`urc.hardware.gpio.build_gpio_hardware`: what to construct) and by
the configuration check (:mod:`.checks`: which pins a kind needs and allows). A new
driver is one entry here (and its emulation in :mod:`.feed`).

The motor kind is ``[hardware.gpio.<axis>] motor``; the sensor kind is the profile's
(``AxisCaps.sensor.kind``). A kind missing from its table is refused by both with the
same words (:func:`motor_kind_issue`, :func:`sensor_kind_issue`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Callable

from ...caps import AxisCaps, RotatorCaps, SensorCaps
from ...clock import Clock
from ...config.issues import Issue, one_of
from ..drivers.stepper import ENVELOPE_ACCEL_FACTOR, StepCountSensor, StepDirMotor
from ..drivers import (As5600Sensor, Bts7960Motor, CompassSensor, Lmd18200Motor, PotSensor, PwmDirMotor,
                       QuadratureEncoder, RelayMotor, SpidPulseSensor, TiltSensor, Vnh5019Motor)
from ..parts import CurrentSense
from ..sim.params import PHYSICS, physics_for
from .feed import ads_reference
from .i2c import Ads1115Channel, As5600Chip, Lsm303Accel, Lsm303agrChip, Lsm303dChip, Lsm303Mag
from .pins import PinIn, PinOut, PinPulseCounter, PinQuadrature
from .spi import Mcp3008Channel
from .stepdir import STEPDIR_CHIPS

#: an AS5600 checking a step count (the berkeley profile's sensor caps)
AS5600_CAPS = SensorCaps(kind="as5600", resolution_deg=360.0 / 4096, absolute=True, modulo_deg=360.0)


@dataclass
class AxisWiring:
    """What a kind's constructor may use to wire one axis (the builder fills it)."""

    name: str
    caps: RotatorCaps
    ax_caps: AxisCaps
    #: the axis' [hardware.gpio.<axis>] section (urc.config.GpioAxis)
    cfg: Any
    clock: Clock
    factory: Any
    buses: Any
    bus_n: int
    mux_ch: int | None
    #: where its I2C chip sits, in words ("bus 1 mux ch0")
    on_bus: str
    #: (label, part) for `urc hw check`
    parts: list[tuple[str, Any]]
    #: LSM303 chips already opened, by (bus, mux channel, address): one serves both axes
    lsm: dict[tuple[int, int | None, int], Any]
    #: the bridge's current sense, or None
    current: CurrentSense | None
    out: Callable[[str], PinOut]
    fault_in: Callable[[str], PinIn | None]
    pwm: Callable[[str], Any]
    #: a pin's step pulse queue (lgpio tx_pulse; emulated: :mod:`.emulate_stepdir`)
    pulses: Callable[[str], Any] | None = None

    @property
    def pins(self) -> dict[str, int]:
        return self.cfg.pins


@dataclass(frozen=True)
class MotorKind:
    #: pins it needs (besides brake / limit_min / limit_max)
    pins: tuple[str, ...]
    #: the profile drive it serves: "pwm" or "relay"
    drive: str
    build: Callable[[AxisWiring], Any]
    #: optional outputs
    optional: tuple[str, ...] = ()
    #: optional inputs: the bridge's fault output (active low)
    fault_inputs: tuple[str, ...] = ()
    #: outputs driven with PWM (the hardware PWM plan, :mod:`.pwm`)
    pwm_pins: tuple[str, ...] = ()
    #: has a current-sense output (current_sense_channel)
    current_sense: bool = False
    #: the motor is its own position sensor (a stepper's step count), whatever the
    #: profile's sensor: (wiring, motor) -> PositionSensor
    own_sensor: Callable[[AxisWiring, Any], Any] | None = None


@dataclass(frozen=True)
class SensorKind:
    build: Callable[[AxisWiring, Any], Any]   # (wiring, motor) -> PositionSensor
    pins: tuple[str, ...] = ()
    optional: tuple[str, ...] = ()


# ------------------------------------------------------------------ motors


def _vnh5019(w: AxisWiring) -> Any:
    return Vnh5019Motor(w.name, w.out("ina"), w.out("inb"), w.pwm("pwm"), current=w.current,
                        diag=w.fault_in("diag"))


def _lmd18200(w: AxisWiring) -> Any:
    return Lmd18200Motor(w.name, w.pwm("pwm"), w.out("dir"), w.out("bridge_brake"), current=w.current,
                         thermal_flag=w.fault_in("thermal_flag"))


def _bts7960(w: AxisWiring) -> Any:
    return Bts7960Motor(w.name, w.pwm("rpwm"), w.pwm("lpwm"), enable=w.out("en") if "en" in w.pins else None,
                        current=w.current)


def _pwm_dir(w: AxisWiring) -> Any:
    return PwmDirMotor(w.name, w.pwm("pwm"), w.out("dir"))


def _relay(w: AxisWiring) -> Any:
    return RelayMotor(w.name, w.out("cw"), w.out("ccw"), w.clock,
                      fast=w.out("fast") if "fast" in w.pins else None,
                      levels=w.ax_caps.drive_levels or (1.0,),
                      reverse_dead_time_s=w.cfg.relay_dead_time_s,
                      pulse_period_s=1.0 / w.cfg.relay_pulse_hz)


def _stepdir(w: AxisWiring) -> Any:
    cfg = w.cfg
    chip = STEPDIR_CHIPS[cfg.stepper_driver]
    levels = chip.levels_for(cfg.microsteps)
    for pin_name, level in zip(("ms1", "ms2", "ms3"), levels):
        if pin_name in w.pins:
            w.out(pin_name).write(bool(level))    # set once: the chip reads them at each step
    enable = None
    if "enable" in w.pins:
        low = chip.enable_active_low if cfg.enable_active_low is None else cfg.enable_active_low
        enable = PinOut(w.factory, w.pins["enable"], active_low=low)   # claimed off (outputs disabled)
    assert w.pulses is not None
    pulses = w.pulses("step")
    w.parts.append((f"{w.name} step pulses", pulses))
    return StepDirMotor(w.name, chip, pulses, w.out("dir"), enable, w.clock.now_s,
                        steps_per_deg=stepdir_steps_per_deg(w.ax_caps, cfg),
                        max_rate_deg_per_s=w.ax_caps.max_rate_deg_per_s,
                        max_accel_deg_per_s2=ENVELOPE_ACCEL_FACTOR * w.ax_caps.accel_deg_per_s2,
                        tick_s=1.0 / w.caps.loop_hz,
                        dir_reversed=cfg.dir_reversed, microsteps=cfg.microsteps)


def stepdir_steps_per_deg(ax_caps: AxisCaps, cfg: Any) -> float:
    return cfg.steps_per_deg if cfg.steps_per_deg is not None else 1.0 / ax_caps.sensor.resolution_deg


def _step_count(w: AxisWiring, motor: Any) -> Any:
    check = None
    if w.cfg.as5600_check:
        chip = As5600Chip(w.buses.chip_bus(w.bus_n, w.mux_ch), w.cfg.i2c_address or As5600Chip.ADDRESS,
                          f"{w.name} AS5600")
        w.parts.append((f"{w.name} AS5600 check ({w.on_bus})", chip))
        check = As5600Sensor(AS5600_CAPS, w.name, chip, zero_deg=w.cfg.zero_deg, reversed=w.cfg.as5600_reversed)
    caps = dataclasses.replace(w.ax_caps.sensor, kind="encoder", absolute=False, modulo_deg=None,
                               resolution_deg=1.0 / motor.steps_per_deg)
    return StepCountSensor(caps, w.name, motor, check=check, microsteps=w.cfg.microsteps,
                           backlash_deg=w.ax_caps.backlash_deg)


MOTORS: dict[str, MotorKind] = {
    "vnh5019": MotorKind(("ina", "inb", "pwm"), "pwm", _vnh5019, fault_inputs=("diag",), pwm_pins=("pwm",),
                         current_sense=True),
    "lmd18200": MotorKind(("pwm", "dir", "bridge_brake"), "pwm", _lmd18200, fault_inputs=("thermal_flag",),
                          pwm_pins=("pwm",), current_sense=True),
    "bts7960": MotorKind(("rpwm", "lpwm"), "pwm", _bts7960, optional=("en",), pwm_pins=("rpwm", "lpwm"),
                         current_sense=True),
    "pwm_dir": MotorKind(("pwm", "dir"), "pwm", _pwm_dir, pwm_pins=("pwm",)),
    "relay": MotorKind(("cw", "ccw"), "relay", _relay, optional=("fast",)),
    # A4988 / DRV8825 / TMC2208 / TMC2209 in step/dir mode: [hardware.gpio.<axis>] stepper_driver
    "stepdir": MotorKind(("step", "dir"), "pwm", _stepdir, optional=("enable", "ms1", "ms2", "ms3"),
                         own_sensor=_step_count),
}


# ------------------------------------------------------------------ sensors


def _encoder(w: AxisWiring, motor: Any) -> Any:
    cfg = w.cfg
    counter = PinQuadrature(w.factory, w.pins["enc_a"], w.pins["enc_b"], w.pins.get("enc_z"))
    enc_caps = w.ax_caps.sensor if cfg.encoder_counts_per_deg is None else \
        dataclasses.replace(w.ax_caps.sensor, resolution_deg=1.0 / cfg.encoder_counts_per_deg)
    w.parts.append((f"{w.name} encoder", counter))
    return QuadratureEncoder(enc_caps, w.name, counter, motor=motor, index_deg=cfg.encoder_index_deg,
                             index_period_deg=cfg.encoder_index_period_deg,
                             drift_counts=cfg.encoder_drift_counts, clock=w.clock)


def _pulse(w: AxisWiring, motor: Any) -> Any:
    counter = PinPulseCounter(w.factory, w.pins["pulse"], debounce_s=w.cfg.pulse_debounce_s)
    w.parts.append((f"{w.name} pulse counter", counter))
    return SpidPulseSensor(w.ax_caps.sensor, w.name, counter, motor)


def _as5600(w: AxisWiring, motor: Any) -> Any:
    chip = As5600Chip(w.buses.chip_bus(w.bus_n, w.mux_ch), w.cfg.i2c_address or As5600Chip.ADDRESS,
                      f"{w.name} AS5600")
    w.parts.append((f"{w.name} AS5600 ({w.on_bus})", chip))
    return As5600Sensor(w.ax_caps.sensor, w.name, chip, zero_deg=w.cfg.zero_deg, reversed=w.cfg.as5600_reversed)


def _magnetometer(w: AxisWiring, motor: Any) -> Any:
    cfg = w.cfg
    chip: Any
    if cfg.compass == "lsm303agr":
        key = (w.bus_n, w.mux_ch, Lsm303agrChip.MAG)
        chip = w.lsm.get(key) or w.lsm.setdefault(key, Lsm303agrChip(w.buses.chip_bus(w.bus_n, w.mux_ch)))
    else:
        key = (w.bus_n, w.mux_ch, cfg.i2c_address or Lsm303dChip.ADDRESS)
        chip = w.lsm.get(key) or w.lsm.setdefault(key, Lsm303dChip(w.buses.chip_bus(w.bus_n, w.mux_ch), key[2]))
    w.parts.append((f"{w.name} {cfg.compass.upper()} ({w.on_bus})", chip))
    if w.name == "az":
        return CompassSensor(w.ax_caps.sensor, w.name, Lsm303Mag(chip), Lsm303Accel(chip),
                             declination_deg=cfg.declination_deg)
    return TiltSensor(w.ax_caps.sensor, w.name, Lsm303Accel(chip))


def _pot(w: AxisWiring, motor: Any) -> Any:
    cfg = w.cfg
    chip = w.buses.adc(w.name, cfg, w.bus_n, pot_vref=cfg.adc_reference_channel is None)
    adc: Any
    if cfg.adc == "mcp3008":
        adc = Mcp3008Channel(chip, cfg.adc_channel, cfg.adc_reference_channel, reference_v=cfg.adc_reference_v)
        where = f"SPI0 CE{cfg.spi_device}"
    else:
        adc = Ads1115Channel(chip, cfg.adc_channel, ads_reference(cfg), reference_v=cfg.adc_reference_v)
        where = w.on_bus
    w.parts.append((f"{w.name} {cfg.adc.upper()} ch{cfg.adc_channel} ({where})", chip))
    return pot_sensor(w.caps, w.name, w.ax_caps, cfg, adc)


def pot_sensor(caps: RotatorCaps, name: str, ax_caps: Any, cfg: Any, adc: Any) -> PotSensor:
    """The pot driver on an ADC channel; M and C from the config, else from the
    profile's simulated pot (its span over the law's full scale, its start)."""
    sp = physics_for(caps.name).axis(name).sensor if caps.name in PHYSICS else None
    law = sp.pot_law if sp is not None else "linear"
    full = 4096.0 if law == "ratiometric" else 1023.0
    m = cfg.pot_m if cfg.pot_m is not None else (sp.pot_span_deg / full if sp else ax_caps.span_deg / full)
    c = cfg.pot_c if cfg.pot_c is not None else (sp.pot_start_deg if sp else ax_caps.min_deg)
    return PotSensor(ax_caps.sensor, name, adc, law=cfg.pot_law or law, m=m, c=c)


SENSORS: dict[str, SensorKind] = {
    "encoder": SensorKind(_encoder, pins=("enc_a", "enc_b"), optional=("enc_z",)),
    "pulse": SensorKind(_pulse, pins=("pulse",)),
    "as5600": SensorKind(_as5600),
    "magnetometer": SensorKind(_magnetometer),
    "pot": SensorKind(_pot),
}

#: pins any axis may have whatever its parts
AXIS_PINS = ("brake", "limit_min", "limit_max")


def motor_kind_issue(axis: str, kind: str) -> Issue | None:
    """None when ``kind`` is a motor driver the table knows; else why not."""
    return None if kind in MOTORS else one_of(f"hardware.gpio.{axis}.motor", list(MOTORS), kind)


def sensor_kind_issue(axis: str, kind: str) -> Issue | None:
    """None when the profile's sensor ``kind`` is one the gpio backend wires; else why not."""
    if kind in SENSORS:
        return None
    return (f"hardware.gpio.{axis}", "a profile whose sensor the gpio backend wires: one of "
            + ", ".join(SENSORS), kind, "the profile's sensor is read by another backend (bridge)")
