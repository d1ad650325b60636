"""Motor drivers: H-bridges and relay drives on digital/PWM output parts.

Each implements :class:`urc.hardware.interfaces.Motor` (``set_drive(duty)`` in [-1, 1],
``read_current_a``). They also remember the direction of the last non-zero drive: a
SPID pulse counter has no direction channel and takes it from the drive
(:class:`DirectionTracker`).

Every driver puts its outputs in the safe state (motor off, H-bridge braking) when it
is built, before anything else can drive them.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

from ...clock import Clock
from ...errors import HardwareError
from ..parts import CurrentSense, DigitalOut, PwmOut, VoltageIn


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
    (VNH5019 carrier: about 0.14 V/A; the output gives the magnitude, not the sign)."""

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

    def __init__(self, name: str, current: CurrentSense | None = None):
        super().__init__()
        self.name = name
        self.duty = 0.0
        self._current = current

    def set_drive(self, duty: float) -> None:
        duty = clamp_duty(duty, self.name)
        self._track(duty)
        self.duty = duty
        self._apply(duty)

    def _apply(self, duty: float) -> None:
        raise NotImplementedError

    def read_current_a(self) -> float:
        return float(self._current.read_current_a()) if self._current is not None else 0.0


class Vnh5019Motor(HBridgeMotor):
    """VNH5019 (Tartu board): INA/INB set the direction, PWM the speed, CS the current.

    INA=1 INB=0 forward, INA=0 INB=1 reverse, both 0 with PWM 0: brake to ground.
    The direction pins change only with PWM at 0, so the bridge never sees a reversal
    under drive.
    """

    def __init__(self, name: str, ina: DigitalOut, inb: DigitalOut, pwm: PwmOut,
                 current: CurrentSense | None = None):
        super().__init__(name, current)
        self.ina, self.inb, self.pwm = ina, inb, pwm
        self._dir = 0
        pwm.write_duty(0.0)
        ina.write(False)
        inb.write(False)

    def _apply(self, duty: float) -> None:
        d = 0 if duty == 0.0 else (1 if duty > 0 else -1)
        if d != self._dir:
            self.pwm.write_duty(0.0)
            self.ina.write(d > 0)
            self.inb.write(d < 0)
            self._dir = d
        self.pwm.write_duty(abs(duty))


class Lmd18200Motor(HBridgeMotor):
    """LMD18200 (SARCNET): PWM, DIR and BRAKE inputs. Off = BRAKE high, PWM low
    (the winding shorted, as the sim's powered bridge at duty 0)."""

    def __init__(self, name: str, pwm: PwmOut, dir: DigitalOut, brake: DigitalOut,
                 current: CurrentSense | None = None):
        super().__init__(name, current)
        self.pwm_out, self.dir_out, self.brake_out = pwm, dir, brake
        pwm.write_duty(0.0)
        brake.write(True)
        dir.write(False)

    def _apply(self, duty: float) -> None:
        if duty == 0.0:
            self.pwm_out.write_duty(0.0)
            self.brake_out.write(True)
            return
        self.pwm_out.write_duty(0.0)
        self.dir_out.write(duty > 0)
        self.brake_out.write(False)
        self.pwm_out.write_duty(abs(duty))


class Bts7960Motor(HBridgeMotor):
    """IBT-2 / BTS7960 (BIG-RAS): RPWM drives forward, LPWM reverse; at most one is
    ever non-zero (the other side is written to 0 first: no shoot-through)."""

    def __init__(self, name: str, rpwm: PwmOut, lpwm: PwmOut, enable: DigitalOut | None = None,
                 current: CurrentSense | None = None):
        super().__init__(name, current)
        self.rpwm, self.lpwm, self.enable = rpwm, lpwm, enable
        rpwm.write_duty(0.0)
        lpwm.write_duty(0.0)
        if enable is not None:
            enable.write(True)     # R_EN/L_EN high: both low sides brake at duty 0

    def _apply(self, duty: float) -> None:
        if duty >= 0.0:
            self.lpwm.write_duty(0.0)
            self.rpwm.write_duty(duty)
        else:
            self.rpwm.write_duty(0.0)
            self.lpwm.write_duty(-duty)


class PwmDirMotor(HBridgeMotor):
    """A plain PWM + DIR driver (the DFRobot board of the Berkeley rotor)."""

    def __init__(self, name: str, pwm: PwmOut, dir: DigitalOut,
                 current: CurrentSense | None = None):
        super().__init__(name, current)
        self.pwm_out, self.dir_out = pwm, dir
        pwm.write_duty(0.0)
        dir.write(False)

    def _apply(self, duty: float) -> None:
        if duty != 0.0 and (duty > 0) != getattr(self, "_fwd", None):
            self.pwm_out.write_duty(0.0)
            self.dir_out.write(duty > 0)
            self._fwd = duty > 0
        self.pwm_out.write_duty(abs(duty))


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
        self.reverse_dead_time_s = float(reverse_dead_time_s)
        self.pulse_period_s = float(pulse_period_s)
        self._current = current
        self.duty = 0.0
        self.level = 0.0          # the level asked for (sign = direction)
        self._on_dir = 0          # the relay energised now: +1 CW, -1 CCW, 0 none
        self._off_since_s: float | None = -math.inf
        self._last_dir = 0        # direction of the last energised relay
        self._level_since_s = 0.0
        cw.write(False)
        ccw.write(False)
        if fast is not None:
            fast.write(False)

    def quantise(self, duty: float) -> float:
        return quantise_relay(duty, self.levels)

    def set_drive(self, duty: float) -> None:
        duty = clamp_duty(duty, self.name)
        self._track(duty)
        self.duty = duty
        level = self.quantise(duty)
        now = self.clock.now_s()
        if level != self.level:
            self._level_since_s = now
            self.level = level
        self.service(now)

    def service(self, now_s: float) -> None:
        """Set the relays for the asked level at ``now_s`` (also called between drives
        by a backend that polls faster than the control tick)."""
        level = self.level
        want = 0 if level == 0.0 else (1 if level > 0 else -1)
        if want and self._last_dir and want != self._last_dir:
            # reversal: off first, then wait out the dead time
            if self._on_dir:
                self._energise(0, now_s)
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
        self._energise(on, now_s)

    def _energise(self, d: int, now_s: float) -> None:
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
            self._off_since_s = now_s
        self._on_dir = d

    def energised(self) -> int:
        return self._on_dir

    def read_current_a(self) -> float:
        return float(self._current.read_current_a()) if self._current is not None else 0.0
