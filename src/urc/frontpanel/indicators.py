"""Status LEDs and the beeper: what they show at a given time, as pure functions of the
status and the clock (so the virtual clock drives them in tests).

The Tartu controller (seed 000) lights one LED per motion direction (CW, CCW, UP,
DOWN) while that motor runs, and reports errors on a fifth LED and on the serial port.
It does not say how errors look on that LED; urc's choice, one blink code per fault
family (flashes of 0.25 s, 0.25 s apart, then 1.5 s dark, repeated):

====  =====================================================================
code  fault
====  =====================================================================
1     stall (driven, not moving)
2     runaway (moving without drive, or the wrong way)
3     position sensor (dead, stuck, jump, out of range)
4     limit switch hit
5     motor overcurrent
6     anything else (control-loop watchdog, state file, ...)
====  =====================================================================

The error LED is steady on when there is no fault but the position is not known
(re-reference before automatic motion), and off when all is well. The LCD shows the
same code beside the fault (``E3 sensor_jump az``) so the two can be matched.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..model.snapshot import Status

BLINK_ON_S = 0.25
BLINK_OFF_S = 0.25
BLINK_GAP_S = 1.5

_CODES = {"stall": 1, "runaway": 2, "sensor_dead": 3, "sensor_stuck": 3, "sensor_jump": 3,
          "sensor_range": 3, "limit_switch": 4, "overcurrent": 5}


def fault_code(kind: str) -> int:
    """The blink code of a fault kind (6: any other)."""
    return _CODES.get(kind, 6)


def blink_on(code: int, t_s: float) -> bool:
    """Is the error LED lit at time ``t_s`` while blinking ``code``?"""
    period_s = code * (BLINK_ON_S + BLINK_OFF_S) + BLINK_GAP_S
    phase_s = t_s % period_s
    if phase_s >= code * (BLINK_ON_S + BLINK_OFF_S):
        return False
    return phase_s % (BLINK_ON_S + BLINK_OFF_S) < BLINK_ON_S


@dataclass(frozen=True)
class LedStates:
    cw: bool
    ccw: bool
    up: bool
    down: bool
    fault: bool


def led_states(st: Status, t_s: float) -> LedStates:
    """Direction LEDs lit while the motor drives that way; the error LED's code."""
    if st.faults:
        err = blink_on(fault_code(st.faults[0].kind), t_s)
    else:
        err = not st.position_known
    el_duty = 0.0 if st.el is None else st.el.duty  # (a single-axis rotator: UP/DOWN stay dark)
    return LedStates(cw=st.az.duty > 0, ccw=st.az.duty < 0, up=el_duty > 0, down=el_duty < 0,
                     fault=err)


#: beeper patterns: (on_s, off_s) pairs. A click for an accepted key, three short for a
#: refused one, one long for a fault latching, two for a value stored.
BEEPS = {
    "click": ((0.03, 0.0),),
    "refused": ((0.08, 0.08),) * 3,
    "fault": ((1.0, 0.0),),
    "stored": ((0.1, 0.1),) * 2,
    "command": ((0.02, 0.0),),       # a new target from a protocol port (beep_on_command)
}


class Tone:
    """A passive beeper on a PWM output (gpiozero PWMOutputDevice at the tone's
    frequency): on is a square wave, off is silence, for :class:`Beeper`."""

    def __init__(self, pwm):
        self.pwm = pwm

    def on(self) -> None:
        self.pwm.value = 0.5

    def off(self) -> None:
        self.pwm.value = 0.0


class Beeper:
    """Plays one pattern at a time on a gpiozero Buzzer-like output (``on()``/``off()``),
    timed by :meth:`update` from the panel's clock; a new pattern replaces the old."""

    def __init__(self, output):
        self.output = output
        self._steps: list[tuple[float, bool]] = []   # (until_s, on)
        self._pending: str | None = None
        self.played: list[str] = []                  # what was played (status, tests)

    def beep(self, pattern: str) -> None:
        if pattern not in BEEPS:
            raise ValueError(f"unknown beep {pattern!r}")
        self._pending = pattern
        self.played.append(pattern)

    def update(self, now_s: float) -> None:
        if self._pending is not None:
            t = now_s
            self._steps = []
            for on_s, off_s in BEEPS[self._pending]:
                t += on_s
                self._steps.append((t, True))
                if off_s:
                    t += off_s
                    self._steps.append((t, False))
            self._pending = None
        while self._steps and now_s >= self._steps[0][0]:
            self._steps.pop(0)
        on = bool(self._steps) and self._steps[0][1]
        if self.output is not None:
            (self.output.on if on else self.output.off)()
