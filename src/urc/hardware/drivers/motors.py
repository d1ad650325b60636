"""Motor drivers: H-bridges and relay drives on digital/PWM output parts.

Each implements :class:`urc.hardware.interfaces.Motor` (``set_drive(duty)`` in [-1, 1],
``read_current_a``). They also remember the direction of the last non-zero drive: a
SPID pulse counter has no direction channel and takes it from the drive
(:class:`DirectionTracker`).

Every driver puts its outputs in the safe state (motor off, H-bridge braking) when it
is built, before anything else can drive them.

Two threads write the same driver: the control tick (``set_drive``) and whoever calls
``Hardware.drive_safe`` without the rotator's lock (the tick watch, the power-fail
callback, a shutdown past a hung tick). Each driver's ``_lock`` is held over its check,
pin writes and state update, so neither sees the other's half-written pins; it is never
held over a current-sense read or ``driver_fault`` (a bus read can hang). ``force_safe``
(what ``drive_safe`` calls) does not wait for a holder that is stuck: it writes the whole
safe pattern anyway, past every cache, and leaves the driver's remembered state unknown
so that the next drive writes every pin again. After ``close`` a driver refuses to drive.

(Just over 600 lines on purpose: the four H-bridges and the relay drive share that one
lock protocol, its helpers and the base class; a module per chip would split the
protocol from the code it guards.)
"""

from __future__ import annotations

import logging
import math
import threading
from contextlib import contextmanager
from typing import Callable, Iterator, Sequence

from ...clock import Clock
from ...errors import ConfigError, HardwareError
from ..parts import CurrentSense, DigitalIn, DigitalOut, PwmOut, VoltageIn
from .bts7960_sense import V_PER_A as BTS7960_V_PER_A

log = logging.getLogger(__name__)

#: current-sense volts per motor ampere, per bridge as its datasheet and board give it:
#: VNH5019: K = I_OUT/I_SENSE typ. 7000 (ST VNH5019A-E datasheet, electrical
#: characteristics, current sense) into the Pololu carrier's 1 kOhm-class CS resistor:
#: 140 mV/A as Pololu states; BTS7960: k_ILIS typ. 8500 (Infineon BTS7960 datasheet
#: 4.4.6) into the IBT-2's two 1 kOhm IS resistors, the pins tied: 500/8500 = 0.0588 V/A
#: (:mod:`.bts7960_sense`). LMD18200: 377 uA/A (TI LMD18200 datasheet, "current sense
#: output") into a resistor of your choosing: no default, set it.
SENSE_V_PER_A = {"vnh5019": 0.14, "bts7960": BTS7960_V_PER_A}

#: TI LMD18200 datasheet, Table 1 "Logic Truth Table": (PWM, DIR, BRAKE) -> outputs on.
#: PWM high with BRAKE high shorts the winding through two switches (brake); PWM low
#: with BRAKE high turns every switch off (coast); BRAKE low: drive (PWM low = both
#: sources on, i.e. braking in the PWM off-time).
LMD18200_TRUTH_TABLE = {
    (1, 1, 0): "source1 sink2",      # forward
    (1, 0, 0): "sink1 source2",      # reverse
    (0, 1, 0): "source1 source2",    # PWM off-time: braked through the high sides
    (0, 0, 0): "source1 source2",
    (1, 1, 1): "source1 source2",    # brake
    (1, 0, 1): "sink1 sink2",        # brake
    (0, 1, 1): "none",               # coast
    (0, 0, 1): "none",
}


def lmd18200_state(pwm_high: bool, dir_high: bool, brake_high: bool) -> str:
    """``"forward"``, ``"reverse"``, ``"brake"`` or ``"coast"`` from the truth table."""
    on = LMD18200_TRUTH_TABLE[(int(pwm_high), int(dir_high), int(brake_high))]
    if on == "none":
        return "coast"
    if on in ("source1 source2", "sink1 sink2"):
        return "brake"
    return "forward" if on == "source1 sink2" else "reverse"


#: ST VNH5019A-E datasheet (Rev 7) §2.4, "Truth table in normal operating conditions":
#: (INA, INB) -> outputs (EN/DIAGA = EN/DIAGB = 1). Both high: brake to VCC (the high
#: sides, whatever PWM does); both low: brake to GND through the low sides — but "in all
#: cases, a '0' on the PWM pin turns off both LSA and LSB switches", so brake to GND
#: needs PWM high: INA = INB = 0 with PWM low has every switch off (the motor coasts).
#: A fault (overtemperature, short, undervoltage...) pulls EN/DIAG low ("Truth table in
#: fault conditions").
VNH5019_TRUTH_TABLE = {(1, 0): "forward", (0, 1): "reverse", (1, 1): "brake to VCC", (0, 0): "brake to GND"}


def vnh5019_state(ina: bool, inb: bool, pwm_high: bool) -> str:
    """``"forward"``, ``"reverse"``, ``"brake"`` or ``"coast"`` (§2.4: PWM low turns
    both low sides off; INA = INB = 0 then leaves every switch off)."""
    row = VNH5019_TRUTH_TABLE[(int(ina), int(inb))]
    if row == "brake to GND" and not pwm_high:
        return "coast"
    return row if row in ("forward", "reverse") else "brake"


#: how long ``force_safe`` and ``close`` wait for a driver another thread holds: a
#: tick's writes take microseconds, so a holder still there after this is stuck mid-write
#: (SIGSTOP, a hung call) and the outputs go safe without it
FORCE_WAIT_S = 0.01


@contextmanager
def forcing(lock: threading.Lock, what: str) -> Iterator[bool]:
    """``lock`` for a write that must happen whatever another thread is doing
    (``force_safe``, ``close``): held if it comes within :data:`FORCE_WAIT_S`, else the
    body runs without it (logged). Yields whether it is held."""
    got = lock.acquire(timeout=FORCE_WAIT_S)
    if not got:
        log.warning("%s: written without the driver's lock (another thread has held it for over %.0f ms: "
                    "stuck mid-write?)", what, FORCE_WAIT_S * 1e3)
    try:
        yield got
    finally:
        if got:
            lock.release()


def force_duty(pwm: PwmOut, duty: float) -> None:
    """``duty`` written whatever the part remembers (a hardware PWM skips a duty it
    thinks it has: :meth:`..gpio.pwm.HardwarePwm.force_duty`)."""
    getattr(pwm, "force_duty", pwm.write_duty)(duty)


def stop_pwm(pwm: PwmOut) -> None:
    """Duty 0 and the PWM stopped (``stop`` where the part has it: lgpio's software PWM
    thread ended, a hardware channel disabled), so the pin sits low, not mid-period."""
    stop = getattr(pwm, "stop", None)
    if stop is not None:
        stop()
    else:
        pwm.write_duty(0.0)


def clamp_duty(duty: float, name: str) -> float:
    duty = float(duty)
    if not math.isfinite(duty):
        raise HardwareError(f"{name} motor: drive must be finite, got {duty!r}")
    return -1.0 if duty < -1.0 else 1.0 if duty > 1.0 else duty


def quantise_relay(duty: float, levels: tuple[float, ...]) -> float:
    """|duty| -> nearest relay level (0 below half the smallest level), sign kept."""
    mag = abs(duty)
    if not levels or mag < min(levels) / 2.0:
        return 0.0
    best = min(levels, key=lambda lv: (abs(lv - mag), -lv))
    return math.copysign(best, duty)


class SenseCurrent:
    """A bridge's current-sense output on an ADC input: amperes = volts / ``v_per_a``
    (:data:`SENSE_V_PER_A`; the output gives the magnitude, not the sign). The
    BTS7960's IS, which senses only during the PWM on-time and carries a fault signal,
    has its own reader (:class:`.bts7960_sense.Bts7960Sense`)."""

    def __init__(self, volts: VoltageIn, v_per_a: float):
        self.volts, self.v_per_a = volts, float(v_per_a)

    def read_current_a(self) -> float:
        return self.volts.read_volts() / self.v_per_a


class DirectionTracker:
    """The sign of the last non-zero drive, and listeners told just before it flips
    (a pulse counter folds the pulses counted so far into the old direction)."""

    def __init__(self) -> None:
        self.direction = 1
        #: how many non-zero drives were given (a sensor can tell the motor ran
        #: between two of its reads even if it is off at both)
        self.drives = 0
        self._listeners: list[Callable[[int], None]] = []

    def add_direction_listener(self, fn: Callable[[int], None]) -> None:
        self._listeners.append(fn)

    def _track(self, duty: float) -> None:
        if duty == 0.0:
            return
        self.drives += 1
        new = 1 if duty > 0 else -1
        if new != self.direction:
            for fn in self._listeners:
                fn(self.direction)
            self.direction = new


class HBridgeMotor(DirectionTracker):
    """Common part of the PWM H-bridges: clamp, track direction, current sense."""

    def __init__(self, name: str, current: CurrentSense | None = None, fault_in: DigitalIn | None = None):
        super().__init__()
        self.name = name
        self.duty = 0.0
        self._current = current
        #: the bridge's fault output where wired (active low: VNH5019 EN/DIAG,
        #: LMD18200 thermal flag)
        self.fault_in = fault_in
        #: held over check + pin writes + state update (see the module's docstring)
        self._lock = threading.Lock()
        #: set by :meth:`close`: every later drive is refused
        self.closed = False
        self._refused = False

    def set_drive(self, duty: float) -> None:
        duty = clamp_duty(duty, self.name)
        self._track(duty)
        with self._lock:
            if self.closed:
                refuse_closed(self, duty)
                return
            self.duty = duty
            self._apply(duty)
            if self.closed:      # closed meanwhile by a thread that could not wait for this one
                self._write_closed()

    def force_safe(self) -> None:
        """Motor off from any thread (``Hardware.drive_safe``): the full safe pattern,
        whatever the driver remembers and whether or not its lock came; then what it
        remembers is unknown, so the next drive writes every pin."""
        with forcing(self._lock, f"{self.name} motor off"):
            self.duty = 0.0
            if self.closed:
                self._write_closed()
            else:
                self._write_safe()

    def close(self) -> None:
        """At exit: the outputs held safe for after the process (the PWM stopped: lgpio's
        software PWM thread ends with it, a disabled hardware channel idles low), and
        every later drive refused (a hung tick that resumes must not drive a line that
        keeps its level after the process ends, ``persist_gpio_outputs``)."""
        with forcing(self._lock, f"{self.name} motor close"):
            self.closed = True   # first: a writer that could not be waited for undoes its writes
            self.duty = 0.0
            self._write_closed()

    def _apply(self, duty: float) -> None:
        raise NotImplementedError

    def _write_safe(self) -> None:
        """The off pattern, every pin written (:meth:`force_safe`)."""
        raise NotImplementedError

    def _write_closed(self) -> None:
        """What :meth:`close` leaves: the off pattern, the PWM outputs stopped."""
        self._write_safe()
        for pwm in self._pwms():
            stop_pwm(pwm)

    def _pwms(self) -> tuple[PwmOut, ...]:
        raise NotImplementedError

    def read_current_a(self) -> float:
        return float(self._current.read_current_a()) if self._current is not None else 0.0

    #: what the fault input going low means (subclasses)
    FAULT_TEXT = "fault output low"

    def driver_fault(self) -> str | None:
        """Why the bridge says it is faulted (its fault pin low, its current-sense fault
        signal), None when it does not or nothing of it is wired."""
        if self.fault_in is not None and not self.fault_in.read():
            return f"{self.name} motor: {type(self).__name__[:-5].upper()} {self.FAULT_TEXT}"
        sense_fault = getattr(self._current, "fault", None)
        return f"{self.name} motor: {sense_fault}" if sense_fault else None


def refuse_closed(motor: HBridgeMotor | RelayMotor, duty: float) -> None:
    if duty != 0.0 and not motor._refused:
        motor._refused = True    # (said once)
        log.warning("%s motor: drive %+.2f refused: the driver is closed (the process is ending)",
                    motor.name, duty)


class Vnh5019Motor(HBridgeMotor):
    """VNH5019 (Tartu board): INA/INB set the direction, PWM the speed, CS the current.

    :data:`VNH5019_TRUTH_TABLE`: INA=1 INB=0 forward, INA=0 INB=1 reverse. Off is
    INA = INB = 0 with PWM at 100 %: brake to GND (both low sides on; with PWM low they
    would be off too and the motor would coast). The direction pins change only with
    PWM at 0 (a moment of coast, never of drive), so the bridge never sees a reversal
    under drive. ``diag``: EN/DIAG (carrier pull-up to logic supply), pulled low by the
    chip on a fault.
    """

    FAULT_TEXT = "EN/DIAG pulled low: the bridge shut down (overtemperature, short circuit or undervoltage)"

    def __init__(self, name: str, ina: DigitalOut, inb: DigitalOut, pwm: PwmOut,
                 current: CurrentSense | None = None, diag: DigitalIn | None = None):
        super().__init__(name, current, diag)
        self.ina, self.inb, self.pwm = ina, inb, pwm
        #: the direction INA/INB were last written for; None = not known (force_safe)
        self._dir: int | None = 0
        pwm.write_duty(0.0)
        ina.write(False)
        inb.write(False)
        pwm.write_duty(1.0)      # brake to GND

    def _apply(self, duty: float) -> None:
        d = 0 if duty == 0.0 else (1 if duty > 0 else -1)
        if d != self._dir:
            self.pwm.write_duty(0.0)
            self.ina.write(d > 0)
            self.inb.write(d < 0)
            self._dir = d
        self.pwm.write_duty(abs(duty) if d else 1.0)

    def _write_safe(self) -> None:
        force_duty(self.pwm, 0.0)
        self.ina.write(False)
        self.inb.write(False)
        force_duty(self.pwm, 1.0)      # brake to GND
        self._dir = None

    def _write_closed(self) -> None:
        """At exit the PWM output stops (a disabled hardware channel idles low, which
        with INA = INB = 0 would coast): hold the brake through the row that needs no
        PWM, INA = INB = 1 (brake to VCC, §2.4). The lines keep these levels after the
        process ends on Raspberry Pi OS (``persist_gpio_outputs``)."""
        stop_pwm(self.pwm)
        self.ina.write(True)
        self.inb.write(True)
        self._dir = None


class Lmd18200Motor(HBridgeMotor):
    """LMD18200 (SARCNET): PWM, DIR and BRAKE inputs, :data:`LMD18200_TRUTH_TABLE`.

    Off = BRAKE high and PWM high: the winding shorted (brake, as the simulator's
    powered bridge at duty 0). BRAKE high with PWM low would turn every switch off
    (coast). Going into brake, BRAKE rises before PWM; leaving it, PWM falls first (a
    moment of coast, never a moment of drive). ``thermal_flag``: pin 9, open collector,
    low while the junction is above 145 C (the thermal warning; shutdown at 170 C).
    """

    FAULT_TEXT = "thermal flag low: junction above 145 C (thermal shutdown follows at 170 C)"

    def __init__(self, name: str, pwm: PwmOut, dir: DigitalOut, brake: DigitalOut,
                 current: CurrentSense | None = None, thermal_flag: DigitalIn | None = None):
        super().__init__(name, current, thermal_flag)
        self.pwm_out, self.dir_out, self.brake_out = pwm, dir, brake
        #: BRAKE and PWM were last written high; False also when not known (force_safe)
        self._braking = False
        pwm.write_duty(0.0)          # coast while BRAKE may still be low
        brake.write(True)
        dir.write(False)
        self._brake()

    def _brake(self) -> None:
        self.brake_out.write(True)
        self.pwm_out.write_duty(1.0)
        self._braking = True

    def _write_safe(self) -> None:
        force_duty(self.pwm_out, 0.0)       # coast while BRAKE may still be low
        self.brake_out.write(True)
        self.dir_out.write(False)
        force_duty(self.pwm_out, 1.0)
        self._braking = False

    def _write_closed(self) -> None:
        """At exit the PWM output stops (a disabled hardware channel idles low; lgpio's
        software PWM is stopped first, or its level when the thread ends is undefined):
        hold the brake through the other braking row of the table, BRAKE low with PWM
        low (both sourcing switches on). The lines keep these levels after the process
        ends on Raspberry Pi OS (``persist_gpio_outputs``)."""
        stop_pwm(self.pwm_out)
        self.brake_out.write(False)
        self._braking = False

    def _apply(self, duty: float) -> None:
        if duty == 0.0:
            if not self._braking:
                self.pwm_out.write_duty(0.0)
                self._brake()
            return
        self.pwm_out.write_duty(0.0)    # coast (BRAKE high) or brake in the off-time (BRAKE low)
        self.dir_out.write(duty > 0)
        self.brake_out.write(False)
        self._braking = False
        self.pwm_out.write_duty(abs(duty))


class Bts7960Motor(HBridgeMotor):
    """IBT-2 / BTS7960 (BIG-RAS): RPWM drives forward, LPWM reverse; at most one is
    ever non-zero (the other side is written to 0 first: no shoot-through). Its fault
    signal comes on IS (:class:`.bts7960_sense.Bts7960Sense`, told each duty: IS senses
    only during the driven side's on-time)."""

    def __init__(self, name: str, rpwm: PwmOut, lpwm: PwmOut, enable: DigitalOut | None = None,
                 current: CurrentSense | None = None):
        super().__init__(name, current)
        self.rpwm, self.lpwm, self.enable = rpwm, lpwm, enable
        rpwm.write_duty(0.0)
        lpwm.write_duty(0.0)
        if enable is not None:
            enable.write(True)     # R_EN/L_EN high: both low sides brake at duty 0

    def _write_safe(self) -> None:
        force_duty(self.lpwm, 0.0)
        force_duty(self.rpwm, 0.0)
        if self.enable is not None:
            self.enable.write(True)
        note_duty = getattr(self._current, "note_duty", None)
        if note_duty is not None:
            note_duty(0.0)

    def _pwms(self) -> tuple[PwmOut, ...]:
        return self.rpwm, self.lpwm

    def _apply(self, duty: float) -> None:
        if duty >= 0.0:
            self.lpwm.write_duty(0.0)
            self.rpwm.write_duty(duty)
        else:
            self.rpwm.write_duty(0.0)
            self.lpwm.write_duty(-duty)
        note_duty = getattr(self._current, "note_duty", None)
        if note_duty is not None:
            # the duty the PWM really makes: lgpio's software PWM truncates to whole
            # percent (a 1.9 % drive runs at 1 %), and the IS reading is divided by it
            read_back = getattr(self.rpwm if duty >= 0.0 else self.lpwm, "read_back", None)
            note_duty(read_back() if read_back is not None else abs(duty))


class PwmDirMotor(HBridgeMotor):
    """A plain PWM + DIR driver (the DFRobot board of the Berkeley rotor)."""

    def __init__(self, name: str, pwm: PwmOut, dir: DigitalOut,
                 current: CurrentSense | None = None):
        super().__init__(name, current)
        self.pwm_out, self.dir_out = pwm, dir
        #: the direction DIR was last written for; None = not known
        self._fwd: bool | None = None
        pwm.write_duty(0.0)
        dir.write(False)

    def _apply(self, duty: float) -> None:
        if duty != 0.0 and (duty > 0) != self._fwd:
            self.pwm_out.write_duty(0.0)
            self.dir_out.write(duty > 0)
            self._fwd = duty > 0
        self.pwm_out.write_duty(abs(duty))

    def _write_safe(self) -> None:
        force_duty(self.pwm_out, 0.0)
        self.dir_out.write(False)
        self._fwd = None

    def _pwms(self) -> tuple[PwmOut, ...]:
        return (self.pwm_out,)


#: the shortest reversal dead time allowed: a relay's contact opens 5-15 ms after its
#: coil is switched off, so a shorter wait can have the CW and CCW contacts closed at
#: once (the phase capacitor shorted); 50 ms covers that with margin
RELAY_MIN_DEAD_TIME_S = 0.05

#: the slow speed's pulse period: the G4JNT controller pulses its motor at 2 Hz
#: (configurable: ``[hardware.gpio.<axis>] relay_pulse_hz``)
SLOW_PULSE_PERIOD_S = 0.5


class RelayMotor(DirectionTracker):
    """Relay drive (G4JNT, Yaesu G-5500 class): CW and CCW relays, optional fast relay.

    The drive switches to the nearest of ``levels`` (besides off). Levels below 1 are
    made with the fast relay off when there is one (a slow winding tap), else by pulsing
    the direction relay on for level x ``pulse_period_s``. Reversing waits
    ``reverse_dead_time_s`` with both relays off (an AC motor must not be plugged
    into the other direction while it still turns; two relays closed at once short the
    phase capacitor). The dead time lives here, not only in the control law, so no
    caller can get round it.
    """

    def __init__(self, name: str, cw: DigitalOut, ccw: DigitalOut, clock: Clock, *,
                 fast: DigitalOut | None = None, levels: Sequence[float] = (1.0,),
                 reverse_dead_time_s: float = 0.5, pulse_period_s: float = SLOW_PULSE_PERIOD_S,
                 current: CurrentSense | None = None):
        super().__init__()
        self.name = name
        self.cw, self.ccw, self.fast = cw, ccw, fast
        self.clock = clock
        self.levels = tuple(sorted(float(v) for v in levels)) or (1.0,)
        if not reverse_dead_time_s >= RELAY_MIN_DEAD_TIME_S:
            raise ConfigError(f"{name} relays: a reversal dead time of {reverse_dead_time_s!r} s can close "
                              "CW and CCW at once (a relay opens 5-15 ms after its coil goes off)",
                              key="hardware.gpio.relay_dead_time_s",
                              expected=f"at least {RELAY_MIN_DEAD_TIME_S:g} s", found=reverse_dead_time_s)
        self.reverse_dead_time_s = float(reverse_dead_time_s)
        self.pulse_period_s = float(pulse_period_s)
        self._current = current
        self.duty = 0.0
        self.level = 0.0          # the level asked for (sign = direction)
        #: the relay energised now: +1 CW, -1 CCW, 0 none, None not known (force_safe)
        self._on_dir: int | None = 0
        self._off_since_s: float | None = -math.inf
        self._last_dir = 0        # direction of the last energised relay
        self._level_since_s = 0.0
        #: held over check + relay writes + state update (see the module's docstring)
        self._lock = threading.Lock()
        self.closed = False
        self._refused = False
        cw.write(False)
        ccw.write(False)
        if fast is not None:
            fast.write(False)

    def quantise(self, duty: float) -> float:
        return quantise_relay(duty, self.levels)

    def set_drive(self, duty: float) -> None:
        duty = clamp_duty(duty, self.name)
        self._track(duty)
        with self._lock:
            if self.closed:
                refuse_closed(self, duty)
                return
            self.duty = duty
            level = self.quantise(duty)
            now = self.clock.now_s()
            if level != self.level:
                self._level_since_s = now
                self.level = level
            self.service(now, level)
            if self.closed:      # closed meanwhile by a thread that could not wait for this one
                self._all_off()

    def force_safe(self) -> None:
        """Every relay off from any thread (``Hardware.drive_safe``), whatever the driver
        remembers and whether or not its lock came; which relay is on is then unknown,
        so the next drive writes them again."""
        with forcing(self._lock, f"{self.name} relays off"):
            self.duty = self.level = 0.0
            self._all_off()

    def close(self) -> None:
        """At exit: every relay off, and every later drive refused (a relay line keeps
        its level after the process ends, ``persist_gpio_outputs``)."""
        with forcing(self._lock, f"{self.name} relays close"):
            self.closed = True   # first: a writer that could not be waited for undoes its writes
            self.duty = self.level = 0.0
            self._all_off()

    def _all_off(self) -> None:
        self.cw.write(False)
        self.ccw.write(False)
        if self.fast is not None:
            self.fast.write(False)
        self._on_dir = None
        self._off_since_s = self.clock.now_s()    # (after the writes: see _energise)

    def service(self, now_s: float, level: float) -> None:
        """Set the relays for ``level`` (the one asked for) at ``now_s``."""
        want = 0 if level == 0.0 else (1 if level > 0 else -1)
        if want and self._last_dir and want != self._last_dir:
            # reversal: off first (also when not known), then wait out the dead time
            if self._on_dir != 0:
                self._energise(0)
            if self._off_since_s is None or now_s - self._off_since_s < self.reverse_dead_time_s - 1e-9:
                return
        mag = abs(level)
        on = want
        if want and mag < 1.0 and self.fast is None:
            # pulsed slow speed: on for mag x period, in phase with the level change
            phase = (now_s - self._level_since_s) % self.pulse_period_s
            on = want if phase < mag * self.pulse_period_s - 1e-9 else 0
        if self.fast is not None:
            self.fast.write(bool(want) and mag >= 1.0)
        self._energise(on)

    def _energise(self, d: int) -> None:
        if d == self._on_dir:
            return
        # break before make: the other relay always opens first
        if d >= 0:
            self.ccw.write(False)
        if d <= 0:
            self.cw.write(False)
        if d > 0:
            self.cw.write(True)
        elif d < 0:
            self.ccw.write(True)
        if d:
            self._last_dir = d
            self._off_since_s = None
        else:
            # the dead time counts from the clock after the writes: ``now_s`` was read
            # before them, and a freeze in between (SIGSTOP, a stalled write) would
            # shorten it by as long as it lasted
            self._off_since_s = self.clock.now_s()
        self._on_dir = d

    def energised(self) -> int | None:
        """The relay energised now: +1 CW, -1 CCW, 0 none, None not known."""
        return self._on_dir

    def read_current_a(self) -> float:
        return float(self._current.read_current_a()) if self._current is not None else 0.0


def sense_v_per_a(cfg: object) -> float:
    """The axis' current-sense scale: configured, else its bridge's (SENSE_V_PER_A)."""
    if cfg.current_sense_v_per_a is not None:  # type: ignore[attr-defined]
        return float(cfg.current_sense_v_per_a)  # type: ignore[attr-defined]
    try:
        return SENSE_V_PER_A[cfg.motor]  # type: ignore[attr-defined]
    except KeyError:
        raise ConfigError(f"current sense on a {cfg.motor}: set current_sense_v_per_a",
                          key="hardware.gpio.current_sense_v_per_a",
                          expected="volts per motor ampere (LMD18200: 377e-6 x the sense resistor)",
                          found=None) from None
