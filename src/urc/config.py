"""The urc configuration file: a small, strict TOML schema.

Every key is optional; ``load_config(None)`` gives the defaults, so urc runs with no file
at all. Anything wrong (a TOML syntax error, a wrong type, a value out of range, an
unknown key, a limit outside what the rotator profile can do) raises
:class:`urc.errors.ConfigError` whose message names the file, the dotted key, what was
expected and what was found::

    /etc/urc.toml: limits.az.max_deg: expected a number (degrees), found 'abc' (str)

Values are typed strictly: ``"1.5"`` (a string) is not a number and ``1`` is not ``true``;
integers are accepted where a float is expected.

Cross-checks that need the rotator profile (user limits inside the profile's range, park
inside the limits, control overrides within the profile's capabilities ...) run whenever a
:class:`Config` is built. The per-instance values here never go into the frozen caps
(DESIGN.md convention 4); use :meth:`Config.effective_limits`, :meth:`Config.park` and
:meth:`Config.effective_control` to combine the two.
"""

from __future__ import annotations

import difflib
import ipaddress
import math
import os
import re
import tomllib
import types
import typing
from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import Any, Literal, Union

import annotated_types
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from .caps import AxisCaps, RotatorCaps
from .control.geometry import KeepOut
from .errors import ConfigError
from .mqtt.config import MqttSection, mqtt_issues
from .profiles import DEFAULT_PROFILE, PROFILES

__all__ = [
    "EXAMPLE_CONFIG", "ApiSection", "AxisControl", "AxisLimits", "Config", "ControlSection",
    "FaultsSection", "HardwareSection", "KeepoutZone", "LimitsSection", "OffsetsSection",
    "PanelSection", "ParkSection", "RotatorSection", "BridgeSection", "ScheduleEntry", "ServeEntry", "StationSection", "TrackingSection", "SimSection", "StateSection", "load_config",
    "loads_config", "parse_host_port",
]

#: the backends this module knows about when the hardware package cannot be asked.
_BUILTIN_BACKENDS = ("sim", "bridge", "gpio")
#: elevation range any keep-out zone must lie in (degrees; > 90 is "over the top").
_KEEPOUT_EL_RANGE = (-90.0, 180.0)

_MODEL_CONFIG = ConfigDict(strict=True, frozen=True, extra="forbid", validate_default=False)


def _num(default: Any = None, *, ge: float | None = None, le: float | None = None,
         gt: float | None = None, lt: float | None = None, description: str = "") -> Any:
    """A finite number field (ints accepted)."""
    return Field(default, ge=ge, le=le, gt=gt, lt=lt, allow_inf_nan=False,
                 description=description)


# --------------------------------------------------------------------------- schema


class _Section(BaseModel):
    model_config = _MODEL_CONFIG


class RotatorSection(_Section):
    #: one of :data:`urc.profiles.PROFILES`
    profile: str = DEFAULT_PROFILE
    loop_hz: float = _num(50.0, ge=1.0, le=1000.0, description="control loop rate")
    #: flying "over the top" (elevation past 90, azimuth + 180) on rotators whose
    #: elevation reaches 180: "auto" = the pass planner decides per pass wherever the
    #: profile can flip (a goto to a sky direction stays unflipped, so protocol clients
    #: read back what they set); true = that, and gotos take the flipped pose when it
    #: is faster (an error on a profile that cannot flip); false = never (the user
    #: forbids it: a feed or cable that must not go over the top). An explicit pose
    #: (elevation past 90) is flown whatever the setting. See :meth:`flip_enabled`.
    flip: bool | Literal["auto"] = "auto"
    #: false = a single-axis rotator, azimuth only (the Tartu TRC turntable, BIG-RAS
    #: with "Elevation: OFF", an HF beam): no elevation parts, limits, park or offset;
    #: protocols answer elevation queries as the original az-only units do.
    elevation: bool = True
    #: BIG-RAS "Max. elevation": 90, or 180 (elevation 0..180: past 90 is over the top,
    #: azimuth + 180, and passes may be flown so); None = the profile's range
    max_el_deg: float | None = _num(None)
    #: BIG-RAS "Pulse/degree": pulses the rotator's pulse sensor gives per degree (both
    #: axes; profiles with pulse feedback only); None = the profile's
    pulses_per_deg: int | None = Field(None, ge=1, le=100)
    #: BIG-RAS "Zero point": where the rotator's mechanical zero points, "north" or
    #: "south". South: the mechanical frame (limits, park, the pulse count) starts at
    #: south, compass azimuth = mechanical + 180 (+ offsets.az_deg). Protocols, status
    #: and the page always speak compass azimuth (north = 0), as the BIG-RAS does.
    zero: Literal["north", "south"] = "north"

    def flip_enabled(self, caps: RotatorCaps) -> bool:
        """May the pass planner fly passes over the top on this profile?"""
        return caps.can_flip if self.flip == "auto" else bool(self.flip)

    def variant(self, caps: RotatorCaps) -> RotatorCaps:
        """The profile's caps as this section changes them (a new caps value): max
        elevation, pulses per degree, single-axis."""
        if self.max_el_deg is not None:
            caps = replace(caps, el=replace(caps.el, max_deg=float(self.max_el_deg),
                                            park_deg=min(caps.el.park_deg, float(self.max_el_deg))))
        if self.pulses_per_deg is not None:
            step_deg = 1.0 / self.pulses_per_deg
            caps = replace(caps, **{n: replace(caps.axis(n), sensor=replace(caps.axis(n).sensor, resolution_deg=step_deg))
                                    for n in ("az", "el") if caps.axis(n).sensor.kind == "pulse"})
        return caps if self.elevation else caps.single_axis()

    @property
    def zero_offset_deg(self) -> float:
        """What the zero point adds to the mechanical azimuth to make it a compass one."""
        return 180.0 if self.zero == "south" else 0.0


class SimSection(_Section):
    seed: int = 1
    wind: bool = True
    #: where the simulated antenna starts; None = at the park position.
    start_az_deg: float | None = _num(None)
    start_el_deg: float | None = _num(None)
    #: model the external safety chain (docs/hardware.md): motor power only while the
    #: heartbeat's rising edges come at most this far apart; None = not modelled
    motor_enable_timeout_s: float | None = _num(None, gt=0.0, le=10.0)


class BridgeSection(_Section):
    """``backend = "bridge"``: drive a controller the station already owns, as a client."""

    #: gs232a, gs232b, easycomm2, easycomm3, rot2prog, rot1prog, md01 or rotctld
    protocol: str
    #: a serial device, e.g. "/dev/ttyUSB0" (exactly one of serial and tcp)
    serial: str | None = Field(None, min_length=1)
    #: None = the protocol's usual rate (GS-232 9600, Rot2Prog 600, Rot1Prog 1200 ...)
    baud: int | None = Field(None, ge=50, le=4_000_000)
    #: "host:port": a rotctld, or an Ethernet/WiFi serial adapter
    tcp: str | None = Field(None, min_length=1)
    #: an answer missing this long is a failure; None = the protocol's (Hamlib's) timeout
    timeout_s: float | None = _num(None, gt=0.0, le=30.0)
    #: poll the position no faster than this; 0 = as fast as the link allows
    poll_interval_s: float = _num(0.0, ge=0.0, le=10.0)
    #: bad or missing answers in a row that count as a lost link
    max_failures: int = Field(3, ge=1, le=100)
    #: reconnect attempts (back-off up to 5 s) before giving up until restart
    reconnect_attempts: int = Field(30, ge=0, le=100_000)
    #: for controllers that ignore a new target while moving: stop first
    stop_before_set: bool = False


class GpioAxis(_Section):
    """One axis' parts on the Pi (``[hardware.gpio.az]``); pins are BCM numbers.

    The sensor comes from the profile (encoder, pulse, pot, as5600, magnetometer); the
    pins each motor driver needs: vnh5019 ina inb pwm; lmd18200 pwm dir bridge_brake;
    bts7960 rpwm lpwm; pwm_dir pwm dir; relay cw ccw [fast]. Sensors: encoder enc_a
    enc_b [enc_z]; pulse pulse. Also brake (the brake relay) and limit_min / limit_max.
    """

    motor: str
    pins: dict[str, int] = {}
    pwm_frequency_hz: float = _num(1000.0, gt=0.0, le=100000.0)
    #: I2C bus for this axis' chip (None = [hardware.gpio] i2c_bus) and its address
    i2c_bus: int | None = Field(None, ge=0, le=31)
    i2c_address: int | None = Field(None, ge=0x03, le=0x77)
    #: the chip sits on this channel of the bus's TCA9548A mux (None = on the bus itself)
    i2c_mux_channel: int | None = Field(None, ge=0, le=7)
    #: the pot's ADC: ads1115 (I2C, i2c_address or 0x48) or mcp3008 (SPI0, chip select
    #: CE<spi_device>: GPIO8 or GPIO7; SCLK 11, MOSI 10, MISO 9)
    adc: str = "ads1115"
    spi_device: int = Field(0, ge=0, le=1)
    #: the motor bridge's current-sense output (VNH5019 CS, BTS7960 IS, LMD18200 sense
    #: resistor) on this input of the axis' ADC (``adc``): the overcurrent fault and the
    #: stall / stuck-sensor verdict then see the motor current; None = not wired
    current_sense_channel: int | None = Field(None, ge=-100, le=100)
    #: None = the bridge's own figure (VNH5019 carrier 0.14, IBT-2/BTS7960 0.118); the
    #: LMD18200 needs it (377 uA/A into your resistor)
    current_sense_v_per_a: float | None = _num(None, gt=0.0, le=10.0)
    #: output pins (by name: ina, cw, brake, ...) whose load is on when the pin is LOW
    #: (most relay modules); urc then drives them high to keep them off
    active_low: list[str] = []
    #: the pot's input and the input wired to the pot supply (None: ADS1115 input 3; on
    #: an MCP3008 its VREF is the pot supply, so N is read as the G4JNT PIC reads it)
    adc_channel: int = Field(0, ge=-100, le=100)
    adc_reference_channel: int | None = Field(None, ge=-100, le=100)
    adc_reference_v: float = _num(3.3, gt=0.0, le=4.096)
    pot_law: str | None = None
    pot_m: float | None = _num(None)
    pot_c: float | None = _num(None)
    zero_deg: float = _num(0.0)
    #: the compass chip of a magnetometer profile: lsm303d (0x1D) or lsm303agr (0x19 + 0x1E)
    compass: str = "lsm303d"
    declination_deg: float = _num(0.0, ge=-180.0, le=180.0)
    #: reversal wait with both relays off; >= 0.05 s: a relay opens 5-15 ms after its coil
    #: goes off, so less can close CW and CCW at once (motors.RELAY_MIN_DEAD_TIME_S)
    relay_dead_time_s: float = _num(0.5, ge=0.05, le=10.0)
    #: False (default): normally-closed limit switches to ground, the pin pulled up: it
    #: reads high (active) when the switch opens OR its wire breaks. True: normally-open
    #: switches closing to ground (a broken wire never shows a limit)
    limit_active_low: bool = False
    #: a limit input's level counts once it has held this long (contact bounce, pickup)
    limit_debounce_s: float = _num(0.02, ge=0.0, le=1.0)
    #: a pulse (SPID reed) closer than this to the last one is bounce, not a pulse
    pulse_debounce_s: float = _num(0.005, ge=0.0, le=1.0)
    #: an encoder's x4 counts per axis degree; None = the profile's (1 / resolution)
    encoder_counts_per_deg: float | None = _num(None, gt=0.0, le=100000.0)
    #: relay motor without a fast relay: the slow speed pulses the direction relay at
    #: this rate (the G4JNT controller's 2 Hz)
    relay_pulse_hz: float = _num(2.0, gt=0.0, le=20.0)
    #: the encoder's index (Z, pin enc_z): the axis angle of an index pulse (found at
    #: commissioning) and the axis degrees between two (360 / turns of the encoder shaft
    #: per axis turn); each pulse re-references the count. None = Z not used
    encoder_index_deg: float | None = _num(None)
    encoder_index_period_deg: float = _num(360.0, gt=0.0, le=360.0)
    #: counts an encoder may move with its motor off before that is a fault; None = no check
    encoder_drift_counts: int | None = Field(20, ge=1)


class GpioSection(_Section):
    """``backend = "gpio"``: parts on a Raspberry Pi's pins and buses."""

    #: run the real drivers on pins and chips emulated from the simulator
    emulate: bool = False
    i2c_bus: int = Field(1, ge=0, le=31)
    #: motor PWM on the PWM peripheral where a pin has it: "2chan" (Pi 3/4/Zero 2 W: PWM0 on
    #: GPIO12 or 18, PWM1 on 13 or 19), "4chan" (Pi 5: 12, 13, 18, 19), "off" (all software)
    hardware_pwm: str = "2chan"
    #: the sysfs pwmchip of the PWM peripheral; None = found at start (Pi 4: 0; Pi 5:
    #: 2 before kernel 6.12, 0 after; a 4-channel chip means a Pi 5: its own pin table)
    pwm_chip: int | None = Field(None, ge=0, le=31)
    #: the TCA9548A's address (A2..A0 straps) on any bus an axis uses i2c_mux_channel on
    i2c_mux_address: int = Field(0x70, ge=0x70, le=0x77)
    heartbeat_pin: int | None = Field(None, ge=0, le=27)
    #: the external safety chain on heartbeat_pin (docs/hardware.md "Safety chain"): its
    #: monostable's timeout. Emulated, the part is modelled with it; on iron it is what
    #: `urc hw check` states. None = no such part wired
    motor_enable_timeout_s: float | None = _num(None, gt=0.0, le=10.0)
    power_fail_pin: int | None = Field(None, ge=0, le=27)
    #: output pins fitted with an external pull-down (GPIO0-8 are pulled up from power-on
    #: until urc claims them: a motor, relay or brake output there needs one)
    pulled_down: list[int] = []
    #: keep the state in an I2C FRAM (MB85RC256V class, on i2c_bus) instead of a file
    fram_address: int | None = Field(None, ge=0x03, le=0x77)
    az: GpioAxis | None = None
    el: GpioAxis | None = None


class HardwareSection(_Section):
    backend: str = "sim"
    sim: SimSection = SimSection()
    bridge: BridgeSection | None = None
    gpio: GpioSection | None = None


class AxisLimits(_Section):
    """User soft limits narrowing the profile's range; None = the profile's."""

    min_deg: float | None = _num(None)
    max_deg: float | None = _num(None)


class LimitsSection(_Section):
    az: AxisLimits = AxisLimits()
    el: AxisLimits = AxisLimits()


class OffsetsSection(_Section):
    #: added to what the sensor says (mount misalignment).
    az_deg: float = _num(0.0, ge=-180.0, le=180.0)
    el_deg: float = _num(0.0, ge=-90.0, le=90.0)


class ParkSection(_Section):
    #: None = the profile's park position.
    az_deg: float | None = _num(None)
    el_deg: float | None = _num(None)
    #: auto-park after this many seconds idle; 0 = never.
    idle_park_s: float = _num(0.0, ge=0.0)

    def __call__(self, caps: RotatorCaps) -> tuple[float, float]:
        """``(az_deg, el_deg)`` to park at: these values, else the profile's park."""
        az = caps.az.park_deg if self.az_deg is None else self.az_deg
        el = caps.el.park_deg if self.el_deg is None else self.el_deg
        return float(az), float(el)


class KeepoutZone(_Section):
    """A region the antenna must never pass through.

    The azimuth sector is in compass degrees and may wrap: ``az_min_deg = 350``,
    ``az_max_deg = 10`` is the 20 degree sector across north. Values in the profile's
    wrap range (e.g. 370) mean the same compass direction (10).
    """

    name: str = ""
    az_min_deg: float = _num(...)
    az_max_deg: float = _num(...)
    el_min_deg: float = _num(...)
    el_max_deg: float = _num(...)

    def keep_out(self, index: int) -> KeepOut:
        """The zone as the controller's geometry uses it (one containment rule)."""
        return KeepOut(self.label(index), self.az_min_deg, self.az_max_deg, self.el_min_deg, self.el_max_deg)

    def label(self, index: int) -> str:
        return self.name or f"keepout[{index}]"


class AxisControl(_Section):
    """Per-axis control overrides; None = the profile's value."""

    tolerance_deg: float | None = _num(None, gt=0.0)
    restart_deg: float | None = _num(None, gt=0.0)
    max_rate_deg_per_s: float | None = _num(None, gt=0.0)
    #: the slowest speed at which the motor still turns reliably (BIG-RAS "Minimal
    #: turn"): motion starts from it and slows to it before stopping, and slow targets
    #: are followed at it in bursts
    min_rate_deg_per_s: float | None = _num(None, gt=0.0)
    accel_deg_per_s2: float | None = _num(None, gt=0.0)
    kp_per_s: float = _num(6.0, ge=0.0)
    ki_per_s2: float = _num(1.0, ge=0.0)
    overshoot_deg: float | None = _num(None, ge=0.0)
    creep_lead_deg: float | None = _num(None, ge=0.0)
    backlash_deg: float | None = _num(None, ge=0.0, le=20.0)


class ControlSection(_Section):
    az: AxisControl = AxisControl()
    el: AxisControl = AxisControl()


class FaultsSection(_Section):
    stall_timeout_s: float = _num(1.5, gt=0.0)
    #: moved this far without a command, or the wrong way -> fault.
    runaway_deg: float = _num(3.0, gt=0.0)
    sensor_jump_deg: float = _num(5.0, gt=0.0)
    #: 0 = the backend's default.
    overcurrent_a: float = _num(0.0, ge=0.0)
    #: control-loop deadline: a tick this late stops the motors, held off until the loop
    #: has been on time for watchdog_recover_s
    watchdog_s: float = _num(0.5, gt=0.0)
    watchdog_recover_s: float = _num(1.0, ge=0.0, le=60.0)
    #: this many stalls within watchdog_latch_window_s latch a watchdog fault (cleared
    #: only by an operator); fewer are ridden out
    watchdog_latch_stalls: int = Field(3, ge=1, le=1000)
    watchdog_latch_window_s: float = _num(600.0, gt=0.0, le=86400.0)
    #: urc run's I/O process takes the outputs over from a control process that is dead
    #: or has published no status for this long (frozen): it kills it, drives every
    #: output safe itself and stops the service (0: never; the control process's own
    #: watch and an external safety chain remain)
    control_takeover_s: float = _num(1.0, ge=0.0, le=60.0)


class ApiSection(_Section):
    host: str = Field("127.0.0.1", min_length=1)
    port: int = Field(8080, ge=0, le=65535)
    token: str = ""

    @property
    def is_loopback(self) -> bool:
        host = self.host.strip().strip("[]").lower()
        if host == "localhost" or host.endswith(".localhost"):
            return True
        try:
            return ipaddress.ip_address(host).is_loopback
        except ValueError:
            return False

    @property
    def control_requires_token(self) -> bool:
        """Control over the API needs ``token`` because the API is reachable from outside.

        With an empty token that means remote control is refused (reading still works).
        """
        return not self.is_loopback


class StateSection(_Section):
    #: "" = the per-user data directory; the --state-dir option overrides.
    dir: str = ""
    #: the longest an axis moves on one state record: a new one is written before the
    #: axis can leave what the last one promised (motion, plus the same again at top
    #: speed). A crash mid-move restarts uncertain by about that much; shorter = more
    #: writes (SD card wear). Bounded: a record promising minutes ahead is no record.
    save_interval_s: float = _num(1.0, gt=0.0, le=10.0)

    def resolve_dir(self, override: str | os.PathLike[str] | None = None) -> Path:
        """The state directory: ``override`` (--state-dir), else ``dir``, else per-user."""
        if override is not None and str(override) != "":
            return Path(override).expanduser()
        if self.dir:
            return Path(self.dir).expanduser()
        import platformdirs

        return Path(platformdirs.user_data_dir("urc"))


class StationSection(_Section):
    """Where the antenna stands. Needed for tracking; None = not configured."""

    lat_deg: float | None = _num(None, ge=-90.0, le=90.0)
    lon_deg: float | None = _num(None, ge=-180.0, le=360.0)
    alt_m: float = _num(0.0, ge=-500.0, le=100_000.0)
    name: str = ""
    #: a GPS receiver's NMEA stream: a device path or "tcp:HOST:PORT"; its fix sets the
    #: station when lat/lon are not given, and tells whether the system clock is right
    gps: str = ""
    gps_baud: int = Field(9600, ge=50, le=4_000_000)

    @property
    def configured(self) -> bool:
        return self.lat_deg is not None and self.lon_deg is not None


class ScheduleEntry(_Section):
    #: satellite name (unique prefix, any case) or NORAD id as text
    sat: str = Field(min_length=1)
    #: larger wins when two passes compete for the antenna
    priority: int = 0


class TrackingSection(_Section):
    #: where element sets are kept; "" = <per-user data dir>/catalog
    catalog_dir: str = ""
    #: passes below this maximum elevation are ignored; tracking starts at this elevation
    min_el_deg: float = _num(0.0, ge=-5.0, le=90.0)
    #: park when a pass ends
    park_after_pass: bool = True
    #: CelesTrak groups `urc tle update` downloads
    groups: tuple[str, ...] = Field(("stations", "amateur", "cubesat", "weather"), strict=False)
    #: satellites to track automatically, pass by pass, by priority
    schedule: tuple[ScheduleEntry, ...] = Field((), strict=False)

    def resolve_catalog_dir(self) -> Path:
        if self.catalog_dir:
            return Path(self.catalog_dir).expanduser()
        import platformdirs

        return Path(platformdirs.user_data_dir("urc")) / "catalog"


class ServeEntry(_Section):
    """One protocol served on one transport: exactly one of tcp, pty, serial, udp."""

    #: one of :data:`urc.protocols.PROTOCOLS`
    protocol: str
    #: "host:port" to listen on
    tcp: str | None = None
    #: path of a stable symlink to a pseudo-terminal urc creates (``rotctl -r PATH``)
    pty: str | None = None
    #: a real serial device, e.g. "/dev/ttyUSB0"
    serial: str | None = None
    #: serial rate; None = the protocol's own default (Tartu 115200, GS-232 9600 ...)
    baud: int | None = Field(None, ge=50, le=4_000_000)
    #: "host:port" to listen on for datagrams (PstRotator)
    udp: str | None = None
    #: UDP replies go to the sender's host on this port (PstRotator listens on 12001)
    reply_port: int = Field(12001, ge=1, le=65535)
    #: protocol-specific options, e.g. { hamlib_version = "4.6" }
    options: dict[str, str | int | float | bool] = Field(default_factory=dict, strict=False)

    @property
    def transport(self) -> tuple[str, str]:
        for kind in ("tcp", "pty", "serial", "udp"):
            value = getattr(self, kind)
            if value is not None:
                return kind, value
        raise ValueError("no transport")

    def describe(self) -> str:
        kind, where = self.transport
        return f"{self.protocol} on {kind} {where}"


#: what urc serves when the configuration has no [[serve]] entries at all
DEFAULT_SERVE = (ServeEntry(protocol="rotctld", tcp="127.0.0.1:4533"),)


class PanelButtons(_Section):
    """GPIO (BCM) numbers of the front-panel push-buttons, wired to ground (pull-up);
    omitted = not fitted."""

    cw: int | None = Field(None, ge=0, le=53)
    ccw: int | None = Field(None, ge=0, le=53)
    up: int | None = Field(None, ge=0, le=53)
    down: int | None = Field(None, ge=0, le=53)
    stop: int | None = Field(None, ge=0, le=53)
    park: int | None = Field(None, ge=0, le=53)
    #: held with a turn button: jog slowly (G4JNT); stores Z in its zero setting
    slow: int | None = Field(None, ge=0, le=53)


class PanelLeds(_Section):
    """GPIO (BCM) numbers of the status LEDs (Tartu: one per direction, one for errors)."""

    cw: int | None = Field(None, ge=0, le=53)
    ccw: int | None = Field(None, ge=0, le=53)
    up: int | None = Field(None, ge=0, le=53)
    down: int | None = Field(None, ge=0, le=53)
    #: error LED: blink codes (see urc.frontpanel.indicators)
    fault: int | None = Field(None, ge=0, le=53)


class PanelLcd(_Section):
    """An HD44780 character LCD on a PCF8574 I2C backpack."""

    bus: int = Field(1, ge=0, le=31)
    address: int = Field(0x27, ge=0x03, le=0x77)
    cols: int = Field(20, ge=16, le=20)
    rows: int = Field(2, ge=2, le=4)


class PanelOled(_Section):
    """An SSD1306 OLED on I2C (Berkeley-style boards)."""

    bus: int = Field(1, ge=0, le=31)
    address: int = Field(0x3C, ge=0x03, le=0x77)
    width: int = Field(128, ge=128, le=128)
    height: int = Field(64, ge=32, le=64)
    contrast: int = Field(0xCF, ge=0, le=255)


class PanelIr(_Section):
    """An IR receiver (kernel gpio-ir) read through the Linux input subsystem."""

    #: e.g. "/dev/input/by-path/platform-ir-receiver@12-event"
    device: str = Field(min_length=1)
    #: evdev key name -> action (cw ccw up down stop park slow); {} = the default map
    keys: dict[str, str] = Field(default_factory=dict, strict=False)


class PanelSection(_Section):
    """The local front panel: buttons, LEDs, beeper, display, IR remote."""

    enabled: bool = False
    #: how the buttons are wired (urc.frontpanel.controls.LAYOUTS): "labelled", each
    #: does its name; "big-ras", the BIG-RAS five-button row named by its two-axis
    #: functions, which changes with elevation off (the far left button turns left)
    layout: Literal["labelled", "big-ras"] = "labelled"
    #: gpiozero's MockFactory instead of real pins (no hardware; tests, a laptop)
    emulate: bool = False
    #: jog speed as a fraction of the axis' top speed; ``slow`` held: slow_speed
    jog_speed: float = _num(1.0, gt=0.0, le=1.0)
    slow_speed: float = _num(0.2, gt=0.0, le=1.0)
    #: display refreshes per second (off the control loop)
    refresh_hz: float = _num(4.0, gt=0.0, le=20.0)
    #: switch debounce
    bounce_s: float = _num(0.02, ge=0.0, le=0.5)
    buttons: PanelButtons = PanelButtons()
    leds: PanelLeds = PanelLeds()
    beeper: int | None = Field(None, ge=0, le=53)
    #: BIG-RAS "Beeper type": "off" (silent), "dc" (an active beeper: on/off) or the tone
    #: in Hz, 200..5000, for a passive one (driven with PWM at that frequency)
    beeper_type: Literal["off", "dc"] | typing.Annotated[int, Field(ge=200, le=5000)] = "dc"
    #: a short beep whenever a command from a protocol port gives the rotator a new
    #: target (the BIG-RAS beeps on each serial command; off unless asked for)
    beep_on_command: bool = False
    #: BIG-RAS "Backlight", percent: the OLED's brightness; a PCF8574 LCD backpack
    #: switches its backlight only, on above 0
    backlight_pct: int = Field(100, ge=0, le=100)
    #: BIG-RAS "Screensaver": the display goes dark this long after the last key (a
    #: button, the IR remote) or fault; 0 = always lit. A key wakes it.
    screensaver_s: float = _num(0.0, ge=0.0, le=86400.0)
    #: BIG-RAS "Autoturn": a jog held 5 s goes on after its button is let go, until a
    #: button is pressed again or the axis reaches its end of travel
    autoturn: bool = False
    lcd: PanelLcd | None = None
    oled: PanelOled | None = None
    ir: PanelIr | None = None


def _panel_issues(cfg: Config) -> list[_Issue]:
    """[panel]: each GPIO used once, IR keys mapped to known actions, one display."""
    from .frontpanel.controls import ACTIONS

    p = cfg.panel
    issues: list[_Issue] = []
    used: dict[int, str] = {}
    pins = [(f"panel.buttons.{k}", v) for k, v in p.buttons.model_dump().items()] + \
        [(f"panel.leds.{k}", v) for k, v in p.leds.model_dump().items()] + [("panel.beeper", p.beeper)]
    for key, pin in pins:
        if pin is None:
            continue
        if pin in used:
            issues.append((key, f"a GPIO not already used by {used[pin]}", pin, ""))
        used.setdefault(pin, key)
    if p.lcd is not None and p.oled is not None:
        issues.append(("panel.oled", "one display: [panel.lcd] or [panel.oled], not both", "both", ""))
    if p.ir is not None:
        for name, action in p.ir.keys.items():
            if action not in ACTIONS:
                issues.append((f"panel.ir.keys.{name}", "one of " + ", ".join(ACTIONS), action,
                               _suggest(action, list(ACTIONS))))
            if not (re.fullmatch(r"(KEY|BTN)_[A-Z0-9_]+", name) or re.fullmatch(r"0x[0-9a-fA-F]+|[0-9]+", name)):
                issues.append((f"panel.ir.keys.{name}", "an evdev key name such as KEY_LEFT, or a key code",
                               name, ""))
    return issues


def parse_host_port(text: str) -> tuple[str, int]:
    """``"127.0.0.1:4533"`` or ``"[::1]:4533"`` -> (host, port); ValueError if not."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ValueError(text)
    return host.strip("[]"), int(port)


class Config(_Section):
    rotator: RotatorSection = RotatorSection()
    hardware: HardwareSection = HardwareSection()
    limits: LimitsSection = LimitsSection()
    offsets: OffsetsSection = OffsetsSection()
    #: ``cfg.park.az_deg`` is the setting; ``cfg.park(caps)`` the resolved position.
    park: ParkSection = ParkSection()
    keepout: tuple[KeepoutZone, ...] = Field((), strict=False)
    control: ControlSection = ControlSection()
    faults: FaultsSection = FaultsSection()
    api: ApiSection = ApiSection()
    state: StateSection = StateSection()
    station: StationSection = StationSection()
    tracking: TrackingSection = TrackingSection()
    #: protocols served and where; None (no [[serve]] at all) = rotctld on 127.0.0.1:4533
    serve: tuple[ServeEntry, ...] | None = Field(None, strict=False)
    panel: PanelSection = PanelSection()
    #: None (no [mqtt]) = no broker (urc.mqtt)
    mqtt: MqttSection | None = None

    @property
    def served(self) -> tuple[ServeEntry, ...]:
        return DEFAULT_SERVE if self.serve is None else self.serve

    @model_validator(mode="after")
    def _check_against_profile(self) -> Config:
        issues = _cross_check(self)
        if issues:
            raise _error_from_issues(issues, "<config>")
        return self

    # -- construction --------------------------------------------------------------

    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>") -> Config:
        """Validate a parsed TOML document (or a dict from the web settings page)."""
        if not isinstance(data, dict):
            raise ConfigError(
                f"{source}: expected a table of settings, found {_describe(data)}",
                path=source, key=None, expected="a table of settings", found=data)
        try:
            return cls.model_validate(data)
        except ValidationError as exc:
            raise _error_from_validation(exc, source) from None
        except ConfigError as exc:
            issues = getattr(exc, "_issues", None)
            if issues is None:  # pragma: no cover - raised by something we called
                raise
            raise _error_from_issues(issues, source) from None

    # -- derived values ---------------------------------------------------------------

    @property
    def caps(self) -> RotatorCaps:
        """The frozen capabilities of ``rotator.profile`` (single-axis when
        ``rotator.elevation`` is false)."""
        return self.rotator.variant(PROFILES[self.rotator.profile])

    def effective_limits(self, caps: RotatorCaps | None = None) -> dict[str, tuple[float, float]]:
        """``{'az': (min_deg, max_deg), 'el': (...)}`` after applying the user limits."""
        caps = caps or self.caps
        out = {}
        for name in ("az", "el"):
            axis: AxisCaps = caps.axis(name)
            lim: AxisLimits = getattr(self.limits, name)
            lo = axis.min_deg if lim.min_deg is None else lim.min_deg
            hi = axis.max_deg if lim.max_deg is None else lim.max_deg
            out[name] = (float(lo), float(hi))
        return out

    def park_position(self, caps: RotatorCaps | None = None) -> tuple[float, float]:
        """``(az_deg, el_deg)`` to park at; same as ``cfg.park(caps)``."""
        return self.park(caps or self.caps)

    def effective_control(self, caps: RotatorCaps | None = None) -> dict[str, dict[str, float]]:
        """Per axis: the control settings after applying the overrides to the caps."""
        caps = caps or self.caps
        out = {}
        for name in ("az", "el"):
            axis: AxisCaps = caps.axis(name)
            c: AxisControl = getattr(self.control, name)
            out[name] = {
                "tolerance_deg": _pick(c.tolerance_deg, axis.tolerance_deg),
                "restart_deg": _pick(c.restart_deg, axis.restart_deg),
                "max_rate_deg_per_s": _pick(c.max_rate_deg_per_s, axis.max_rate_deg_per_s),
                "min_rate_deg_per_s": _pick(c.min_rate_deg_per_s, axis.min_rate_deg_per_s),
                "accel_deg_per_s2": _pick(c.accel_deg_per_s2, axis.accel_deg_per_s2),
                "kp_per_s": float(c.kp_per_s),
                "ki_per_s2": float(c.ki_per_s2),
                "overshoot_deg": _pick(c.overshoot_deg, axis.overshoot_deg),
                "creep_lead_deg": _pick(c.creep_lead_deg, axis.effective_creep_lead_deg),
                "backlash_deg": _pick(c.backlash_deg, axis.backlash_deg),
            }
        return out

    @property
    def control_requires_token(self) -> bool:
        return self.api.control_requires_token

    # -- output -------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict, None values left out, as it would be written to TOML."""
        return _strip_none(self.model_dump())

    def to_toml(self) -> str:
        """This configuration as a TOML document that loads back to an equal Config."""
        return _dump_toml(self.to_dict())


def _pick(override: float | None, default: float) -> float:
    return float(default if override is None else override)


# --------------------------------------------------------------------------- cross-checks

_Issue = tuple[str, str, Any, str]  # key, expected, found, hint


def _fmt(x: float) -> str:
    return f"{x:g}"


def _backends() -> list[str]:
    try:
        from .hardware import available_backends

        return list(available_backends())
    except ImportError:
        return list(_BUILTIN_BACKENDS)


def _cross_check(cfg: Config) -> list[_Issue]:
    issues: list[_Issue] = []
    caps = PROFILES.get(cfg.rotator.profile)
    if caps is None:
        valid = ", ".join(sorted(PROFILES))
        hint = _suggest(cfg.rotator.profile, sorted(PROFILES))
        return [("rotator.profile", f"one of {valid}", cfg.rotator.profile, hint)]

    issues += _menu_issues(cfg, caps)
    caps = cfg.rotator.variant(caps)
    issues += _single_axis_issues(cfg, caps)
    if cfg.rotator.flip is True and not caps.can_flip and caps.has_el:
        issues.append(("rotator.flip", f"false (profile {caps.name!r} elevation stops at "
                       f"{_fmt(caps.el.max_deg)} deg, flip needs 180), or \"auto\"", True, ""))

    backends = _backends()
    if cfg.hardware.backend not in backends:
        issues.append(("hardware.backend", "one of " + ", ".join(backends),
                       cfg.hardware.backend, _suggest(cfg.hardware.backend, backends)))

    issues += _bridge_issues(cfg)
    issues += _gpio_issues(cfg, caps)
    issues += _panel_issues(cfg)
    issues += mqtt_issues(cfg)

    for name in ("az", "el"):
        axis = caps.axis(name)
        start = getattr(cfg.hardware.sim, f"start_{name}_deg")
        if start is not None and not axis.min_deg <= start <= axis.max_deg:
            issues.append((f"hardware.sim.start_{name}_deg",
                           f"a number (degrees) in {_fmt(axis.min_deg)}..{_fmt(axis.max_deg)} "
                           f"(profile {caps.name!r} {name} range)", start, ""))

    # user limits inside the profile's range, min < max
    limits_ok = True
    for name in ("az", "el"):
        axis = caps.axis(name)
        lim = getattr(cfg.limits, name)
        rng = f"profile {caps.name!r} {name} range {_fmt(axis.min_deg)}..{_fmt(axis.max_deg)}"
        for end in ("min_deg", "max_deg"):
            v = getattr(lim, end)
            if v is not None and not axis.min_deg <= v <= axis.max_deg:
                limits_ok = False
                issues.append((f"limits.{name}.{end}",
                               f"a number (degrees) in {_fmt(axis.min_deg)}..{_fmt(axis.max_deg)}"
                               f" (the {rng})", v, ""))
        lo = axis.min_deg if lim.min_deg is None else lim.min_deg
        hi = axis.max_deg if lim.max_deg is None else lim.max_deg
        if lo >= hi:
            limits_ok = False
            key = f"limits.{name}.max_deg" if lim.max_deg is not None else f"limits.{name}.min_deg"
            found = hi if lim.max_deg is not None else lo
            issues.append((key, f"limits.{name}.min_deg < limits.{name}.max_deg "
                           f"(min is {_fmt(lo)}, max is {_fmt(hi)})", found, ""))

    # park inside the limits
    if limits_ok:
        eff = cfg.effective_limits(caps)
        park = cfg.park_position(caps)
        for i, name in enumerate(("az", "el")[:len(caps.axes)]):
            lo, hi = eff[name]
            v = park[i]
            user = getattr(cfg.park, f"{name}_deg")
            if not lo <= v <= hi:
                hint = "" if user is not None else (
                    f"the profile's park {name} is outside limits.{name}; set park.{name}_deg")
                issues.append((f"park.{name}_deg",
                               f"a number (degrees) inside the {name} limits "
                               f"{_fmt(lo)}..{_fmt(hi)}", v, hint))

    # keep-out zones
    az_lo, az_hi = min(caps.az.min_deg, 0.0), max(caps.az.max_deg, 360.0)
    el_lo, el_hi = _KEEPOUT_EL_RANGE
    for i, z in enumerate(cfg.keepout):
        pre = f"keepout[{i}]"
        zone_ok = True
        for end in ("az_min_deg", "az_max_deg"):
            v = getattr(z, end)
            if not az_lo <= v <= az_hi:
                zone_ok = False
                issues.append((f"{pre}.{end}", f"a number (degrees) in {_fmt(az_lo)}.."
                               f"{_fmt(az_hi)} (compass, or profile {caps.name!r} wrap range)",
                               v, ""))
        for end in ("el_min_deg", "el_max_deg"):
            v = getattr(z, end)
            if not el_lo <= v <= el_hi:
                zone_ok = False
                issues.append((f"{pre}.{end}", f"a number (degrees) in {_fmt(el_lo)}.."
                               f"{_fmt(el_hi)}", v, ""))
        if z.az_min_deg == z.az_max_deg:
            zone_ok = False
            issues.append((f"{pre}.az_max_deg", f"a number different from az_min_deg "
                           f"({_fmt(z.az_min_deg)}); a sector across north is written "
                           f"az_min_deg = 350, az_max_deg = 10", z.az_max_deg, ""))
        elif z.az_max_deg - z.az_min_deg > 360.0:
            zone_ok = False
            issues.append((f"{pre}.az_max_deg", f"at most 360 degrees past az_min_deg "
                           f"({_fmt(z.az_min_deg)})", z.az_max_deg, ""))
        if z.el_min_deg >= z.el_max_deg:
            zone_ok = False
            issues.append((f"{pre}.el_max_deg", f"a number greater than el_min_deg "
                           f"({_fmt(z.el_min_deg)})", z.el_max_deg, ""))
        if zone_ok and limits_ok:
            paz, pel = cfg.park_position(caps)
            if z.keep_out(i).contains(paz, pel):
                user = cfg.park.az_deg is not None or cfg.park.el_deg is not None
                key = "park.az_deg" if user else pre
                issues.append((key, f"a park position outside keep-out zone {z.label(i)!r}",
                               (paz, pel), "" if user else
                               "the profile's park position is inside this zone; set [park]"))

    # served protocols: a known protocol, exactly one well-formed transport each
    from .protocols.registry import PROTOCOLS

    seen: dict[tuple[str, str], int] = {}
    for i, entry in enumerate(cfg.serve or ()):
        pre = f"serve[{i}]"
        if entry.protocol not in PROTOCOLS:
            issues.append((f"{pre}.protocol", "one of " + ", ".join(PROTOCOLS), entry.protocol,
                           _suggest(entry.protocol, list(PROTOCOLS))))
        given = [k for k in ("tcp", "pty", "serial", "udp") if getattr(entry, k) is not None]
        if len(given) != 1:
            issues.append((pre, "exactly one of tcp, pty, serial, udp", given or "none", ""))
            continue
        kind, where = entry.transport
        if kind in ("tcp", "udp"):
            try:
                parse_host_port(where)
            except ValueError:
                issues.append((f"{pre}.{kind}", '"host:port", e.g. "127.0.0.1:4533"', where, ""))
        if (kind, where) in seen:
            issues.append((f"{pre}.{kind}", f"an address not already used by serve[{seen[kind, where]}]",
                           where, ""))
        seen[(kind, where)] = i

    # control overrides within what the profile can do
    eff_ctl = cfg.effective_control(caps)
    for name in ("az", "el"):
        axis = caps.axis(name)
        c = getattr(cfg.control, name)
        for fld, cap, unit in (("max_rate_deg_per_s", axis.max_rate_deg_per_s, "deg/s"),
                               ("accel_deg_per_s2", axis.accel_deg_per_s2, "deg/s^2")):
            v = getattr(c, fld)
            if v is not None and v > cap:
                issues.append((f"control.{name}.{fld}",
                               f"a number <= {_fmt(cap)} {unit} (profile {caps.name!r} "
                               f"{name} maximum)", v, ""))
        e = eff_ctl[name]
        if c.min_rate_deg_per_s is not None and c.min_rate_deg_per_s > e["max_rate_deg_per_s"]:
            issues.append((f"control.{name}.min_rate_deg_per_s", f"a number <= the {name} top speed "
                           f"{_fmt(e['max_rate_deg_per_s'])} deg/s", c.min_rate_deg_per_s, ""))
        if e["restart_deg"] < e["tolerance_deg"]:
            key = f"control.{name}.restart_deg" if c.restart_deg is not None \
                else f"control.{name}.tolerance_deg"
            found = c.restart_deg if c.restart_deg is not None else c.tolerance_deg
            issues.append((key, f"restart_deg >= tolerance_deg (restart "
                           f"{_fmt(e['restart_deg'])}, tolerance {_fmt(e['tolerance_deg'])})",
                           found, ""))
    return issues


#: ADC inputs per converter
_ADC_CHANNELS = {"ads1115": 4, "mcp3008": 8}


def _menu_issues(cfg: Config, caps: RotatorCaps) -> list[_Issue]:
    """The BIG-RAS menu settings in [rotator]: values the controller offers, on a profile
    that has what they set."""
    r, issues = cfg.rotator, []
    if r.max_el_deg is not None and r.max_el_deg not in (90.0, 180.0):
        issues.append(("rotator.max_el_deg", "90 or 180 (degrees)", r.max_el_deg, ""))
    if r.max_el_deg is not None and not r.elevation:
        issues.append(("rotator.max_el_deg", "no max_el_deg (rotator.elevation = false: azimuth only)",
                       r.max_el_deg, ""))
    if r.pulses_per_deg is not None and not any(caps.axis(n).sensor.kind == "pulse" for n in ("az", "el")):
        issues.append(("rotator.pulses_per_deg", f"no pulses_per_deg (profile {caps.name!r} has no pulse "
                       f"sensor: its sensor is {caps.az.sensor.kind})", r.pulses_per_deg, ""))
    return issues


def _single_axis_issues(cfg: Config, caps: RotatorCaps) -> list[_Issue]:
    """``rotator.elevation = false``: no setting may give the absent axis a value."""
    if caps.has_el:
        return []
    expected = "no elevation setting (rotator.elevation = false: azimuth only)"
    issues: list[_Issue] = []
    given = [("limits.el.min_deg", cfg.limits.el.min_deg), ("limits.el.max_deg", cfg.limits.el.max_deg),
             ("park.el_deg", cfg.park.el_deg), ("hardware.sim.start_el_deg", cfg.hardware.sim.start_el_deg),
             ("hardware.gpio.el", None if cfg.hardware.gpio is None or cfg.hardware.gpio.el is None else "[...]")]
    if cfg.offsets.el_deg:
        given.append(("offsets.el_deg", cfg.offsets.el_deg))
    for key, v in given:
        if v is not None:
            issues.append((key, expected, v, "remove it, or set rotator.elevation = true"))
    if cfg.rotator.flip is True:
        issues.append(("rotator.flip", 'false or "auto" (a single-axis rotator cannot fly over the top)',
                       True, ""))
    return issues


def _gpio_issues(cfg: Config, caps: RotatorCaps) -> list[_Issue]:
    """[hardware.gpio]: every pin the profile's parts need, each pin once, one device
    per I2C address, ADC inputs that exist."""
    g = cfg.hardware.gpio
    if g is None:
        if cfg.hardware.backend == "gpio":
            return [("hardware.gpio", "[hardware.gpio] with [hardware.gpio.az] and [hardware.gpio.el] "
                     '(backend "gpio"; see examples/)', None, "")]
        return []
    from .hardware.gpio import FAULT_INPUT_PINS, MOTOR_PINS, OPTIONAL_PINS, SENSOR_PINS
    from .hardware.gpio.pwm import HARDWARE_PWM

    issues: list[_Issue] = []
    if g.hardware_pwm not in HARDWARE_PWM:
        issues.append(("hardware.gpio.hardware_pwm", "one of " + ", ".join(HARDWARE_PWM), g.hardware_pwm,
                       _suggest(g.hardware_pwm, list(HARDWARE_PWM))))
    used: dict[int, str] = {}
    for key, pin in (("heartbeat_pin", g.heartbeat_pin), ("power_fail_pin", g.power_fail_pin)):
        if pin is not None:
            used[pin] = f"hardware.gpio.{key}"
    #: (bus, mux channel or None, address) -> (key, chip)
    i2c: dict[tuple[int, int | None, int], tuple[str, str]] = {}
    if g.fram_address is not None:
        i2c[(g.i2c_bus, None, g.fram_address)] = ("hardware.gpio.fram_address", "fram")
    muxed_buses: set[int] = set()
    spi_vref: dict[int, tuple[str, float]] = {}
    adc_inputs: dict[tuple, str] = {}
    for name in caps.axes:  # single-axis: no [hardware.gpio.el] needed (nor allowed)
        ax = getattr(g, name)
        pre = f"hardware.gpio.{name}"
        if ax is None:
            issues.append((pre, f"[{pre}] with motor and pins", None, ""))
            continue
        axc = caps.axis(name)
        if ax.motor not in MOTOR_PINS:
            issues.append((f"{pre}.motor", "one of " + ", ".join(MOTOR_PINS), ax.motor,
                           _suggest(ax.motor, list(MOTOR_PINS))))
            continue
        if (ax.motor == "relay") != (axc.drive == "relay"):
            issues.append((f"{pre}.motor", f"a {'relay' if axc.drive == 'relay' else 'PWM'} drive "
                           f"(profile {caps.name!r} {name} is {axc.drive})", ax.motor, ""))
        kind = axc.sensor.kind
        need = list(MOTOR_PINS[ax.motor]) + list(SENSOR_PINS.get(kind, ()))
        if axc.brake:
            need.append("brake")
        allowed = set(need) | set(OPTIONAL_PINS.get(ax.motor, ())) | set(OPTIONAL_PINS.get(kind, ())) | \
            {"brake", "limit_min", "limit_max"}
        for pin_name in need:
            if pin_name not in ax.pins:
                issues.append((f"{pre}.pins.{pin_name}", f"a BCM pin number (needed by {ax.motor} / "
                               f"{kind})", None, ""))
        for pin_name, pin in ax.pins.items():
            if pin_name not in allowed:
                issues.append((f"{pre}.pins.{pin_name}", "one of " + ", ".join(sorted(allowed)), pin_name,
                               _suggest(pin_name, sorted(allowed))))
            elif not 0 <= pin <= 27:
                issues.append((f"{pre}.pins.{pin_name}", "a BCM pin 0..27", pin, ""))
            elif pin in used:
                issues.append((f"{pre}.pins.{pin_name}", f"a pin not already used (GPIO{pin} is "
                               f"{used[pin]})", pin, ""))
            else:
                used[pin] = f"{pre}.pins.{pin_name}"
        if ax.encoder_index_deg is not None and (kind != "encoder" or "enc_z" not in ax.pins):
            issues.append((f"{pre}.encoder_index_deg", "an encoder with its index on pins.enc_z",
                           ax.encoder_index_deg, ""))
        if kind == "magnetometer" and ax.compass not in ("lsm303d", "lsm303agr"):
            issues.append((f"{pre}.compass", "lsm303d or lsm303agr", ax.compass, ""))
        if ax.adc not in _ADC_CHANNELS:
            issues.append((f"{pre}.adc", "one of " + ", ".join(_ADC_CHANNELS), ax.adc,
                           _suggest(ax.adc, list(_ADC_CHANNELS))))
            continue
        if ax.current_sense_channel is not None and ax.current_sense_v_per_a is None and ax.motor == "lmd18200":
            issues.append((f"{pre}.current_sense_v_per_a", "volts per motor ampere for the LMD18200's sense "
                           "output (377e-6 x your sense resistor in ohms)", None, ""))
        uses_adc = kind == "pot" or ax.current_sense_channel is not None
        if uses_adc:
            issues += _adc_issues(pre, ax, kind, used, spi_vref, adc_inputs,
                                  g.i2c_bus if ax.i2c_bus is None else ax.i2c_bus)
        chips = {"as5600": [("as5600", 0x36)],
                 "magnetometer": [("lsm303agr", 0x19), ("lsm303agr", 0x1E)] if ax.compass == "lsm303agr"
                 else [("lsm303d", 0x1D)]}.get(kind, [])
        if uses_adc and ax.adc == "ads1115":
            chips = chips + [("ads1115", 0x48)]
        bus = g.i2c_bus if ax.i2c_bus is None else ax.i2c_bus
        ch = ax.i2c_mux_channel
        if ch is not None:
            muxed_buses.add(bus)
            if not chips:
                issues.append((f"{pre}.i2c_mux_channel", f"no mux channel (the {kind} sensor has no "
                               "I2C chip)", ch, ""))
        where = f"I2C bus {bus}" + ("" if ch is None else f" mux channel {ch}")
        for dev in chips:
            addr = (ax.i2c_address or dev[1]) if len(chips) == 1 else dev[1]
            # a chip on the bus itself meets every mux channel's chips at its address
            for (b, c, a), other in i2c.items():
                if b != bus or a != addr or (c is not None and ch is not None and c != ch):
                    continue
                # one LSM303 serves both axes (compass and tilt), one ADS1115 both pots
                if c != ch or other[1] != dev[0] or dev[0] == "as5600":
                    issues.append((f"{pre}.i2c_address", f"an address free on {where} (0x{addr:02x} is "
                                   f"{other[0]}'s; two AS5600 need two buses or two channels of a "
                                   "TCA9548A mux: i2c_mux_channel)", hex(addr), ""))
                    break
            i2c[(bus, ch, addr)] = (pre, dev[0])
    for bus in sorted(muxed_buses):
        for (b, _c, a), other in i2c.items():
            if b == bus and a == g.i2c_mux_address:
                issues.append(("hardware.gpio.i2c_mux_address", f"an address free on I2C bus {bus} for "
                               f"the TCA9548A (0x{a:02x} is {other[0]}'s)", hex(a), ""))
    if g.motor_enable_timeout_s is not None and g.heartbeat_pin is None:
        issues.append(("hardware.gpio.motor_enable_timeout_s", "a heartbeat_pin for the safety chain to watch",
                       g.motor_enable_timeout_s, ""))
    for name in caps.axes:
        ax = getattr(g, name)
        if ax is None:
            continue
        outputs = set(MOTOR_PINS.get(ax.motor, ())) | set(OPTIONAL_PINS.get(ax.motor, ())) | {"brake"}
        outputs -= set(FAULT_INPUT_PINS) | set(SENSOR_PINS.get("encoder", ())) | {"pulse"}
        for key in ax.active_low:
            if key not in outputs or key not in ax.pins:
                issues.append((f"hardware.gpio.{name}.active_low", "names of this axis' output pins "
                               f"({', '.join(sorted(k for k in ax.pins if k in outputs))})", key, ""))
    # every pin against every other: the panel's too, and the buses' (I2C1 is GPIO2/3
    # whenever a chip, the FRAM or a panel display sits on it)
    bus_users = bool(i2c) or cfg.panel.lcd is not None or cfg.panel.oled is not None
    if bus_users:
        for pin, what in ((2, "I2C1 SDA"), (3, "I2C1 SCL")):
            for key, p in list(used.items()):
                if key == pin:
                    issues.append((p, f"a pin not used by the I2C bus (GPIO{pin} is {what})", pin, ""))
            used.setdefault(pin, what)
    p = cfg.panel
    panel = [(f"panel.buttons.{k}", v) for k, v in p.buttons.model_dump().items()] + \
        [(f"panel.leds.{k}", v) for k, v in p.leds.model_dump().items()] + [("panel.beeper", p.beeper)]
    for key, pin in panel:
        if pin is not None and pin in used:
            issues.append((key, f"a GPIO not already used (GPIO{pin} is {used[pin]})", pin, ""))
    return issues


#: BCM2711/BCM2835 default pulls at power-on: GPIO0-8 up, 9-27 down (BCM2711 ARM
#: Peripherals, "Alternative Function Assignments", the pull column)
BOOT_HIGH_PINS = frozenset(range(0, 9))


def gpio_warnings(cfg: Config) -> list[str]:
    """What ``urc config check`` warns about in [hardware.gpio] without refusing it: a
    motor, relay or brake output that is high from power-on until urc claims it (or,
    active low, low from power-on), and current sensed with no overcurrent trip."""
    g = cfg.hardware.gpio
    if g is None:
        return []
    from .hardware.gpio import FAULT_INPUT_PINS, MOTOR_PINS, OPTIONAL_PINS
    notes = []
    for name in ("az", "el"):
        ax = getattr(g, name)
        if ax is None:
            continue
        outputs = (set(MOTOR_PINS.get(ax.motor, ())) | set(OPTIONAL_PINS.get(ax.motor, ())) | {"brake"}) \
            - set(FAULT_INPUT_PINS)
        for key, pin in sorted(ax.pins.items()):
            if key not in outputs or pin in g.pulled_down:
                continue
            high_at_boot = pin in BOOT_HIGH_PINS
            low_active = key in ax.active_low
            if high_at_boot == low_active:     # off at boot: high for active low, low otherwise
                continue
            if high_at_boot:
                notes.append(f"hardware.gpio.{name}.pins.{key}: GPIO{pin} is pulled HIGH from power-on until "
                             "urc starts: the output is on during boot. Use a pin from GPIO9-27, or fit a "
                             f"10 kOhm pull-down and list it in hardware.gpio.pulled_down")
            else:
                notes.append(f"hardware.gpio.{name}.pins.{key}: active low on GPIO{pin}, which is pulled LOW "
                             "from power-on until urc starts: the load is on during boot. Use a pin from "
                             "GPIO0-8 for an active-low output, or fit a pull-up")
        if ax.current_sense_channel is not None and cfg.faults.overcurrent_a == 0 and not g.emulate:
            notes.append(f"hardware.gpio.{name}.current_sense_channel: the motor current is sensed but "
                         "faults.overcurrent_a is 0: no overcurrent trip. Set it (about twice the running "
                         "current, below the stall current)")
    if g.heartbeat_pin is not None and g.heartbeat_pin in BOOT_HIGH_PINS and g.heartbeat_pin not in g.pulled_down:
        notes.append(f"hardware.gpio.heartbeat_pin: GPIO{g.heartbeat_pin} is pulled high at power-on: that rising "
                     "edge can hold the safety chain's relay in for one timeout while the Pi boots. Use a "
                     "pin from GPIO9-27")
    if g.heartbeat_pin is not None and g.motor_enable_timeout_s is None:
        notes.append("hardware.gpio.motor_enable_timeout_s: no safety chain declared: if urc freezes or dies "
                     "nothing but urc stops the motors (docs/hardware.md, \"Safety chain\")")
    return notes


#: motor drivers with a current-sense output
_CURRENT_SENSE_MOTORS = ("vnh5019", "bts7960", "lmd18200")


def _adc_issues(pre: str, ax: Any, kind: str, used: dict[int, str], spi_vref: dict[int, tuple[str, float]],
                adc_inputs: dict[tuple, str], bus: int) -> list[_Issue]:
    """An axis' ADC (its pot and/or its bridge's current sense): inputs that exist, each
    used once per chip (the pots' shared supply input aside), SPI0's pins, one VREF per
    MCP3008."""
    issues: list[_Issue] = []
    n = _ADC_CHANNELS[ax.adc]
    if ax.adc == "mcp3008":
        issues += _spi_issues(pre, ax.spi_device, used)
        chip: tuple = ("MCP3008", ax.spi_device)
    else:
        chip = ("ADS1115", ax.i2c_address or 0x48, bus, ax.i2c_mux_channel)
    inputs = []
    if kind == "pot":
        inputs.append(("adc_channel", ax.adc_channel))
        ref = 3 if ax.adc_reference_channel is None and ax.adc == "ads1115" else ax.adc_reference_channel
        if ref is not None and not 0 <= ref < n:
            issues.append((f"{pre}.adc_reference_channel", f"an {ax.adc.upper()} input 0..{n - 1}", ref, ""))
        elif ax.adc_channel == ref:
            issues.append((f"{pre}.adc_reference_channel", "an input other than adc_channel "
                           "(the pot supply)", ref, ""))
    if ax.current_sense_channel is not None:
        inputs.append(("current_sense_channel", ax.current_sense_channel))
        if ax.motor not in _CURRENT_SENSE_MOTORS:
            issues.append((f"{pre}.current_sense_channel", "a bridge with a current-sense output ("
                           + ", ".join(_CURRENT_SENSE_MOTORS) + ")", ax.motor, ""))
    for key, v in inputs:
        if not 0 <= v < n:
            issues.append((f"{pre}.{key}", f"an {ax.adc.upper()} input 0..{n - 1}", v, ""))
        elif (chip, v) in adc_inputs:
            issues.append((f"{pre}.{key}", f"an input not already used ({ax.adc.upper()} input {v} is "
                           f"{adc_inputs[(chip, v)]})", v, ""))
        else:
            adc_inputs[(chip, v)] = f"{pre}.{key}"
    if ax.adc == "mcp3008":
        # one chip, one VREF: the pot supply (a pot with no reference input) or the 3.3 V rail
        vref = ax.adc_reference_v if kind == "pot" and ax.adc_reference_channel is None else 3.3
        other_vref = spi_vref.setdefault(ax.spi_device, (pre, vref))
        if other_vref[1] != vref:
            issues.append((f"{pre}.adc_reference_channel", f"the same VREF as {other_vref[0]} on "
                           f"this MCP3008 ({other_vref[1]:g} V)", ax.adc_reference_channel, ""))
    return issues


def _spi_issues(pre: str, device: int, used: dict[int, str]) -> list[_Issue]:
    """SPI0's pins for a chip on chip select ``device``: taken by SPI0 (shared by its
    chips), by nothing else."""
    from .hardware.gpio.spi import SPI0_CE, SPI0_PINS

    issues: list[_Issue] = []
    for what, pin in [*SPI0_PINS.items(), (f"ce{device}", SPI0_CE[device])]:
        owner = f"SPI0 {what.upper()}"
        if pin in used and used[pin] != owner:
            issues.append((f"{pre}.spi_device", f"SPI0's GPIO{pin} ({owner}) free for the MCP3008 "
                           f"(it is {used[pin]})", device, ""))
        used.setdefault(pin, owner)
    return issues


def _bridge_issues(cfg: Config) -> list[_Issue]:
    """[hardware.bridge]: present for the bridge backend, a known protocol, one link."""
    from .hardware.bridge.dialects import BRIDGE_PROTOCOLS

    br = cfg.hardware.bridge
    if br is None:
        if cfg.hardware.backend == "bridge":
            return [("hardware.bridge", '[hardware.bridge] with protocol and serial or tcp '
                     '(backend "bridge")', None, "")]
        return []
    issues: list[_Issue] = []
    if br.protocol not in BRIDGE_PROTOCOLS:
        issues.append(("hardware.bridge.protocol", "one of " + ", ".join(BRIDGE_PROTOCOLS), br.protocol,
                       _suggest(br.protocol, list(BRIDGE_PROTOCOLS))))
    given = [k for k in ("serial", "tcp") if getattr(br, k) is not None]
    if len(given) != 1:
        issues.append(("hardware.bridge", "exactly one of serial, tcp", given or "none", ""))
    elif br.tcp is not None:
        try:
            parse_host_port(br.tcp)
        except ValueError:
            issues.append(("hardware.bridge.tcp", '"host:port", e.g. "127.0.0.1:4533"', br.tcp, ""))
    if br.baud is not None and br.tcp is not None:
        issues.append(("hardware.bridge.baud", "no baud with tcp (only a serial line has one)", br.baud, ""))
    if br.protocol == "rot1prog" and cfg.hardware.backend == "bridge" and cfg.caps.has_el and \
            cfg.effective_limits(cfg.caps)["el"][1] > 1.0:
        issues.append(("limits.el.max_deg", "at most 1 (a Rot1Prog turns azimuth only)",
                       cfg.limits.el.max_deg, "set rotator.elevation = false (or [limits.el] max_deg = 1)"))
    return issues


# --------------------------------------------------------------------------- errors


def _describe(value: Any) -> str:
    """``'abc' (str)``; long values shortened."""
    if isinstance(value, tuple) and len(value) == 2 and all(isinstance(v, float) for v in value):
        return f"az {_fmt(value[0])}, el {_fmt(value[1])}"
    if isinstance(value, dict):
        return f"a table ({len(value)} key{'' if len(value) == 1 else 's'})"
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def _key(loc: tuple[Any, ...]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


def _suggest(word: str, choices: list[str]) -> str:
    close = difflib.get_close_matches(str(word), choices, n=1, cutoff=0.6)
    return f"did you mean {close[0]!r}?" if close else ""


def _make_error(source: str, key: str | None, expected: str, found: Any, hint: str = "",
                *, found_text: str | None = None) -> ConfigError:
    found_text = found_text if found_text is not None else _describe(found)
    where = f"{source}: {key}: " if key else f"{source}: "
    msg = f"{where}expected {expected}, found {found_text}"
    if hint:
        msg += f"; {hint}"
    return ConfigError(msg, path=source, key=key, expected=expected, found=found)


def _combine(errors: list[ConfigError]) -> ConfigError:
    first = errors[0]
    msg = str(first)
    if len(errors) > 1:
        msg += f"\n  ({len(errors) - 1} more problem{'s' if len(errors) > 2 else ''}:)"
        msg += "".join(f"\n  {e}" for e in errors[1:])
    err = ConfigError(msg, path=first.path, key=first.key, expected=first.expected,
                      found=first.found)
    err.errors = errors  # type: ignore[attr-defined]
    return err


def _error_from_issues(issues: list[_Issue], source: str) -> ConfigError:
    errs = [_make_error(source, k, exp, found, hint) for k, exp, found, hint in issues]
    err = _combine(errs)
    err._issues = issues  # type: ignore[attr-defined]
    return err


def _unwrap_model(annotation: Any) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _unwrap_model(typing.get_args(annotation)[0])
    if origin in (Union, types.UnionType, tuple, list):
        for arg in typing.get_args(annotation):
            found = _unwrap_model(arg)
            if found is not None:
                return found
    return None


def _resolve(loc: tuple[Any, ...]) -> tuple[type[BaseModel] | None, Any]:
    """The model holding ``loc[-1]`` and that field's FieldInfo (or None)."""
    model: type[BaseModel] | None = Config
    for part in loc[:-1]:
        if isinstance(part, int) or model is None:
            continue
        info = _fields_by_name(model).get(part)
        model = _unwrap_model(info.annotation) if info is not None else None
    if model is None or not loc or isinstance(loc[-1], int):
        return model, None
    return model, _fields_by_name(model).get(loc[-1])


def _fields_by_name(model: type[BaseModel]) -> dict[str, Any]:
    return dict(model.model_fields)


_UNITS = (("_deg_per_s2", "degrees per second squared"), ("_deg_per_s", "degrees per second"),
          ("_per_s2", "per second squared"), ("_per_s", "per second"), ("_deg", "degrees"),
          ("_hz", "Hz"), ("_s", "seconds"), ("_a", "amperes"))


def _unit(name: str) -> str:
    for suffix, unit in _UNITS:
        if name.endswith(suffix):
            return unit
    return ""


def _range_text(info: Any) -> str:
    parts = {}
    for m in getattr(info, "metadata", ()):
        for attr in ("ge", "gt", "le", "lt"):
            if isinstance(m, getattr(annotated_types, attr.capitalize())):
                parts[attr] = getattr(m, attr)
    lo = parts.get("ge", parts.get("gt"))
    hi = parts.get("le", parts.get("lt"))
    if "ge" in parts and "le" in parts:
        return f" in {_fmt(lo)}..{_fmt(hi)}"
    bits = []
    if lo is not None:
        bits.append(f"{'>=' if 'ge' in parts else '>'} {_fmt(lo)}")
    if hi is not None:
        bits.append(f"{'<=' if 'le' in parts else '<'} {_fmt(hi)}")
    return (" " + " and ".join(bits)) if bits else ""


def _kind(model: type[BaseModel] | None, info: Any, name: str) -> str:
    """What a field holds, in words: 'a number (degrees)', 'an integer', ..."""
    if info is None:
        return "a value"
    ann = info.annotation
    args = set(typing.get_args(ann)) | {ann}
    if _unwrap_model(ann) is not None:
        if typing.get_origin(ann) is tuple:
            return f"an array of tables ([[{name}]])"
        return f"a table ([{name}])"
    literals = [a for a in typing.get_args(ann) if typing.get_origin(a) is Literal]
    if bool in args and literals:  # flip = "auto" | true | false
        words = [f'"{v}"' for lit in literals for v in typing.get_args(lit)]
        return "true, false or " + " or ".join(words)
    if bool in args:
        return "true or false"
    if typing.get_origin(ann) is Literal:  # zero = "north" | "south"
        return " or ".join(f'"{v}"' for v in typing.get_args(ann))
    if float in args:
        unit = _unit(name)
        return f"a number ({unit})" if unit else "a number"
    if int in args:
        return "an integer"
    if str in args:
        return "a string"
    return "a value"


def _error_from_validation(exc: ValidationError, source: str) -> ConfigError:
    errs = []
    seen: set[tuple[Any, ...]] = set()
    for e in exc.errors(include_url=False):
        loc = tuple(e.get("loc", ()))
        if len(loc) >= 2 and e.get("type") != "extra_forbidden" and _resolve(loc)[1] is None \
                and _resolve(loc[:-1])[1] is not None:
            loc = loc[:-1]  # a union's member (flip: bool | "auto"): one error for the key
        if loc in seen:
            continue
        seen.add(loc)
        key = _key(loc) or None
        etype = e.get("type", "")
        value = e.get("input")
        model, info = _resolve(loc)
        name = str(loc[-1]) if loc else ""
        if etype == "extra_forbidden":
            known = sorted(_fields_by_name(model)) if model is not None else []
            shown = name
            hint = _suggest(shown, known)
            where = _key(loc[:-1])
            expected = (f"one of the keys of [{where}]: " if where else
                        "one of the top-level sections: ") + ", ".join(known)
            errs.append(_make_error(source, key, expected, shown,
                                    hint, found_text=f"unknown key {shown!r}"))
            continue
        kind = _kind(model, info, name)
        if etype == "missing":
            errs.append(_make_error(source, key, f"{kind} (required)", None,
                                    found_text="nothing"))
            continue
        if etype in ("finite_number",):
            expected = kind + _range_text(info) + ", finite (not nan or inf)"
        elif etype.startswith(("greater_than", "less_than")):
            expected = kind + _range_text(info)
        elif etype in ("string_too_short",):
            expected = "a non-empty string"
        else:
            expected = kind + (_range_text(info) if kind.startswith(("a number", "an int"))
                               else "")
        errs.append(_make_error(source, key, expected, value))
    if not errs:  # pragma: no cover - pydantic always reports at least one
        errs.append(_make_error(source, None, "a valid configuration", str(exc)))
    return _combine(errs)


# --------------------------------------------------------------------------- loading


def load_config(path: str | os.PathLike[str] | None) -> Config:
    """Read a TOML configuration file; ``None`` gives the defaults."""
    if path is None:
        return Config()
    source = os.fspath(path)
    try:
        raw = Path(source).read_bytes()
    except FileNotFoundError:
        raise ConfigError(f"{source}: configuration file not found: expected an existing file, "
                          "found no such file",
                          path=source, expected="an existing file", found="no such file"
                          ) from None
    except IsADirectoryError:
        raise ConfigError(f"{source}: expected a configuration file, found a directory",
                          path=source, expected="a file", found="a directory") from None
    except OSError as exc:
        raise ConfigError(f"{source}: cannot read the configuration file: {exc.strerror or exc}",
                          path=source, expected="a readable file", found=str(exc)) from None
    return loads_config(raw, source=source)


def loads_config(text: str | bytes, source: str = "<string>") -> Config:
    """Parse TOML text (str or UTF-8 bytes) into a Config."""
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            line = text[:exc.start].count(b"\n") + 1
            col = exc.start - (text.rfind(b"\n", 0, exc.start) + 1) + 1
            raise ConfigError(
                f"{source}:{line}:{col}: expected UTF-8 text, found byte "
                f"0x{text[exc.start]:02x} at line {line}, column {col}",
                path=source, expected="UTF-8 text", found=text[exc.start:exc.end]) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise _syntax_error(exc, text, source) from None
    except RecursionError:
        raise ConfigError(f"{source}: expected valid TOML, found nesting too deep to read",
                          path=source, expected="valid TOML", found="deep nesting") from None
    return Config.from_dict(data, source=source)


_POS = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")


def _syntax_error(exc: tomllib.TOMLDecodeError, text: str, source: str) -> ConfigError:
    msg = str(exc)
    m = _POS.search(msg)
    if m:
        line, col = int(m.group(1)), int(m.group(2))
        what = msg[:m.start()]
    else:
        what = msg.replace("(at end of document)", "").strip()
        lines = text.split("\n")
        line, col = len(lines), len(lines[-1]) + 1
    lines = text.split("\n")
    snippet = lines[line - 1] if 0 < line <= len(lines) else ""
    found = f"{what.rstrip('.').lower() or 'a syntax error'} in {snippet.strip()[:60]!r}"
    err = ConfigError(
        f"{source}:{line}:{col}: TOML syntax error at line {line}, column {col}: "
        f"expected valid TOML, found {found}",
        path=source, key=None, expected="valid TOML", found=found)
    err.line, err.column = line, col  # type: ignore[attr-defined]
    return err


# --------------------------------------------------------------------------- writing


def _strip_none(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _strip_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, (list, tuple)):
        return [_strip_none(v) for v in value]
    return value


_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _toml_key(key: str) -> str:
    return key if _BARE_KEY.match(key) else _toml_str(key)


def _toml_str(s: str) -> str:
    out = ['"']
    for ch in s:
        o = ord(ch)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif o < 0x20 or o == 0x7F:
            out.append(f"\\u{o:04x}")
        elif 0xD800 <= o <= 0xDFFF:  # lone surrogate: not representable, replace
            out.append("\\ufffd")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):  # pragma: no cover - the schema forbids it
            raise ValueError(f"cannot write {v!r}")
        return repr(v)
    if isinstance(v, str):
        return _toml_str(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(i) for i in v) + "]"
    if isinstance(v, dict):  # inline table, e.g. [[serve]] options
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(i)}" for k, i in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")  # pragma: no cover


def _dump_toml(data: dict[str, Any]) -> str:
    lines: list[str] = []

    def is_tables(v: Any) -> bool:  # a non-empty list of tables: written as [[name]]
        return isinstance(v, list) and bool(v) and all(isinstance(i, dict) for i in v)

    def table(prefix: str, d: dict[str, Any], header: str | None) -> None:
        scalars = [(k, v) for k, v in d.items() if not isinstance(v, dict) and not is_tables(v)]
        if header is not None and (scalars or (not d and header.startswith("[["))):
            if lines:
                lines.append("")
            lines.append(header)
        for k, v in scalars:
            lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
        for k, v in d.items():
            name = f"{prefix}.{_toml_key(k)}" if prefix else _toml_key(k)
            if isinstance(v, dict):
                table(name, v, f"[{name}]")
            elif is_tables(v):
                for item in v:
                    table(name, item, f"[[{name}]]")

    table("", data, None)
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- example

EXAMPLE_CONFIG: str = resources.files(__package__).joinpath(
    "config_example.toml").read_text(encoding="utf-8")
