"""``[hardware.gpio]`` checks beside the gpio builder (registered with the backend, run
whenever a configuration is validated): every pin the profile's parts need (the kinds'
table, :mod:`.kinds`), each pin once (the front panel's and the buses' too), one device
per I2C address, ADC inputs that exist; and the warnings ``urc config check`` prints
without refusing the configuration (:func:`gpio_warnings`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ...caps import RotatorCaps
from ...config.issues import Issue, one_of, suggest, warning
from .enable_sense import SENSE_POINTS
from .kinds import AXIS_PINS, MOTORS, SENSORS, SensorKind, motor_kind_issue, sensor_kind_issue
from .pwm import HARDWARE_PWM
from .spi import SPI0_CE, SPI0_PINS
from .stepdir import STEPDIR_CHIPS

if TYPE_CHECKING:
    from ...config import Config

#: ADC inputs per converter
_ADC_CHANNELS = {"ads1115": 4, "mcp3008": 8}


def gpio_issues(cfg: Config, caps: RotatorCaps) -> list[Issue]:
    """[hardware.gpio]: every pin the profile's parts need, each pin once, one device
    per I2C address, ADC inputs that exist."""
    g = cfg.hardware.gpio
    if g is None:
        if cfg.hardware.backend == "gpio":
            return [("hardware.gpio", "[hardware.gpio] with [hardware.gpio.az] and [hardware.gpio.el] "
                     '(backend "gpio"; see examples/)', None, "")]
        return []
    issues: list[Issue] = []
    if g.hardware_pwm not in HARDWARE_PWM:
        issues.append(("hardware.gpio.hardware_pwm", "one of " + ", ".join(HARDWARE_PWM), g.hardware_pwm,
                       suggest(g.hardware_pwm, list(HARDWARE_PWM))))
    used: dict[int, str] = {}
    for key, pin in (("heartbeat_pin", g.heartbeat_pin), ("power_fail_pin", g.power_fail_pin),
                     ("motor_enable_sense_pin", g.motor_enable_sense_pin)):
        if pin is not None and pin in used:
            issues.append((f"hardware.gpio.{key}", f"a pin not already used (GPIO{pin} is {used[pin]})", pin, ""))
            continue
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
        kind = axc.sensor.kind
        unknown = [i for i in (motor_kind_issue(name, ax.motor), sensor_kind_issue(name, kind)) if i is not None]
        if unknown:
            issues += unknown
            continue
        motor, sensor = MOTORS[ax.motor], SENSORS[kind]
        if motor.own_sensor is not None:        # a stepper's step count: no sensor pins
            sensor = SensorKind(sensor.build)
            issues += _stepdir_issues(pre, ax)
        if motor.drive != axc.drive:
            issues.append((f"{pre}.motor", f"a {'relay' if axc.drive == 'relay' else 'PWM'} drive "
                           f"(profile {caps.name!r} {name} is {axc.drive})", ax.motor, ""))
        need = list(motor.pins) + list(sensor.pins)
        if axc.brake:
            need.append("brake")
        allowed = set(need) | set(motor.optional) | set(motor.fault_inputs) | set(sensor.optional) | set(AXIS_PINS)
        for pin_name in need:
            if pin_name not in ax.pins:
                issues.append((f"{pre}.pins.{pin_name}", f"a BCM pin number (needed by {ax.motor} / "
                               f"{kind})", None, ""))
        for pin_name, pin in ax.pins.items():
            if pin_name not in allowed:
                issues.append((f"{pre}.pins.{pin_name}", "one of " + ", ".join(sorted(allowed)), pin_name,
                               suggest(pin_name, sorted(allowed))))
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
                           suggest(ax.adc, list(_ADC_CHANNELS))))
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
                 else [("lsm303d", 0x1D)]}.get(
                     "as5600" if motor.own_sensor is not None and ax.as5600_check else kind, [])
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
    if g.motor_enable_sense_point not in SENSE_POINTS:
        issues.append(("hardware.gpio.motor_enable_sense_point", "one of " + ", ".join(SENSE_POINTS),
                       g.motor_enable_sense_point, suggest(g.motor_enable_sense_point, list(SENSE_POINTS))))
    if g.motor_enable_timeout_s is not None and g.heartbeat_pin is None:
        issues.append(("hardware.gpio.motor_enable_timeout_s", "a heartbeat_pin for the safety chain to watch",
                       g.motor_enable_timeout_s, ""))
    for name in caps.axes:
        ax = getattr(g, name)
        if ax is None:
            continue
        outputs = _outputs(ax.motor)
        for key in ax.active_low:
            if key not in outputs or key not in ax.pins:
                issues.append((f"hardware.gpio.{name}.active_low", "names of this axis' output pins "
                               f"({', '.join(sorted(k for k in ax.pins if k in outputs))})", key, ""))
    # every pin against every other: the panel's too, and the buses' (I2C1 is GPIO2/3
    # whenever a chip, the FRAM or a panel display sits on it)
    bus_users = bool(i2c) or cfg.panel.lcd is not None or cfg.panel.oled is not None or \
        (cfg.panel.presets is not None and cfg.panel.presets.adc == "ads1115")
    if bus_users:
        for pin, what in ((2, "I2C1 SDA"), (3, "I2C1 SCL")):
            if pin in used:
                issues.append((used[pin], f"a pin not used by the I2C bus (GPIO{pin} is {what})", pin, ""))
            used.setdefault(pin, what)
    p = cfg.panel
    panel = [(f"panel.buttons.{k}", v) for k, v in p.buttons.model_dump().items()] + \
        [(f"panel.leds.{k}", v) for k, v in p.leds.model_dump().items()] + [("panel.beeper", p.beeper)]
    if p.ir is not None:
        panel.append(("panel.ir.gpio_pin", p.ir.gpio_pin))
    for panel_key, panel_pin in panel:
        if panel_pin is not None and panel_pin in used:
            issues.append((panel_key, f"a GPIO not already used (GPIO{panel_pin} is {used[panel_pin]})",
                           panel_pin, ""))
    return issues


#: BCM2711/BCM2835 default pulls at power-on: GPIO0-8 up, 9-27 down (BCM2711 ARM
#: Peripherals, "Alternative Function Assignments", the pull column)
BOOT_HIGH_PINS = frozenset(range(0, 9))


#: pins with a function of their own while the Pi boots, before urc claims them: the HAT
#: ID EEPROM's I2C (ID_SD / ID_SC, which the firmware interrogates at boot: Raspberry
#: Pi 4 reduced schematics, "ID_SD and ID_SC pins"; the HAT design guide reserves them)
#: and the primary UART (TXD / RXD, carrying the boot messages when enable_uart or the
#: serial console is on)
BOOT_FUNCTION_PINS = {0: "ID_SD (the HAT ID EEPROM's I2C data, probed by the firmware at boot)",
                      1: "ID_SC (the HAT ID EEPROM's I2C clock, probed by the firmware at boot)",
                      14: "UART TXD (the boot messages when enable_uart or the serial console is on)",
                      15: "UART RXD (the serial console's input when enable_uart is on)"}


#: the PWM frequencies the BTS7960 current sense is read well at: the filter (10.5 ms)
#: leaves a ripple of duty x (1 - duty) x period / tau, 5 % of the reading at 500 Hz; above
#: some kHz IS spends much of a low duty's on-time settling (Infineon BTS7960 Rev 1.1 §4.4)
BTS7960_SENSE_PWM_HZ = (500.0, 5000.0)


def gpio_warnings(cfg: Config) -> list[str]:
    """What ``urc config check`` warns about in [hardware.gpio] without refusing it: a
    motor, relay or brake output that is high from power-on until urc claims it (or,
    active low, low from power-on), current sensed with no overcurrent trip, and a
    BTS7960's current sensed at a PWM frequency its filter does not suit."""
    g = cfg.hardware.gpio
    if g is None:
        return []
    notes = []
    for name in ("az", "el"):
        ax = getattr(g, name)
        if ax is None:
            continue
        outputs = _outputs(ax.motor)
        for key, pin in sorted(ax.pins.items()):
            if key not in outputs or pin in g.pulled_down:
                continue
            high_at_boot = pin in BOOT_HIGH_PINS
            low_active = _active_low(ax, key)
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
        lo_hz, hi_hz = BTS7960_SENSE_PWM_HZ
        if ax.motor == "bts7960" and ax.current_sense_channel is not None \
                and not lo_hz <= ax.pwm_frequency_hz <= hi_hz:
            notes.append(f"hardware.gpio.{name}.pwm_frequency_hz: {ax.pwm_frequency_hz:g} Hz with BTS7960 "
                         f"current sense: keep it within {lo_hz:g}-{hi_hz:g} Hz (docs/hardware.md, bigras): "
                         "slower, the 10.5 ms IS filter passes the PWM ripple into the reading; faster, "
                         "IS has little of each short on-time to settle in")
        if ax.current_sense_channel is not None and cfg.faults.overcurrent_a == 0 and not g.emulate:
            notes.append(f"hardware.gpio.{name}.current_sense_channel: the motor current is sensed but "
                         "faults.overcurrent_a is 0: no overcurrent trip. Set it (about twice the running "
                         "current, below the stall current)")
    notes += _boot_function_notes(g)
    if g.heartbeat_pin is not None and g.heartbeat_pin in BOOT_HIGH_PINS and g.heartbeat_pin not in g.pulled_down:
        notes.append(f"hardware.gpio.heartbeat_pin: GPIO{g.heartbeat_pin} is pulled high at power-on: that rising "
                     "edge can hold the safety chain's relay in for one timeout while the Pi boots. Use a "
                     "pin from GPIO9-27")
    if g.motor_enable_sense_pin is not None and (g.heartbeat_pin is None or g.motor_enable_timeout_s is None):
        notes.append("hardware.gpio.motor_enable_sense_pin: a read-back with no safety chain declared (heartbeat_pin "
                     "and motor_enable_timeout_s): nothing is tested on it")
    if g.heartbeat_pin is not None and g.motor_enable_timeout_s is not None and g.motor_enable_sense_pin is None:
        notes.append("hardware.gpio.motor_enable_sense_pin: the safety chain is not read back: urc cannot test it "
                     "at start (a stuck enable, a floating trigger or a welded contact goes unseen). Wire the "
                     "relay's auxiliary contact to a free pin (docs/hardware.md, \"Safety chain\")")
    if g.heartbeat_pin is not None and g.motor_enable_timeout_s is None:
        notes.append("hardware.gpio.motor_enable_timeout_s: no safety chain declared: if urc freezes or dies "
                     "nothing but urc stops the motors (docs/hardware.md, \"Safety chain\")")
    return notes


def _boot_function_notes(g: Any) -> list[str]:
    """An output or the heartbeat on a pin that something else drives while the Pi boots
    (:data:`BOOT_FUNCTION_PINS`): whatever its level or pull-down, it toggles before urc
    claims it — a relay chatters, a motor jerks, the heartbeat's edges hold the safety
    chain's relay in."""
    pins: list[tuple[str, int, str]] = []
    for name in ("az", "el"):
        ax = getattr(g, name)
        if ax is not None:
            outputs = _outputs(ax.motor)
            pins += [(f"hardware.gpio.{name}.pins.{k}", p, "the output") for k, p in sorted(ax.pins.items())
                     if k in outputs]
    if g.heartbeat_pin is not None:
        pins.append(("hardware.gpio.heartbeat_pin", g.heartbeat_pin,
                     "the heartbeat (its edges hold the safety chain's relay in)"))
    notes = [warning(key, f"GPIO{pin}", f"{BOOT_FUNCTION_PINS[pin]}: {what} toggles while the Pi boots, "
                     "before urc claims it", "use a free pin from GPIO9-27 (GPIO4-8 with active_low)")
             for key, pin, what in pins if pin in BOOT_FUNCTION_PINS]
    sense = g.motor_enable_sense_pin
    if sense in BOOT_FUNCTION_PINS:
        notes.append(warning("hardware.gpio.motor_enable_sense_pin", f"GPIO{sense}",
                             f"{BOOT_FUNCTION_PINS[sense]}: driven while the Pi boots, against the read-back's "
                             "contact or Q", "use a free pin from GPIO9-27"))
    return notes


def _active_low(ax: Any, key: str) -> bool:
    """A step/dir chip's ENABLE has the chip's polarity (active low on all four), or
    enable_active_low's; any other output active_low's."""
    if ax.motor == "stepdir" and key == "enable":
        if ax.enable_active_low is not None:
            return bool(ax.enable_active_low)
        chip = STEPDIR_CHIPS.get(ax.stepper_driver)
        return chip.enable_active_low if chip is not None else True
    return key in ax.active_low


def _outputs(motor_kind: str) -> set[str]:
    """The output pins an axis with this motor driver may have (a brake's included)."""
    m = MOTORS.get(motor_kind)
    return ({"brake"} | set(m.pins) | set(m.optional)) if m is not None else {"brake"}


def _adc_issues(pre: str, ax: Any, kind: str, used: dict[int, str], spi_vref: dict[int, tuple[str, float]],
                adc_inputs: dict[tuple, str], bus: int) -> list[Issue]:
    """An axis' ADC (its pot and/or its bridge's current sense): inputs that exist, each
    used once per chip (the pots' shared supply input aside), SPI0's pins, one VREF per
    MCP3008."""
    issues: list[Issue] = []
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
        sensing = [k for k, m in MOTORS.items() if m.current_sense]
        if ax.motor not in sensing:
            issues.append((f"{pre}.current_sense_channel", "a bridge with a current-sense output ("
                           + ", ".join(sensing) + ")", ax.motor, ""))
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


def _spi_issues(pre: str, device: int, used: dict[int, str]) -> list[Issue]:
    """SPI0's pins for a chip on chip select ``device``: taken by SPI0 (shared by its
    chips), by nothing else."""
    issues: list[Issue] = []
    for what, pin in [*SPI0_PINS.items(), (f"ce{device}", SPI0_CE[device])]:
        owner = f"SPI0 {what.upper()}"
        if pin in used and used[pin] != owner:
            issues.append((f"{pre}.spi_device", f"SPI0's GPIO{pin} ({owner}) free for the MCP3008 "
                           f"(it is {used[pin]})", device, ""))
        used.setdefault(pin, owner)
    return issues


def _stepdir_issues(pre: str, ax: Any) -> list[Issue]:
    """A step/dir axis: a chip the table knows, a microstep it has, no more microstep
    pins than it has inputs."""
    chip = STEPDIR_CHIPS.get(ax.stepper_driver)
    if chip is None:
        return [one_of(f"{pre}.stepper_driver", list(STEPDIR_CHIPS), ax.stepper_driver)]
    issues: list[Issue] = []
    if ax.microsteps not in chip.microstep_table.values():
        issues.append((f"{pre}.microsteps", f"one the {chip.name} has: "
                       + ", ".join(str(n) for n in sorted(set(chip.microstep_table.values()))), ax.microsteps, ""))
    extra = [k for k in ("ms1", "ms2", "ms3")[len(chip.microstep_pins):] if k in ax.pins]
    for k in extra:
        issues.append((f"{pre}.pins.{k}", f"at most {len(chip.microstep_pins)} microstep pins on the {chip.name} "
                       f"({', '.join(chip.microstep_pins)})", k, ""))
    if ax.as5600_check and ax.i2c_address is not None and ax.i2c_address != 0x36:
        issues.append((f"{pre}.i2c_address", "the AS5600's 0x36 (it has no other)", ax.i2c_address, ""))
    return issues
