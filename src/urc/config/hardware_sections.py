"""``[hardware]``: which backend drives the rotator and that backend's own section
(the simulator, a bridge to an existing controller, parts on a Raspberry Pi's pins).
The checks that need more than one field live beside each backend's builder
(:mod:`urc.hardware.gpio.checks`, :mod:`urc.hardware.bridge.checks`)."""

from __future__ import annotations

from pydantic import Field

from .base import Section, num


class SimSection(Section):
    seed: int = 1
    wind: bool = True
    #: where the simulated antenna starts; None = at the park position.
    start_az_deg: float | None = num(None)
    start_el_deg: float | None = num(None)
    #: model the external safety chain (docs/hardware.md): motor power only while the
    #: heartbeat's rising edges come at most this far apart; None = not modelled
    motor_enable_timeout_s: float | None = num(None, gt=0.0, le=10.0)
    #: where the beam truly points differs from the axes by this pointing error model
    #: (issue 38; urc.pointing.model's terms: {ia_deg = 1.0, tf_deg = 0.5, ...}); the
    #: controller never sees it, a simulated power source ([pointing] source = "sim")
    #: does. None = a perfect mount. Its terms are checked by the hardware's check
    #: (urc.hardware.factory, registered with .owners): urc.config imports no pointing.
    pointing_error: dict[str, float] | None = Field(default=None, strict=False)


class BridgeSection(Section):
    """``backend = "bridge"``: drive a controller the station already owns, as a client."""

    #: gs232a, gs232b, easycomm2, easycomm3, rot2prog, rot1prog, md01 or rotctld
    protocol: str
    #: a serial device, e.g. "/dev/ttyUSB0" (exactly one of serial and tcp)
    serial: str | None = Field(default=None, min_length=1)
    #: None = the protocol's usual rate (GS-232 9600, Rot2Prog 600, Rot1Prog 1200 ...)
    baud: int | None = Field(default=None, ge=50, le=4_000_000)
    #: "host:port": a rotctld, or an Ethernet/WiFi serial adapter
    tcp: str | None = Field(default=None, min_length=1)
    #: an answer missing this long is a failure; None = the protocol's (Hamlib's) timeout
    timeout_s: float | None = num(None, gt=0.0, le=30.0)
    #: poll the position no faster than this; 0 = as fast as the link allows
    poll_interval_s: float = num(0.0, ge=0.0, le=10.0)
    #: bad or missing answers in a row that count as a lost link
    max_failures: int = Field(default=3, ge=1, le=100)
    #: reconnect attempts (back-off up to 5 s) before giving up until restart
    reconnect_attempts: int = Field(default=30, ge=0, le=100_000)
    #: for controllers that ignore a new target while moving: stop first
    stop_before_set: bool = False


class GpioAxis(Section):
    """One axis' parts on the Pi (``[hardware.gpio.az]``); pins are BCM numbers.

    The sensor comes from the profile (encoder, pulse, pot, as5600, magnetometer); the
    pins each motor driver needs: vnh5019 ina inb pwm; lmd18200 pwm dir bridge_brake;
    bts7960 rpwm lpwm; pwm_dir pwm dir; relay cw ccw [fast]; stepdir step dir [enable
    ms1 ms2 ms3] (its step count is the axis' sensor, whatever the profile's). Sensors: encoder enc_a
    enc_b [enc_z]; pulse pulse. Also brake (the brake relay) and limit_min / limit_max.
    """

    motor: str
    pins: dict[str, int] = {}
    pwm_frequency_hz: float = num(1000.0, gt=0.0, le=100000.0)
    #: I2C bus for this axis' chip (None = [hardware.gpio] i2c_bus) and its address
    i2c_bus: int | None = Field(default=None, ge=0, le=31)
    i2c_address: int | None = Field(default=None, ge=0x03, le=0x77)
    #: the chip sits on this channel of the bus's TCA9548A mux (None = on the bus itself)
    i2c_mux_channel: int | None = Field(default=None, ge=0, le=7)
    #: the pot's ADC: ads1115 (I2C, i2c_address or 0x48) or mcp3008 (SPI0, chip select
    #: CE<spi_device>: GPIO8 or GPIO7; SCLK 11, MOSI 10, MISO 9)
    adc: str = "ads1115"
    spi_device: int = Field(default=0, ge=0, le=1)
    #: the motor bridge's current-sense output (VNH5019 CS, BTS7960 IS, LMD18200 sense
    #: resistor) on this input of the axis' ADC (``adc``): the overcurrent fault and the
    #: stall / stuck-sensor verdict then see the motor current; None = not wired
    current_sense_channel: int | None = Field(default=None, ge=-100, le=100)
    #: None = the bridge's own figure (VNH5019 carrier 0.14; IBT-2/BTS7960 with its R_IS
    #: and L_IS tied, 500 Ohm: 500/8500 = 0.0588, docs/hardware.md); the LMD18200 needs it
    #: (377 uA/A into your resistor). Calibrate it with a meter: the BTS7960's k_ILIS
    #: spreads 3000-14000 at 5 A
    current_sense_v_per_a: float | None = num(None, gt=0.0, le=10.0)
    #: output pins (by name: ina, cw, brake, ...) whose load is on when the pin is LOW
    #: (most relay modules); urc then drives them high to keep them off
    active_low: list[str] = []
    #: the pot's input and the input wired to the pot supply (None: ADS1115 input 3; on
    #: an MCP3008 its VREF is the pot supply, so N is read as the G4JNT PIC reads it)
    adc_channel: int = Field(default=0, ge=-100, le=100)
    adc_reference_channel: int | None = Field(default=None, ge=-100, le=100)
    adc_reference_v: float = num(3.3, gt=0.0, le=4.096)
    pot_law: str | None = None
    pot_m: float | None = num(None)
    pot_c: float | None = num(None)
    zero_deg: float = num(0.0)
    #: an AS5600 whose count falls as the axis angle rises (its DIR pin tied to VDD, or
    #: the chip on the other side of the magnet): urc counts it the other way. DIR must be
    #: tied to GND or VDD; left floating, the direction is undefined
    as5600_reversed: bool = False
    #: the compass chip of a magnetometer profile: lsm303d (0x1D) or lsm303agr (0x19 + 0x1E)
    compass: str = "lsm303d"
    declination_deg: float = num(0.0, ge=-180.0, le=180.0)
    #: reversal wait with both relays off; >= 0.05 s: a relay opens 5-15 ms after its coil
    #: goes off, so less can close CW and CCW at once (motors.RELAY_MIN_DEAD_TIME_S)
    relay_dead_time_s: float = num(0.5, ge=0.05, le=10.0)
    #: False (default): normally-closed limit switches to ground, the pin pulled up: it
    #: reads high (active) when the switch opens OR its wire breaks. True: normally-open
    #: switches closing to ground (a broken wire never shows a limit)
    limit_active_low: bool = False
    #: a limit input's level counts once it has held this long (contact bounce, pickup)
    limit_debounce_s: float = num(0.02, ge=0.0, le=1.0)
    #: a pulse (SPID reed) closer than this to the last one is bounce, not a pulse
    pulse_debounce_s: float = num(0.005, ge=0.0, le=1.0)
    #: an encoder's x4 counts per axis degree; None = the profile's (1 / resolution)
    encoder_counts_per_deg: float | None = num(None, gt=0.0, le=100000.0)
    #: relay motor without a fast relay: the slow speed pulses the direction relay at
    #: this rate (the G4JNT controller's 2 Hz)
    relay_pulse_hz: float = num(2.0, gt=0.0, le=20.0)
    #: the encoder's index (Z, pin enc_z): the axis angle of an index pulse (found at
    #: commissioning) and the axis degrees between two (360 / turns of the encoder shaft
    #: per axis turn); each pulse re-references the count. None = Z not used
    encoder_index_deg: float | None = num(None)
    encoder_index_period_deg: float = num(360.0, gt=0.0, le=360.0)
    #: counts an encoder may move with its motor off before that is a fault; None = no check
    encoder_drift_counts: int | None = Field(default=20, ge=1)
    #: motor = "stepdir": the driver chip (a4988, drv8825, tmc2208, tmc2209: its timing and
    #: microstep table, urc.hardware.gpio.stepdir), the microstep it is set to (by pins
    #: ms1..ms3 when wired, in the chip's order: DRV8825 MODE0..2; else by the board's
    #: jumpers), and the steps per axis degree (None = the profile's step, 1 / resolution)
    stepper_driver: str = "a4988"
    microsteps: int = Field(default=8, ge=1, le=256)
    steps_per_deg: float | None = num(None, gt=0.0, le=100000.0)
    #: the enable input's level that turns the outputs on: None = the chip's (all four:
    #: low); True/False to override (a board with an inverter)
    enable_active_low: bool | None = None
    #: DIR low turns the axis the way its angle grows (the motor wired the other way)
    dir_reversed: bool = False
    #: an AS5600 on the axis (i2c_bus / i2c_address / i2c_mux_channel) checks the step
    #: count: lost steps become a fault instead of an unseen error
    as5600_check: bool = False


class GpioSection(Section):
    """``backend = "gpio"``: parts on a Raspberry Pi's pins and buses."""

    #: run the real drivers on pins and chips emulated from the simulator
    emulate: bool = False
    i2c_bus: int = Field(default=1, ge=0, le=31)
    #: motor PWM on the PWM peripheral where a pin has it: "2chan" (Pi 3/4/Zero 2 W: PWM0 on
    #: GPIO12 or 18, PWM1 on 13 or 19), "4chan" (Pi 5: 12, 13, 18, 19), "off" (all software)
    hardware_pwm: str = "2chan"
    #: the sysfs pwmchip of the PWM peripheral; None = found at start (Pi 4: 0; Pi 5:
    #: 2 before kernel 6.12, 0 after; a 4-channel chip means a Pi 5: its own pin table)
    pwm_chip: int | None = Field(default=None, ge=0, le=31)
    #: the TCA9548A's address (A2..A0 straps) on any bus an axis uses i2c_mux_channel on
    i2c_mux_address: int = Field(default=0x70, ge=0x70, le=0x77)
    heartbeat_pin: int | None = Field(default=None, ge=0, le=27)
    #: the external safety chain on heartbeat_pin (docs/hardware.md "Safety chain"): its
    #: monostable's timeout. Emulated, the part is modelled with it; on iron it is what
    #: `urc hw check` states. None = no such part wired
    motor_enable_timeout_s: float | None = num(None, gt=0.0, le=10.0)
    #: the safety chain's read-back input (docs/hardware.md "Safety chain"): the start-up
    #: self-test and `urc hw check` measure the chain on it. None = not wired
    motor_enable_sense_pin: int | None = Field(default=None, ge=0, le=27)
    #: what it reads: "contact" (a force-guided relay's auxiliary contact) or "q" (the
    #: monostable's output; blind to a shorted Q1 and a welded contact)
    motor_enable_sense_point: str = "contact"
    #: the pin reads low while the motors have power (an optocoupler, a normally-open
    #: contact to GND); False: high while they have power (Q, a normally-closed contact)
    motor_enable_sense_active_low: bool = False
    power_fail_pin: int | None = Field(default=None, ge=0, le=27)
    #: output pins fitted with an external pull-down (GPIO0-8 are pulled up from power-on
    #: until urc claims them: a motor, relay or brake output there needs one)
    pulled_down: list[int] = []
    #: keep the state in an I2C FRAM (MB85RC256V class, on i2c_bus) instead of a file
    fram_address: int | None = Field(default=None, ge=0x03, le=0x77)
    az: GpioAxis | None = None
    el: GpioAxis | None = None


class HardwareSection(Section):
    backend: str = "sim"
    sim: SimSection = SimSection()
    bridge: BridgeSection | None = None
    gpio: GpioSection | None = None

