"""The safety chain's start-up self-test: stop the heartbeat, see the enable fall within
the timeout, re-arm (issue 35).

What it cannot see (docs/hardware.md): a missing pull-down on +TR (the test drives the
heartbeat line, so +TR does not float then; a commissioning check with the line
undriven shows it), and a relay slow to release by less than the margin (a plain diode
across its coil: tens of ms).

The chain (docs/hardware.md "Safety chain") is only worth something if it cuts: a Q
stuck high or a Q1 failed shorted, a trigger floating in mains hum (hum is edges) and a
welded relay contact all leave the motors powered with nothing in control, and none of
them shows while urc runs normally. With the chain's output read back on an input
(``Hardware.enable_sense``) the test shows each: it arms the chain with heartbeat edges,
gives one last rising edge, holds the heartbeat low and times how long the enable takes
to fall. It must fall after about the monostable's period: within ``timeout_s`` +/-
``margin_s`` (the relay's drop-out time is inside the margin). Never falling is a chain
that does not cut; falling much sooner is one that is not what the configuration says
(a wrong RX or CX, a relay not held in, a read-back on the wrong point). Then the
heartbeat runs again and the enable must come back.

Pure with respect to the clock it is given: on a virtual clock with the modelled chain
(``sleep`` advances it) the result is exact; on a real clock the read-back is polled
every ``poll_s``, and each verdict is drawn from readings only (the enable seen ON past
the deadline, seen OFF before the window opened), so a late wake-up on a loaded machine
widens the measurement's uncertainty (``resolution_s``), never makes a good chain fail.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable

#: the control loop's heartbeat: a level change per 50 Hz tick (a rising edge per 40 ms)
BEAT_S = 0.02
#: how often the read-back is read while waiting for it to change
POLL_S = 0.001
#: the tolerance on the measured timeout: the CD4538B's T = RX CX is specified for VDD 5
#: to 15 V (it can differ at 3.3 V), RX and CX have their tolerances, and the relay
#: opens its contact some ms after Q falls (a few with the documented Zener clamp)
DEFAULT_MARGIN_S = 0.05


@dataclass(frozen=True)
class SelfTestResult:
    #: True: the chain cut within the window and came back; False: it did not (``why``);
    #: None: not measured (no read-back input)
    ok: bool | None
    #: from the last rising edge to the first reading of the enable off (None: never seen)
    measured_s: float | None
    why: str
    #: the interval the drop lies in, readings apart (the measurement's uncertainty)
    resolution_s: float | None = None

    def line(self) -> str:
        """One line for a log, `urc hw check` or a latched fault."""
        if self.ok is None:
            return f"safety chain self-test: {self.why}"
        return f"safety chain self-test {'passed' if self.ok else 'FAILED'}: {self.why}"


def self_test(hw: Any, timeout_s: float, margin_s: float = DEFAULT_MARGIN_S, clock: Any = None, *,
              sleep: Callable[[float], None] | None = None, beat_s: float = BEAT_S,
              poll_s: float = POLL_S) -> SelfTestResult:
    """Test the safety chain on ``hw`` (its ``heartbeat`` and ``enable_sense``); the
    motors must be off (the chain powers them for the test's ~``timeout_s`` x 2). Run it
    with nothing else writing the heartbeat; it returns with the chain armed (its last
    edge just given), so the control loop's first tick should follow within
    ``timeout_s`` (or the relay drops and picks up again at that tick).

    ``clock``: ``now_s()``; ``sleep(dt_s)`` waits on it (default: the clock's
    ``advance`` if it is a virtual clock, else ``time.sleep``)."""
    sense, beat = getattr(hw, "enable_sense", None), getattr(hw, "heartbeat", None)
    if sense is None:
        return SelfTestResult(None, None, "not measured: no read-back input (motor_enable_sense_pin)")
    if beat is None:
        return SelfTestResult(False, None, "a read-back input but no heartbeat output to test the chain with")
    if clock is None:
        from ..clock import RealClock
        clock = RealClock()
    if sleep is None:
        sleep = getattr(clock, "advance", None) or time.sleep
    return _Run(hw, sense, beat, float(timeout_s), float(margin_s), clock.now_s, sleep, beat_s, poll_s).run()


class _Run:
    def __init__(self, hw: Any, sense: Any, beat: Any, timeout_s: float, margin_s: float,
                 now_s: Callable[[], float], sleep: Callable[[float], None], beat_s: float, poll_s: float):
        self.hw, self.sense, self.beat = hw, sense, beat
        self.timeout_s, self.margin_s = timeout_s, margin_s
        self.now_s, self.sleep, self.beat_s, self.poll_s = now_s, sleep, beat_s, poll_s
        self.level = False
        #: the enable's readings at the read-back, for messages (which point it reads)
        self.what = "the relay's contact" if getattr(sense, "point", "contact") == "contact" else "Q"

    def read(self) -> tuple[float, float, bool]:
        """(clock before, clock after, the enable read): on a loaded machine this process
        may be descheduled between the two, so each verdict uses the bound that can only
        make a good chain pass (review of issue 35: a reading timed before it was taken
        made a good chain "fall too soon" after an 80 ms stall)."""
        self.hw.poll(self.now_s())        # (a simulated or emulated chain advances to now)
        before_s = self.now_s()
        on = bool(self.sense.read())
        after_s = self.now_s()
        note = getattr(self.hw, "note_enable", None)
        if note is not None:              # (the cut resets a step/dir chip's indexer: supply_watch)
            note(on)
        return before_s, after_s, on

    def toggle(self) -> tuple[float, float]:
        """The heartbeat's next level; the clock before and after the write."""
        self.level = not self.level
        before_s = self.now_s()
        self.beat.write(self.level)
        return before_s, self.now_s()

    def arm(self, within_s: float) -> float | None:
        """Heartbeat edges until the read-back shows the enable on (the clock time it
        did), at most ``within_s``."""
        end_s = self.now_s() + within_s
        next_beat_s = self.now_s()
        while True:
            if self.now_s() >= next_beat_s:
                self.toggle()
                next_beat_s += self.beat_s
            t_s, _after_s, on = self.read()
            if on:
                return t_s
            if t_s >= end_s:
                return None
            self.sleep(min(self.poll_s, max(0.0, next_beat_s - self.now_s())) or self.poll_s)

    def run(self) -> SelfTestResult:
        try:
            return self._run()
        except Exception as exc:   # a read-back or heartbeat that fails is a failed test
            return SelfTestResult(False, None, f"the test could not run: {exc}")

    def _run(self) -> SelfTestResult:
        T, m = self.timeout_s, self.margin_s
        window = f"{T - m:.3f} to {T + m:.3f} s ({T:g} s configured, +/- {m:g} s)"
        if self.arm(T + m) is None:
            return SelfTestResult(False, None, (
                f"{self.what} never showed the enable on while the heartbeat ran for {T + m:.3f} s: no supply to "
                "the relay's coil, the chain broken (U1, Q1, the coil), or the read-back miswired or at the wrong "
                "level (motor_enable_sense_active_low). urc cannot show that the chain cuts"))
        # the last rising edge, then the heartbeat held low (a falling edge never retriggers)
        if self.level:
            self.toggle()
        edge_before_s, edge_s = self.toggle()   # (the rising edge lies between the two)
        self.toggle()
        last_on_s = edge_before_s
        while True:
            t_s, after_s, on = self.read()
            if not on:
                break
            last_on_s = t_s
            if t_s - edge_s > T + m:  # (seen on at least this long after the edge)
                return SelfTestResult(False, None, (
                    f"{self.what} still showed the enable on {t_s - edge_s:.3f} s after the heartbeat stopped "
                    f"(it must fall within {window}): the chain does not cut. Look for Q stuck high or Q1 "
                    "failed shorted, a trigger floating now (the heartbeat wire broken with no 100 kOhm from "
                    "+TR to GND: hum retriggers it)" + (", a welded relay contact, a relay releasing more than "
                                                       f"{m:g} s late (a plain diode across its coil)"
                                                       if self.what != "Q" else "")))
            self.sleep(self.poll_s)
        # it fell before this reading ended, and after the last reading that saw it on:
        # "too soon" only if even the latest it can have fallen is too soon
        measured_s, resolution_s = after_s - edge_before_s, after_s - last_on_s
        if measured_s < T - m:
            return SelfTestResult(False, measured_s, (
                f"the enable fell {measured_s:.3f} s after the last heartbeat edge, sooner than {window}: the "
                "monostable's period is not the configured one (RX, CX; if it is right, set "
                "motor_enable_timeout_s to it), the relay is not held in (its coil supply), or the read-back "
                "reads something else"), resolution_s)
        if self.arm(m + 2 * self.beat_s) is None:
            return SelfTestResult(False, measured_s, (
                f"the enable fell after {measured_s:.3f} s but did not come back within "
                f"{m + 2 * self.beat_s:.3f} s of the heartbeat resuming: the relay does not pick up again "
                "(its coil supply, U1's reset)"), resolution_s)
        return SelfTestResult(True, measured_s, (
            f"the enable fell {measured_s:.3f} s after the last heartbeat edge at {self.what} (window "
            f"{T - m:.3f} to {T + m:.3f} s) and came back with the heartbeat"), resolution_s)


__all__ = ["self_test", "SelfTestResult", "DEFAULT_MARGIN_S"]
