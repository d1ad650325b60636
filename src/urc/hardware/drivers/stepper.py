"""A step/dir stepper as urc's ``Motor`` and its step count as the ``PositionSensor``.

:class:`StepDirMotor` turns the drive (-1..1, the law's duty) into a step rate, duty 1
being the profile's top speed, and hands each tick's steps to the pulse train (lgpio's
queue, :mod:`..gpio.stepdir`) as one entry of an exact count. The rate never exceeds
the profile's top speed and never changes faster than ``max_accel_deg_per_s2`` (the
builder gives :data:`ENVELOPE_ACCEL_FACTOR` times the profile's acceleration): the
envelope that keeps the demanded torque under the motor's pull-out curve (the
simulator's model, :mod:`..sim.stepper`, checks it with margin). It is wider than the
profile's own ramp because urc's law plans that ramp in duty and brakes harder near a
target (a DC motor's duty is not its speed); a stepper held to the firmware's ramp
alone coasts on for seconds past where the law stopped driving. The direction pin changes only
with the queue empty (the rate ramps through 0 first), so DIR is stable long before
any STEP edge (the datasheets' setup times are 20-650 ns).

The step count is the open-loop position (:class:`StepCountSensor`): exact while no
step is lost. The driver knows of losses it causes: the train cut while moving (a
fault's ``force_safe``, closing), the enable taken away mid-move. Those make the
position *uncertain*: reported once as a driver fault (the guard latches it and stops
the axis) and kept in ``position_lost`` until the axis is re-referenced (homing on
the endstop, ``set_reference_deg``). The motor supply lost while urc drives (the safety
chain's read-back, :mod:`..supply_watch`: ``supply_lost``) is one of those losses, at
rest too while the chip is enabled: the steps went to a driver without power, and the
indexer reset. Each time the read-back shows the supply off (the start-up self-test's
cut included: ``supply_off``) while stepping, the position is lost; at rest, on a chip
whose translator the loss resets, the count's bound ``position_bound_deg`` widens by
``HOME_SNAP_FULL_STEPS`` full steps, the snap of the reset indexer (the axis takes it
as its uncertainty until homed). Steps the motor slips under a load it cannot
move are invisible to it; an absolute sensor beside the count (an AS5600 on the axis,
``check``) turns them into a fault: the two disagreeing by more than ``check_tol_deg``.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from typing import Any, Callable

from ...caps import SensorCaps
from ...errors import HardwareError, SensorError
from .stepdir_chips import HOME_SNAP_FULL_STEPS, MAX_LIBRARY_TIMED_HZ, StepDirChip, pulse_times_us
from ..parts import DigitalOut
from ...angles import wrap180_deg

#: the driver's acceleration envelope over the profile's ramp (see the module's text)
ENVELOPE_ACCEL_FACTOR = 8.0
#: the train is queued this far ahead of the tick (in ticks): one late tick does not
#: leave it empty (an empty queue is a sudden stop at full speed)
LEAD_TICKS = 2


class StepDirMotor:
    """``set_drive(duty)`` -> a step rate; ``steps()`` the steps emitted so far (signed).

    ``pulses``: the STEP pin's pulse queue (``queue``/``room``/``busy``/``cut``);
    ``dir_out``: DIR (high = increasing angle unless ``dir_reversed``); ``enable``:
    the chip's enable input as a logical output (True = outputs on; its active level
    is the chip's, :attr:`StepDirChip.enable_active_low`), None when tied on."""

    def __init__(self, name: str, chip: StepDirChip, pulses: Any, dir_out: DigitalOut,
                 enable: DigitalOut | None, now_s: Callable[[], float], *, steps_per_deg: float,
                 max_rate_deg_per_s: float, max_accel_deg_per_s2: float, tick_s: float = 0.02,
                 dir_reversed: bool = False, microsteps: int = 8):
        self.name, self.chip, self.pulses = name, chip, pulses
        self.dir_out, self.enable, self.now_s = dir_out, enable, now_s
        self.steps_per_deg = float(steps_per_deg)
        self.max_sps = max_rate_deg_per_s * self.steps_per_deg
        self.accel_sps2 = max_accel_deg_per_s2 * self.steps_per_deg
        if self.max_sps > MAX_LIBRARY_TIMED_HZ:
            raise HardwareError(f"{name}: {self.max_sps:.0f} steps/s is over the {MAX_LIBRARY_TIMED_HZ:.0f} "
                                "a library-timed pulse train keeps up with (fewer microsteps?)")
        if chip.max_step_hz is not None and self.max_sps > chip.max_step_hz:
            raise HardwareError(f"{name}: {self.max_sps:.0f} steps/s is over the {chip.name}'s "
                                f"{chip.max_step_hz:.0f}")
        self.tick_s = tick_s
        self.dir_reversed = dir_reversed
        self.duty = 0.0
        self.rate_sps = 0.0               # signed, as last queued
        self.direction = 1
        self.drives = 0
        self._frac = 0.0                  # the fraction of a step carried to the next entry
        self._last_s: float | None = None
        #: entries queued and not yet known done: [steps (signed), period_s, start_s]
        self._sched: deque[list[float]] = deque()
        self._done = 0                    # steps of the entries known done
        self.position_lost = ""           # why the count is no longer the position
        #: the count is the position to within this (deg) until re-referenced: a translator
        #: reset by a motor-supply loss at rest (:meth:`supply_off`)
        self.position_bound_deg = 0.0
        self.microsteps = int(microsteps)
        self.full_step_deg = microsteps / self.steps_per_deg
        self._reported = ""
        self._lock = threading.Lock()
        self.closed = False
        #: bumped by every force_safe before it waits for the lock: a drive that began
        #: before sees it changed and queues nothing after the cut
        self._halt = 0
        self._dir_level = True
        self._write_dir(1)
        #: the chip's outputs on as last written (True where ENABLE is tied on)
        self.enabled = True
        if self.enable is not None:
            self.enable.write(True)       # holding torque: the worm and the count stay put
        #: how many motor-supply losses the read-back showed since the start (supply_off)
        self.supply_offs = 0

    # ---------------------------------------------------------------- the count
    def steps(self) -> int:
        """Steps emitted by now (signed): the entries done, and of the running one the
        pulses its period has given since it began."""
        now = self.now_s()
        n = self._done
        while self._sched:
            steps, period, start = self._sched[0]
            if now < start + abs(steps) * period - 1e-9:
                break
            self._done += int(steps)
            n = self._done
            self._sched.popleft()
        for steps, period, start in self._sched:
            if now >= start:
                k = min(abs(steps), math.floor((now - start) / period + 1e-9) + 1)
                n += int(math.copysign(k, steps))
        return n

    def committed_steps(self) -> int:
        """Steps emitted and queued (signed): where the rotor is once the queue is out.
        A drive changes it at once, the emitted count only LEAD_TICKS later."""
        self.steps()
        return self._done + sum(int(e[0]) for e in self._sched)

    def at_rest(self) -> bool:
        """No step asked for and every queued one out: by the schedule and by lg, whose
        train starts up to 20 ms after it is queued (lgPthTx.c:61), so the schedule can
        end before the last pulse is out."""
        self.steps()
        return self.rate_sps == 0.0 and not self._sched and not self.pulses.busy()

    def _queued_end_s(self) -> float:
        if not self._sched:
            return self.now_s()
        steps, period, start = self._sched[-1]
        return start + abs(steps) * period

    # ---------------------------------------------------------------- the drive
    def set_drive(self, duty: float) -> None:
        duty = float(duty)
        if not math.isfinite(duty):
            raise HardwareError(f"{self.name} motor: drive must be finite, got {duty!r}")
        duty = max(-1.0, min(1.0, duty))
        with self._lock:
            if self.closed:
                raise HardwareError(f"{self.name} motor: closed")
            halt = self._halt
            now = self.now_s()
            dt = self.tick_s if self._last_s is None else min(max(now - self._last_s, 1e-3), 5 * self.tick_s)
            self._last_s = now
            self.duty = duty
            if duty != 0.0:
                self.drives += 1
                self.direction = 1 if duty > 0 else -1
            if self.enable is not None:
                self.enable.write(True)
                self.enabled = True
            want = duty * self.max_sps
            step = self.accel_sps2 * dt
            rate = self.rate_sps + max(-step, min(step, want - self.rate_sps))
            if rate != 0.0 and (rate > 0) != (self.rate_sps > 0) and self.rate_sps != 0.0:
                rate = 0.0                # through 0 first: DIR changes with the queue empty
            self._queue(rate, now, halt)

    def _queue(self, rate: float, now: float, halt: int) -> None:
        self.rate_sps = rate
        if rate == 0.0:
            self._frac = 0.0
            return
        sign = 1 if rate > 0 else -1
        if sign != self._dir_level_sign():
            if self.pulses.busy():
                self.rate_sps = 0.0       # the last pulses are still out: wait a tick
                return
            self.steps()                  # (the schedule caught up before DIR turns)
            self._write_dir(sign)
        # keep LEAD_TICKS of pulses ahead of now, one entry per tick
        horizon = now + LEAD_TICKS * self.tick_s
        end = max(self._queued_end_s(), now)
        if end >= horizon:
            return
        span = horizon - end
        exact = abs(rate) * span + self._frac
        n = int(exact)
        self._frac = exact - n
        if n <= 0:
            return
        # the n pulses spread over the span (a slow rate's one pulse does not hold the
        # queue for its whole period)
        high, low = pulse_times_us(max(abs(rate), n / span), self.chip)
        # force_safe gives up waiting for the lock after 10 ms and cuts without it
        # (review: stepper.py set_drive against force_safe): a halt since this drive
        # began, before or during tx_pulse, must not leave these pulses queued behind its cut
        if self._halt != halt:
            self._halted()
            return
        left = self.pulses.queue(high, low, n)
        if self._halt != halt:
            self._halted()
            self.pulses.cut()
            return
        if left < 0:
            raise HardwareError(f"{self.name} motor: the step queue refused {n} pulses (lg status {left})")
        start = max(end, now)
        self._sched.append([sign * n, (high + low) * 1e-6, start])

    def _halted(self) -> None:
        self.rate_sps, self.duty, self._frac = 0.0, 0.0, 0.0

    def _dir_level_sign(self) -> int:
        return (1 if self._dir_level else -1) * (-1 if self.dir_reversed else 1)

    def _write_dir(self, sign: int) -> None:
        level = (sign > 0) != self.dir_reversed
        self._dir_level = level
        self.dir_out.write(level)

    # ---------------------------------------------------------------- safety
    def force_safe(self) -> None:
        """The train cut now and the chip disabled; a cut mid-move loses the count."""
        self._halt += 1
        got = self._lock.acquire(timeout=0.01)
        n = self._done
        try:
            moving = self.pulses.busy()
            n = self.steps()
            if moving:
                self._lose(f"{self.name}: the step train was cut while moving (at step {n}); "
                           "the position is uncertain until the axis is homed")
            self.pulses.cut()
        finally:
            # (whatever the cut raised: the chip disabled and the drive forgotten all the same)
            try:
                if self.enable is not None:
                    self.enabled = False  # (before the write: a failed one may have disabled it)
                    self.enable.write(False)
            finally:
                self._sched.clear()
                self._done = n
                self.rate_sps, self.duty, self._frac = 0.0, 0.0, 0.0
                if got:
                    self._lock.release()

    def close(self) -> None:
        try:
            self.force_safe()
        finally:
            self.closed = True

    def supply_off(self) -> None:
        """The read-back showed the motor supply off (once per loss, the self-test's cut
        too; urc.hardware.supply_watch): while stepping, the steps after it are lost
        (position lost); at rest, on a chip whose translator its loss resets
        (:attr:`StepDirChip.home_on_motor_supply_loss`: DRV8825, TMC22xx), the rotor snaps
        to the home state's nearest position when power returns, up to
        ``HOME_SNAP_FULL_STEPS`` full steps from the count (an A4988 keeps its translator
        on VDD, and the powered-again coils pull the rotor back where it was)."""
        self.supply_offs += 1
        if self.rate_sps != 0.0 or self.pulses.busy():
            # (said by the stop that cut it — a stall's, or the motor_power fault — not as
            # this driver's fault too; the count is untrusted from here)
            self._lose(f"{self.name}: motor supply lost while moving (cut while stepping, at step {self.steps()}): "
                       "the position is uncertain until the axis is homed")
            self._reported = self.position_lost
        elif self.chip.home_on_motor_supply_loss:
            self.position_bound_deg += HOME_SNAP_FULL_STEPS * self.full_step_deg

    def supply_lost(self, why: str) -> None:
        """The motor supply lost while urc drives (the ``motor_power`` fault, ``why``):
        a train running or the chip enabled (holding) loses the count, and a running
        train is cut. The fault says why, so it is not reported again as this driver's
        fault."""
        moving = self.rate_sps != 0.0 or bool(self._sched) or self.pulses.busy()
        if not (moving or self.enabled):
            return
        n = self.steps()
        already = bool(self.position_lost)
        self._lose(f"{self.name}: motor supply lost while {'moving' if moving else 'holding'} (at step {n}): "
                   "the steps went to a driver without power and its indexer reset; the position is "
                   "uncertain until the axis is homed")
        if not already:
            self._reported = self.position_lost
        if moving:
            # the train cut now: its steps reach no rotor, and a supply back mid-ramp
            # would give a standing rotor steps at speed
            self.force_safe()

    def _lose(self, why: str) -> None:
        if not self.position_lost:
            self.position_lost = why

    def driver_fault(self) -> str:
        """The position loss, once (the guard latches it); '' otherwise."""
        if self.position_lost and self._reported != self.position_lost:
            self._reported = self.position_lost
            return self.position_lost
        return ""

    def re_referenced(self) -> None:
        self.position_lost = self._reported = ""
        self.position_bound_deg = 0.0

    def read_current_a(self) -> float:
        return 0.0

    def identify(self) -> str:
        return (f"{self.chip.name} step/dir: {self.rate_sps:+.0f} steps/s, count {self.steps()}"
                + (f", within +/-{self.position_bound_deg:.3f} deg after {self.supply_offs} motor-supply "
                   "loss(es)" if self.position_bound_deg else "")
                + (f", POSITION LOST ({self.position_lost})" if self.position_lost else ""))


class StepCountSensor:
    """The step count as the axis angle: ``reference_deg + steps / steps_per_deg``, the
    steps queued counted in (:meth:`StepDirMotor.committed_steps`): they go out whatever
    the next drive is, so that is where the axis is going. Counted as emitted, the law
    saw its drive two ticks late and a stop at a target ran the queue on past the
    tolerance (0.06 deg from the slowest speed on satnogs-v3, the tolerance 0.05). At
    rest the two are the same; a reference set while moving (homing on the endstop) is
    the emitted count's, where the switch was met.

    ``check`` (optional): an absolute sensor on the axis (an AS5600, reading modulo
    360) compared with the count on every read: once the two differ by more than
    ``check_tol_deg`` (from where they agreed at the last reference) steps were lost,
    and the motor reports it as a fault."""

    def __init__(self, caps: SensorCaps, name: str, motor: StepDirMotor, *, check: Any = None,
                 check_tol_deg: float | None = None, microsteps: int = 8, backlash_deg: float = 0.0):
        self.caps, self.name, self.motor = caps, name, motor
        self.reference_deg = 0.0
        self.check = check
        # 4 full steps (one electrical turn: what a slipping rotor loses at least) at the
        # axis' own microstep, or two counts of the check sensor, whichever is more; plus
        # the gear play between the motor and a sensor on the axis side (the profile's
        # backlash): the two differ by up to it after a reversal, with no step lost
        full_step_deg = microsteps / motor.steps_per_deg
        self.check_tol_deg = check_tol_deg if check_tol_deg is not None else max(
            4 * full_step_deg, 2 * getattr(getattr(check, "caps", None), "resolution_deg", 0.0)) + backlash_deg
        self._check_offset_deg: float | None = None

    def counts(self) -> int:
        return self.motor.steps()

    def read_deg(self) -> float:
        deg = self.reference_deg + self.motor.committed_steps() / self.motor.steps_per_deg
        if self.check is not None and self.motor.at_rest():
            self._compare(deg)            # (at rest: an I2C read's age is no error then)
        return deg

    def _compare(self, deg: float) -> None:
        try:
            abs_deg = self.check.read_deg()
        except SensorError:
            return                        # the count goes on; the check sensor's own fault is its own
        d = abs_deg - deg
        if self._check_offset_deg is None:
            self._check_offset_deg = d
            return
        err = wrap180_deg(d - self._check_offset_deg)
        if abs(err) > self.check_tol_deg:
            self.motor._lose(f"{self.name}: the step count and the absolute sensor differ by {err:+.2f} deg "
                             f"({round(err * self.motor.steps_per_deg):+d} steps lost); home the axis")

    def set_reference_deg(self, angle_deg: float) -> None:
        self.reference_deg = float(angle_deg) - self.motor.steps() / self.motor.steps_per_deg
        self._check_offset_deg = None
        self.motor.re_referenced()
        if self.check is not None and self.motor.at_rest():
            self._compare(float(angle_deg))     # where the two agree from now on

    def calibration(self) -> dict[str, Any]:
        return {"reference_deg": self.reference_deg}

    def load_calibration(self, values: dict[str, Any]) -> None:
        if "reference_deg" in values:
            self.reference_deg = float(values["reference_deg"])

    def identify(self) -> str:
        return f"step count {self.motor.steps()}" + (" + absolute check" if self.check is not None else "")
