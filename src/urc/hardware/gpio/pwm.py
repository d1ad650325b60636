"""Which motor PWM outputs get the Pi's hardware PWM, and the hardware PWM part.

lgpio (gpiozero's pin factory on a Pi) makes PWM in software on any pin: its edges
jitter when the CPU is busy. The PWM peripheral is steady whatever the load, but only
on GPIO12/13/18/19 and only as many outputs as it has channels: two on a Pi 3/4/Zero 2 W
(PWM0 on GPIO12 or 18, PWM1 on GPIO13 or 19: two pins of one channel carry the same
duty, so one pin per channel), four on a Pi 5 (GPIO12, 13, 18, 19 each their own). The
kernel exposes it through /sys/class/pwm once the overlay is loaded
(``dtoverlay=pwm-2chan,pin=12,func=4,pin2=13,func2=4`` in /boot/firmware/config.txt);
rpi-hardware-pwm
(urc's ``[pi]`` extra) drives that.

Which ``pwmchipN`` that is differs: 0 on a Pi 4; on a Pi 5 the RP1's PWM0 is pwmchip2
before kernel 6.12 and pwmchip0 after (rpi-hardware-pwm's notes), and its channels map
GPIO12/13/18/19 to 0/1/2/3 whatever overlay is loaded: :func:`detect_pwm_chip`.

rpi-hardware-pwm 0.3.1 exports the channel, waits until its period, duty_cycle and
enable files are writable (udev gives the gpio group its rights only after the export;
0.3.0 wrote the period at once and could fail on a first start: hence >= 0.3.1) and
writes its period and a duty of 0, but
leaves ``enable`` as it found it: a channel a killed urc left enabled stays enabled, and
its period write fails (EINVAL) when the duty it left is longer than the new period.
:class:`HardwarePwm` therefore first writes duty 0 and enable 0 straight to sysfs
(:func:`sysfs_pwm_off`), disables it again through the library (``stop``), enables it
only for the first non-zero duty, and disables it again at close.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from ...errors import ConfigError
from .kinds import MOTORS

log = logging.getLogger(__name__)

#: ``[hardware.gpio] hardware_pwm`` -> {BCM pin: PWM channel}
HARDWARE_PWM = {"2chan": {12: 0, 18: 0, 13: 1, 19: 1},
                "4chan": {12: 0, 13: 1, 18: 2, 19: 3},
                "off": {}}
#: the kernel's PWM class (read at call time by the builder, the takeover and the checks:
#: tests point it at a tree of their own)
SYS_PWM = Path("/sys/class/pwm")
#: lgpio's software PWM (tx_pwm) frequency limit
SOFTWARE_PWM_MAX_HZ = 10_000.0


#: the PWM peripheral's platform device, by model (the pwmchip's ``device`` link)
PWM_DEVICES = {"1f00098000.pwm": "pi5", "fe20c000.pwm": "pi4", "7e20c000.pwm": "pi4", "20c000.pwm": "pi4"}


def detect_pwm_chip(gpio: Any, sys_pwm: Path | None = None) -> tuple[int, str | None]:
    """``(pwmchip number, pin table name or None = as configured)``: ``pwm_chip`` if
    set; else the pwmchip whose device is the Pi's PWM peripheral (a Pi 5's RP1 PWM0:
    its own 4-channel table, whatever ``hardware_pwm`` says); 0 when none is found."""
    if gpio.hardware_pwm == "off":
        return 0, None
    sys_pwm = SYS_PWM if sys_pwm is None else sys_pwm
    found: list[tuple[int, str]] = []
    try:
        # by the PWM peripheral's base address only: the RP1's PWM1 (the fan's,
        # 1f0009c000.pwm) also has 4 channels and is numbered first before 6.12; in
        # number order (a text sort puts pwmchip10 before pwmchip2)
        for number, chip in sorted((int(c.name[len("pwmchip"):]), c) for c in sys_pwm.glob("pwmchip*")
                                   if c.name[len("pwmchip"):].isdigit()):
            dev = (chip / "device").resolve().name
            model = next((m for d, m in PWM_DEVICES.items() if dev.endswith(d)), None)
            if model is not None:
                found.append((number, model))
    except OSError:
        found = []
    if gpio.pwm_chip is not None:
        model = next((m for n, m in found if n == gpio.pwm_chip), None)
        return gpio.pwm_chip, "4chan" if model == "pi5" else None
    if not found:
        return 0, None
    number, model = found[0]
    if model == "pi5" and gpio.hardware_pwm != "4chan":
        log.warning("hardware_pwm = %r, but this is a Pi 5 (pwmchip%d, the RP1's PWM0): its channels "
                    "are GPIO12/13/18/19 -> 0/1/2/3 (hardware_pwm = \"4chan\")", gpio.hardware_pwm, number)
    return number, "4chan" if model == "pi5" else None


def pwm_plan(gpio: Any, table_name: str | None = None) -> dict[str, tuple[int, int | None]]:
    """``"az.pwm" -> (pin, hardware channel or None)`` for every motor PWM output, az
    first: a pin gets its channel if no earlier output took it. ``table_name``
    overrides ``hardware_pwm`` (a detected Pi 5)."""
    table = HARDWARE_PWM.get(table_name or gpio.hardware_pwm, {})
    taken: set[int] = set()
    plan: dict[str, tuple[int, int | None]] = {}
    for name in ("az", "el"):
        ax = getattr(gpio, name)
        if ax is None:
            continue
        kind = MOTORS.get(ax.motor)
        for key in kind.pwm_pins if kind is not None else ():
            pin = ax.pins.get(key)
            if pin is None:
                continue
            ch = table.get(pin)
            if ch is not None and ch in taken:
                ch = None
            if ch is not None:
                taken.add(ch)
            plan[f"{name}.{key}"] = (pin, ch)
    return plan


def pwm_advice(gpio: Any, table_name: str | None = None) -> list[str]:
    """Warnings about motor PWM in software (config check, the start log), on the pin
    table ``table_name`` (the detected one: :func:`detect_pwm_chip`) or ``hardware_pwm``'s."""
    if gpio is None or gpio.hardware_pwm == "off":
        return []
    table = HARDWARE_PWM[table_name or gpio.hardware_pwm]
    pins = ", ".join(f"GPIO{p}" for p in sorted(table))
    notes = []
    plan = pwm_plan(gpio, table_name)
    for where, (pin, ch) in plan.items():
        if ch is not None:
            continue
        axis, key = where.split(".")
        at = f"hardware.gpio.{axis}.pins.{key}"
        hz = getattr(gpio, axis).pwm_frequency_hz
        if hz > SOFTWARE_PWM_MAX_HZ:
            notes.append(f"hardware.gpio.{axis}.pwm_frequency_hz: {hz:g} Hz, but GPIO{pin} runs software PWM, "
                         f"which lgpio makes at {SOFTWARE_PWM_MAX_HZ:g} Hz at most")
        if pin in table:
            other = next(w for w, (p, c) in plan.items() if c == table[pin])
            notes.append(f"{at}: GPIO{pin} shares PWM{table[pin]} with {other} (GPIO{plan[other][0]}), so it "
                         "runs software PWM (one pin per channel on a Pi 3/4; hardware_pwm = \"4chan\" on a Pi 5)")
        else:
            notes.append(f"{at}: GPIO{pin} has no hardware PWM; software PWM jitters under CPU load "
                         f"(hardware PWM pins: {pins})")
    return notes


def sysfs_pwm_off(chip: int, channel: int, sys_pwm: Path = Path("/sys/class/pwm")) -> bool:
    """Duty 0, then disabled, written straight to the channel's sysfs files (where it is
    exported; returns whether it was). No period write: rpi-hardware-pwm writes the
    period before the duty, and a duty a dead urc left longer than the new period makes
    that write fail (EINVAL), leaving the channel enabled at the dead duty."""
    ch = sys_pwm / f"pwmchip{chip}" / f"pwm{channel}"
    if not ch.is_dir():
        return False
    for name in ("duty_cycle", "enable"):
        try:
            (ch / name).write_text("0")
        except OSError as exc:
            log.warning("pwmchip%d/pwm%d: could not write %s 0: %s", chip, channel, name, exc)
    return True


class HardwarePwm:
    """A motor PWM output on the PWM peripheral (rpi-hardware-pwm over sysfs); duty in
    [0, 1] like :class:`.pins.PinPwm`."""

    def __init__(self, pin: int, channel: int, *, frequency_hz: float, pwm_class: Any = None,
                 chip: int = 0, sys_pwm: Path = Path("/sys/class/pwm")):
        if pwm_class is None:
            from rpi_hardware_pwm import HardwarePWM as pwm_class
        self.pin, self.channel, self.frequency_hz, self.chip = pin, channel, frequency_hz, chip
        sysfs_pwm_off(chip, channel, sys_pwm)   # before the library's period write
        self.pwm = pwm_class(pwm_channel=channel, hz=frequency_hz, chip=chip)
        self.duty = 0.0
        #: False after force_duty: ``duty`` may not be what the channel has (a write from
        #: another thread may have come between), so the next write_duty writes whatever
        self._duty_known = True
        #: set by close: the channel is never enabled again
        self.closed = False
        self.enabled = True            # not known: a dead urc may have left it running
        self.pwm.stop()                # duty 0, then disabled
        self.enabled = False

    def write_duty(self, duty: float) -> None:
        duty = min(1.0, max(0.0, float(duty)))
        if self.closed:
            return                     # disabled for good: the pin idles low
        if duty != self.duty or not self._duty_known:   # a sysfs write per change, not per tick
            # known before the write: a force_duty that comes between then leaves it unknown
            self._duty_known = True
            self._write(duty)
            if self.closed:            # closed meanwhile from another thread: off again
                self._off()

    def force_duty(self, duty: float) -> None:
        """``duty`` written whatever :attr:`duty` says (``Hardware.drive_safe``, from
        another thread than the tick's). The sysfs writes release the GIL, so a tick's
        write can land between this write and its bookkeeping: the remembered duty is
        left unknown, and the next :meth:`write_duty` writes."""
        duty = min(1.0, max(0.0, float(duty)))
        if self.closed:
            self._off()
            return
        self._write(duty)
        self._duty_known = False
        if self.closed:
            self._off()

    def _write(self, duty: float) -> None:
        if duty > 0.0 and not self.enabled:
            self.pwm.start(duty * 100.0)
            self.enabled = True
        else:
            self.pwm.change_duty_cycle(duty * 100.0)
        self.duty = duty

    def read_back(self) -> float:
        return self.duty

    def identify(self) -> str:
        return f"GPIO{self.pin}: hardware PWM{self.channel} (pwmchip{self.chip}) at {self.frequency_hz:g} Hz"

    def stop(self) -> None:
        self.close()

    def close(self) -> None:
        """Duty 0 and the channel disabled (the pin idles low), for good: a later
        write_duty (a hung tick resuming at exit) is refused, never restarts it."""
        self.closed = True             # first: a write_duty under way sees it after its write
        self._off()

    def _off(self) -> None:
        self.pwm.stop()
        self.enabled = False
        self.duty = 0.0


#: where the firmware reads config.txt on Raspberry Pi OS bookworm (before: /boot/config.txt)
CONFIG_TXT = "/boot/firmware/config.txt"


def overlay_advice(pin: int, heartbeat_pin: int | None = None) -> str:
    """How to route ``pin`` to PWM, never through the pwm-2chan default (GPIO18/19) when
    one of those is the heartbeat: routing GPIO18 to PWM would take the heartbeat pin."""
    if pin in (12, 13):
        return f"route it in {CONFIG_TXT}: dtoverlay=pwm-2chan,pin=12,func=4,pin2=13,func2=4 (docs/hardware.md)"
    if pin in (18, 19) and heartbeat_pin in (18, 19):
        return (f"GPIO{heartbeat_pin} is the heartbeat, so do not route GPIO18/19 to PWM (no pwm-2chan with "
                "its default pins): put this output on GPIO12/13 for hardware PWM")
    if pin in (18, 19):
        return (f"route it in {CONFIG_TXT}: dtoverlay=pwm-2chan,pin=18,func=2,pin2=19,func2=2 on a Pi 3/4 "
                "(docs/hardware.md for a Pi 5)")
    return "hardware PWM exists on GPIO12, 13, 18 and 19 only"


class PwmChannelLevel:
    """A hardware PWM channel held at a plain level through sysfs (the takeover): low is
    duty 0 and disabled (the pin idles low), high is duty = period and enabled. The pin
    stays routed to PWM: it is never claimed as a GPIO line (:mod:`.pinmux`)."""

    def __init__(self, pin: int, chip: int, channel: int, *, frequency_hz: float,
                 sys_pwm: Path = Path("/sys/class/pwm")):
        self.pin, self.chip, self.channel, self.frequency_hz = pin, chip, channel, frequency_hz
        self.dir = sys_pwm / f"pwmchip{chip}" / f"pwm{channel}"
        self.chip_dir = sys_pwm / f"pwmchip{chip}"

    def write(self, level: bool) -> None:
        """Raises OSError when the level could not be set."""
        if not level:
            if self.dir.is_dir():          # (not exported: disabled since boot)
                (self.dir / "duty_cycle").write_text("0")
                (self.dir / "enable").write_text("0")
            return
        if not self.dir.is_dir():
            (self.chip_dir / "export").write_text(str(self.channel))
        period_ns = int((self.dir / "period").read_text().strip() or 0)
        if period_ns <= 0:
            period_ns = round(1e9 / self.frequency_hz)
            (self.dir / "period").write_text(str(period_ns))
        (self.dir / "duty_cycle").write_text(str(period_ns))
        (self.dir / "enable").write_text("1")

    def read_back(self) -> bool:
        try:
            enabled = (self.dir / "enable").read_text().strip() == "1"
            duty, period = (int((self.dir / n).read_text().strip()) for n in ("duty_cycle", "period"))
        except (OSError, ValueError):
            return False
        return enabled and period > 0 and duty >= period

    def __repr__(self) -> str:
        return f"GPIO{self.pin} on PWM{self.channel} (pwmchip{self.chip})"


def routed_to_pwm(functions: Any, pin: int, channel: int, chip: int,
                  sys_pwm: Path = Path("/sys/class/pwm")) -> bool:
    """Whether ``pin`` may be routed to PWM ``channel`` (so it must not be claimed as a
    GPIO line): what ``functions`` (:func:`.pinmux.pin_functions`) says; when it cannot
    tell, True while the PWM chip exists (an overlay loaded may have routed it)."""
    from .pinmux import pwm_channel_of
    fn = functions.function(pin) if functions is not None else None
    if fn is not None:
        return pwm_channel_of(fn) == channel
    return (sys_pwm / f"pwmchip{chip}").is_dir()


def make_pwm(factory: Any, pin: int, channel: int | None, frequency_hz: float, *, emulated: bool,
             pwm_class: Any = None, chip: int = 0, functions: Any = None,
             sys_pwm: Path = Path("/sys/class/pwm"), heartbeat_pin: int | None = None) -> Any:
    """The PWM part for a motor output: hardware PWM where the plan gives the pin a
    channel (on iron; emulated, every PWM is a mock pin), else lgpio's software PWM.

    lgpio's software PWM claims the pin as a GPIO line, which takes it off the PWM
    peripheral until the next boot (:mod:`.pinmux`). So: a pin the plan gives a channel
    but the overlay did not route to it (``functions`` says so) runs software PWM (it
    is a GPIO already); a hardware PWM that cannot be opened falls back to software PWM
    only when no PWM chip exists (no overlay: nothing routed the pin); a pin routed to
    PWM whose channel cannot be opened (no write access to sysfs) is refused with a
    ConfigError, never claimed."""
    from .pins import PinPwm

    if channel is None or emulated:
        return PinPwm(factory, pin, frequency_hz=frequency_hz)
    fn = functions.function(pin) if functions is not None else None
    if not routed_to_pwm(functions, pin, channel, chip, sys_pwm):
        if fn is not None:
            log.warning("GPIO%d is not routed to PWM%d (pinctrl: %s): software PWM instead; %s", pin, channel,
                        fn, overlay_advice(pin, heartbeat_pin))
            return PinPwm(factory, pin, frequency_hz=frequency_hz)
    try:
        return HardwarePwm(pin, channel, frequency_hz=frequency_hz, pwm_class=pwm_class, chip=chip,
                           sys_pwm=sys_pwm)
    except Exception as exc:  # rpi-hardware-pwm raises its own exception, or OSError
        if routed_to_pwm(functions, pin, channel, chip, sys_pwm):
            raise ConfigError(
                f"GPIO{pin}: hardware PWM{channel} (pwmchip{chip}) cannot be opened ({exc}), and the pin "
                "is routed to PWM: urc will not claim it as a plain GPIO (software PWM), which would take "
                "it off the PWM peripheral until the next reboot. Give urc write access to "
                "/sys/class/pwm (docs/hardware.md), or set hardware_pwm = \"off\" and remove the PWM "
                "overlay", key="hardware.gpio.hardware_pwm", expected="a PWM channel urc can open",
                found=f"pwmchip{chip}/pwm{channel}: {exc}") from exc
        # (not the library's own advice: it names /boot/config.txt and the overlay's default pins)
        why = f"no {sys_pwm}/pwmchip{chip}: no PWM overlay loaded" \
            if not (sys_pwm / f"pwmchip{chip}").is_dir() else str(exc)
        log.warning("GPIO%d: hardware PWM%d unavailable (%s): software PWM instead; %s", pin, channel, why,
                    overlay_advice(pin, heartbeat_pin))
    return PinPwm(factory, pin, frequency_hz=frequency_hz)
