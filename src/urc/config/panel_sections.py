"""``[panel]``: the local front panel (urc.frontpanel); its cross-checks are
:mod:`urc.frontpanel.checks` (registered with :mod:`.owners`)."""

from __future__ import annotations

import typing
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from .base import Section, num


class PanelPresets(BaseModel):
    """The preset knobs: each a potentiometer across the ADC's reference (its ends on
    the supply and ground, the wiper on an input), so the reading is a fraction of the
    supply whatever the supply is."""

    model_config = ConfigDict(strict=True, frozen=True, extra="forbid", validate_default=False)

    #: 1: one knob (P1) sets both axes; 2: P1 the azimuth, P2 the elevation
    pots: Literal[1, 2] = 2
    #: "ads1115" (I2C, ``bus`` and ``address``) or "mcp3008" (SPI0, chip select
    #: ``spi_device``; its VREF wired to the knobs' supply)
    adc: Literal["ads1115", "mcp3008"] = "ads1115"
    bus: int = Field(1, ge=0, le=31)
    address: int = Field(0x49, ge=0x48, le=0x4B)
    spi_device: int = Field(1, ge=0, le=1)
    p1_channel: int = Field(0, ge=0, le=7)
    p2_channel: int = Field(1, ge=0, le=7)
    #: the ADS1115 input wired to the knobs' supply (the MCP3008 uses its VREF)
    reference_channel: int = Field(3, ge=0, le=7)


class PanelButtons(Section):
    """GPIO (BCM) numbers of the front-panel push-buttons, wired to ground (pull-up);
    omitted = not fitted."""

    cw: int | None = Field(default=None, ge=0, le=53)
    ccw: int | None = Field(default=None, ge=0, le=53)
    up: int | None = Field(default=None, ge=0, le=53)
    down: int | None = Field(default=None, ge=0, le=53)
    stop: int | None = Field(default=None, ge=0, le=53)
    park: int | None = Field(default=None, ge=0, le=53)
    #: held with a turn button: jog slowly (G4JNT); stores Z in its zero setting
    slow: int | None = Field(default=None, ge=0, le=53)
    #: BIG-RAS SW7 / SW8: turn the azimuth / elevation to the preset knobs' direction;
    #: SW10 held: the display shows that direction ([panel.presets])
    preset_az: int | None = Field(default=None, ge=0, le=53)
    preset_el: int | None = Field(default=None, ge=0, le=53)
    show_preset: int | None = Field(default=None, ge=0, le=53)


class PanelLeds(Section):
    """GPIO (BCM) numbers of the status LEDs (Tartu: one per direction, one for errors)."""

    cw: int | None = Field(default=None, ge=0, le=53)
    ccw: int | None = Field(default=None, ge=0, le=53)
    up: int | None = Field(default=None, ge=0, le=53)
    down: int | None = Field(default=None, ge=0, le=53)
    #: error LED: blink codes (see urc.frontpanel.indicators)
    fault: int | None = Field(default=None, ge=0, le=53)


class PanelLcd(Section):
    """An HD44780 character LCD on a PCF8574 I2C backpack."""

    bus: int = Field(default=1, ge=0, le=31)
    address: int = Field(default=0x27, ge=0x03, le=0x77)
    cols: int = Field(default=20, ge=16, le=20)
    rows: int = Field(default=2, ge=2, le=4)


class PanelOled(Section):
    """An SSD1306 OLED on I2C (Berkeley-style boards)."""

    bus: int = Field(default=1, ge=0, le=31)
    address: int = Field(default=0x3C, ge=0x03, le=0x77)
    width: int = Field(default=128, ge=128, le=128)
    height: int = Field(default=64, ge=32, le=64)
    contrast: int = Field(default=0xCF, ge=0, le=255)


class PanelIr(Section):
    """An IR receiver (kernel gpio-ir) read through the Linux input subsystem."""

    #: e.g. "/dev/input/by-path/platform-ir-receiver@12-event"
    device: str = Field(min_length=1)
    #: the GPIO the receiver is wired to (config.txt ``dtoverlay=gpio-ir,gpio_pin=N``):
    #: the kernel holds it, so urc only checks that no other part is given it too
    gpio_pin: int | None = Field(default=None, ge=0, le=27)
    #: evdev key name -> action (cw ccw up down stop park slow); {} = the default map
    keys: dict[str, str] = Field(default_factory=dict, strict=False)


class PanelSection(Section):
    """The local front panel: buttons, LEDs, beeper, display, IR remote."""

    enabled: bool = False
    #: how the buttons are wired (urc.frontpanel.controls.LAYOUTS): "labelled", each
    #: does its name; "big-ras", the BIG-RAS five-button row named by its two-axis
    #: functions, which changes with elevation off (the far left button turns left)
    layout: Literal["labelled", "big-ras"] = "labelled"
    #: gpiozero's MockFactory instead of real pins (no hardware; tests, a laptop)
    emulate: bool = False
    #: jog speed as a fraction of the axis' top speed; ``slow`` held: slow_speed
    jog_speed: float = num(1.0, gt=0.0, le=1.0)
    slow_speed: float = num(0.2, gt=0.0, le=1.0)
    #: display refreshes per second (off the control loop)
    refresh_hz: float = num(4.0, gt=0.0, le=20.0)
    #: switch debounce
    bounce_s: float = num(0.02, ge=0.0, le=0.5)
    buttons: PanelButtons = PanelButtons()
    leds: PanelLeds = PanelLeds()
    beeper: int | None = Field(default=None, ge=0, le=53)
    #: BIG-RAS "Beeper type": "off" (silent), "dc" (an active beeper: on/off) or the tone
    #: in Hz, 200..5000, for a passive one (driven with PWM at that frequency)
    beeper_type: Literal["off", "dc"] | typing.Annotated[int, Field(ge=200, le=5000)] = "dc"
    #: a short beep whenever a command from a protocol port gives the rotator a new
    #: target (the BIG-RAS beeps on each serial command; off unless asked for)
    beep_on_command: bool = False
    #: BIG-RAS "Backlight", percent: the OLED's brightness; a PCF8574 LCD backpack
    #: switches its backlight only, on above 0
    backlight_pct: int = Field(default=100, ge=0, le=100)
    #: BIG-RAS "Screensaver": the display goes dark this long after the last key (a
    #: button, the IR remote) or fault; 0 = always lit. A key wakes it.
    screensaver_s: float = num(0.0, ge=0.0, le=86400.0)
    #: BIG-RAS "Autoturn": a jog held 5 s goes on after its button is let go, until a
    #: button is pressed again or the axis reaches its end of travel
    autoturn: bool = False
    #: the time on the display's lower rows (BIG-RAS; a 4-row LCD, the OLED always),
    #: from the system clock (NTP), in ``timezone``: "UTC" or an IANA name such as
    #: "Europe/Budapest" (summer time follows by itself, as the BIG-RAS's does)
    clock: bool = False
    timezone: str = Field(default="UTC", min_length=1)
    #: the BIG-RAS preset knobs P1/P2 on an ADC (urc.frontpanel.settings)
    presets: PanelPresets | None = None
    lcd: PanelLcd | None = None
    oled: PanelOled | None = None
    ir: PanelIr | None = None
