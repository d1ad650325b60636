"""The simulated step/dir stage (the plain simulator's steppers, and the gpio backend's
emulation behind its pins): lgpio's pulse queue on the virtual clock, and the driver
chip reading its STEP, DIR and ENABLE inputs into the simulator's stepper axis.

The queue follows lg's ``tx_pulse`` as :mod:`urc.hardware.gpio.stepdir` describes it (lgPthTx.c): up to
``LG_TX_BUF`` entries, each exactly ``cycles`` pulses of (high + low) microseconds, the
next entry starting when the previous one's last period ends; ``cut`` drops them all
at once. A train queued while none runs starts late, as lg's does: its record is
picked up when lg's thread next wakes (it sleeps 20 ms at a time when idle,
``pthTxDelayMicros = 20000``, lgPthTx.c:61) and its first edge is aligned to its period
(lgGpioCreateTxRec). Here the thread's wake-ups are the 20 ms grid of the clock: the
idle case, the longest delay (with another pin's train running lg wakes sooner). The chip
(:data:`..drivers.stepdir_chips.STEPDIR_CHIPS`) steps on each rising STEP edge in
the direction DIR has then, only while its enable input is at its active level; a DIR
change while pulses run (closer than its setup time to an edge) is counted in
``dir_violations`` and the steps of that entry go the new way (as on iron: the chip
samples DIR at the edge).

The plain simulator drives a profile whose physics has a stepper
(:attr:`.params.SimAxisParams.stepper`: satnogs-v3) through this stage as the gpio
backend does (:func:`build_sim_stepper`): urc's :class:`..drivers.stepper.StepDirMotor`
on the queue, its step count (:class:`..drivers.stepper.StepCountSensor`) the axis'
sensor, and the stepper model (:mod:`.stepper`) moving the axis, so a simulated
satnogs-v3 takes its position from the steps and loses them beyond pull-out, as the
iron does. Both keep lg's start latency: it is what urc's driver meets on a Pi.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any, Callable

from ..drivers.stepdir_chips import (LG_BAD_PWM_MICROS, LG_ERROR_TEXT, LG_MIN_PERIOD_US, LG_TX_BUF,
                                     LG_TX_QUEUE_FULL, StepDirChip, lg_error_code)

#: lg's thread sleeps this long between passes when no edge is due sooner (lgPthTx.c:61)
LG_IDLE_WAKE_S = 0.02


def lg_first_edge_s(now_s: float, period_us: int) -> float:
    """When lg's first rising edge of a train queued at ``now_s`` with none running
    comes: at the thread's next wake-up (the idle grid), plus ``ct - frac`` where
    ``frac`` is that wake-up's microsecond within the second modulo the period
    (lgGpioCreateTxRec, lgPthTx.c)."""
    wake_s = (math.floor(now_s / LG_IDLE_WAKE_S + 1e-9) + 1) * LG_IDLE_WAKE_S
    wake_us = round(wake_s * 1e6) % 1_000_000
    return wake_s + (period_us - wake_us % period_us) * 1e-6


class LgError(Exception):
    """lgpio's ``error`` as its Python raises it for a negative status (``exceptions``
    is True by default, ``_u2i``): ``error(error_text(status))``, so ``value`` is the
    text and no code comes with it (:func:`.stepdir.lg_error_code` maps it back)."""

    def __init__(self, value: str):
        super().__init__(value)
        self.value = value

    def __str__(self) -> str:
        return repr(self.value)


def lg_raise(code: int) -> LgError:
    """The exception lgpio raises for lg's ``code``."""
    return LgError(LG_ERROR_TEXT.get(code, f"unknown error {code}"))


class EmulatedTxQueue:
    """lg's pulse queue for one pin on ``now_s``; ``sink(n, period_s, t_s)`` gets each
    run of pulses emitted (``t_s``: the time of the run's last rising edge)."""

    def __init__(self, now_s: Callable[[], float], sink: Callable[[int, float, float], None]):
        self.now_s, self.sink = now_s, sink
        #: [high_us, low_us, cycles left, start of its next pulse (s)]
        self._entries: deque[list[Any]] = deque()
        self.emitted = 0
        self.cuts = 0

    def tx_pulse(self, high_us: int, low_us: int, cycles: int) -> int:
        """lg's ``tx_pulse`` on this pin as lgpio's Python has it (xSetAsPwm, lgGpio.c):
        (0, 0) stops a running train and returns 0, but with none running it is
        LG_BAD_PWM_MICROS, raised (:class:`LgError`) as lgpio raises every negative
        status."""
        self.advance()
        if not high_us and not low_us and self._entries:
            self._entries.clear()
            self.cuts += 1
            return 0
        if high_us + low_us < LG_MIN_PERIOD_US:
            raise lg_raise(LG_BAD_PWM_MICROS)
        if len(self._entries) >= LG_TX_BUF:
            raise lg_raise(LG_TX_QUEUE_FULL)
        start = self._entries[-1][3] + self._entries[-1][2] * (self._entries[-1][0] + self._entries[-1][1]) * 1e-6 \
            if self._entries else lg_first_edge_s(self.now_s(), int(high_us) + int(low_us))
        self._entries.append([int(high_us), int(low_us), int(cycles), start])
        return LG_TX_BUF - len(self._entries)

    def room(self) -> int:
        self.advance()
        return LG_TX_BUF - len(self._entries)

    def busy(self) -> bool:
        self.advance()
        return bool(self._entries)

    def queue(self, high_us: int, low_us: int, cycles: int) -> int:
        """(:meth:`urc.hardware.gpio.stepdir.LgpioStepPulses.queue`'s contract: lg's status, negative refused)"""
        try:
            return self.tx_pulse(high_us, low_us, cycles)
        except LgError as exc:
            return lg_error_code(exc)

    def cut(self) -> None:
        """As :meth:`urc.hardware.gpio.stepdir.LgpioStepPulses.cut`: the stop asked only while a train runs."""
        try:
            if self.busy():
                self.tx_pulse(0, 0, 0)
        except LgError:
            pass

    def advance(self) -> None:
        """Emit every pulse whose rising edge is due by now."""
        now = self.now_s()
        while self._entries:
            e = self._entries[0]
            period_s = (e[0] + e[1]) * 1e-6
            due = min(e[2], math.floor((now - e[3]) / period_s + 1e-9) + 1) if now >= e[3] else 0
            if due > 0:
                self.emitted += due
                e[2] -= due
                e[3] += due * period_s
                self.sink(due, period_s, e[3] - period_s)
            if e[2] > 0 or now < e[3]:
                return            # (lg's record stays busy to the end of its last period)
            end_s = e[3]
            self._entries.popleft()
            if self._entries and self._entries[0][3] < end_s:
                self._entries[0][3] = end_s

    def identify(self) -> str:
        return (f"lgpio tx_pulse queue (emulated), {LG_TX_BUF - self.room()} of {LG_TX_BUF} entries queued, "
                f"{self.emitted} pulses out")

    def __repr__(self) -> str:
        return "step pulses (lgpio tx_pulse, emulated)"


class EmulatedStepDirChip:
    """The driver chip on the mock pins: rising STEP edges (from the queue) into the
    simulated stepper axis (:class:`.stepper.StepperAxis`), in DIR's direction,
    while ENABLE is active and the motor supply is on (``powered()``)."""

    def __init__(self, chip: StepDirChip, axis: Any, dir_pin: Any, enable_pin: Any | None,
                 powered: Callable[[], bool] = lambda: True, positive_dir_level: bool = True,
                 enable_active_low: bool | None = None):
        self.chip, self.axis = chip, axis
        self.enable_active_low = chip.enable_active_low if enable_active_low is None else enable_active_low
        self.dir_pin, self.enable_pin, self.powered = dir_pin, enable_pin, powered
        self.positive_dir_level = positive_dir_level
        self.dir_violations = 0
        self._last_dir: bool | None = None
        self._last_edge_s = -math.inf
        self._powered = True
        #: translator resets by a motor-supply loss (the chips whose logic it feeds)
        self.translator_resets = 0

    def poll_power(self) -> None:
        """The motor supply's return after a loss resets the translator of a chip whose
        logic runs on it (:attr:`StepDirChip.home_on_motor_supply_loss`): the rotor snaps
        to the home state's nearest position as the outputs come on."""
        on = bool(self.powered())
        if on and not self._powered and self.chip.home_on_motor_supply_loss:
            self.axis.reset_translator()
            self.translator_resets += 1
        self._powered = on

    def identify(self) -> str:
        return (f"{self.chip.name} (simulated): {self.axis.steps_taken:+d} steps moved the rotor, "
                f"{self.axis.steps_lost} lost, worst pull-out margin {self.axis.worst_margin:.2f}")

    def enabled(self) -> bool:
        if self.enable_pin is None:
            return True
        level = bool(self.enable_pin.state)
        return level != self.enable_active_low

    def on_pulses(self, n: int, period_s: float, last_edge_s: float) -> None:
        self.poll_power()
        level = bool(self.dir_pin.state)
        first_edge_s = last_edge_s - (n - 1) * period_s
        if self._last_dir is not None and level != self._last_dir and \
                first_edge_s - self._last_edge_s < period_s:
            self.dir_violations += 1   # DIR turned round mid-train: no setup before its edge
        self._last_dir, self._last_edge_s = level, last_edge_s
        direction = 1 if level == self.positive_dir_level else -1
        self.axis.steps(n, direction, period_s, last_edge_s, enabled=self.enabled() and self.powered())


class EmulatedStepper:
    """The step/dir driver as the backend hands it out when emulated: each drive first
    brings the world and the pulses emitted up to now (one step of the iron, under the
    world's lock, as the gpio emulation's ``EmulatedMotor`` does)."""

    def __init__(self, driver: Any, world: Any, sync: Callable[[], None]):
        self.driver, self.world, self.sync = driver, world, sync

    def set_drive(self, duty: float) -> None:
        with self.world.lock:
            self.world.catch_up()
            self.sync()
            self.driver.set_drive(duty)

    def force_safe(self) -> None:
        with self.world.lock:
            self.world.catch_up()
            self.sync()
            self.driver.force_safe()

    def __getattr__(self, name: str) -> Any:
        return getattr(self.__dict__["driver"], name)


class SimLine:
    """A logic output the simulated chip reads (DIR, ENABLE as "outputs on")."""

    def __init__(self, state: bool = False):
        self.state = bool(state)

    def write(self, value: bool) -> None:
        self.state = bool(value)


def attach_stepper_model(name: str, motor: Any, sensor: Any, world: Any, *, dir_pin: Any,
                         enable_pin: Any | None, dir_reversed: bool, enable_active_low: bool | None,
                         ) -> tuple[EmulatedStepDirChip, Callable[[], None]]:
    """The simulator's stepper axis (:mod:`.stepper`) behind ``motor``'s STEP queue:
    the queue feeds the chip, which moves the model; ``sync`` (each poll, each drive)
    brings the pulses up to now and makes the model's angle the world axis' (its DC
    stand-in stays unpowered by its own drive), so limit switches, an AS5600 and the
    truth all see it. A jam on the world axis, or its hard stops, slip every step."""
    import dataclasses

    from .stepper import StepperAxis, satnogs_v3_stepper

    phys = world.axes[name]
    own = getattr(phys.p, "stepper", None)
    base = own if own is not None else satnogs_v3_stepper(motor.microsteps)
    # the gear ratio that gives this axis' steps per degree at its microstep
    params = dataclasses.replace(base, microsteps=motor.microsteps, gear_ratio=motor.steps_per_deg * 360.0 / (
        motor.microsteps * base.full_steps_per_turn))
    model = StepperAxis(params, phys.load_deg, stops_deg=(phys.p.hard_min_deg, phys.p.hard_max_deg))
    chip = EmulatedStepDirChip(motor.chip, model, dir_pin, enable_pin,
                               powered=lambda: bool(phys.powered), positive_dir_level=not dir_reversed,
                               enable_active_low=enable_active_low)
    motor.pulses.sink = chip.on_pulses

    def sync() -> None:
        chip.poll_power()
        model.jammed = bool(phys.jammed)
        motor.pulses.advance()
        phys.gear_deg = phys.load_deg = model.angle_deg
        phys.gear_deg_per_s = phys.load_deg_per_s = 0.0

    sensor.set_reference_deg(phys.load_deg)   # a fresh rotator starts referenced, as the sim's
    return chip, sync


def build_sim_stepper(name: str, caps: Any, world: Any, clock: Any, driver: str,
                      ) -> tuple[EmulatedStepper, Any, EmulatedStepDirChip, Callable[[], None]]:
    """The plain simulator's stepper axis ``name``: urc's step/dir driver for chip
    ``driver`` on a simulated pulse queue, its step count as the sensor (the profile's
    resolution: one microstep after the gear), the model behind it. Returns (motor,
    sensor, chip, sync)."""
    import dataclasses

    from ..drivers.stepdir_chips import STEPDIR_CHIPS
    from ..drivers.stepper import ENVELOPE_ACCEL_FACTOR, StepCountSensor, StepDirMotor

    ax_caps = caps.axis(name)
    microsteps = world.axes[name].p.stepper.microsteps
    steps_per_deg = 1.0 / ax_caps.sensor.resolution_deg
    chip_part = STEPDIR_CHIPS[driver]
    dir_out, enable = SimLine(), SimLine()
    pulses = EmulatedTxQueue(clock.now_s, sink=lambda *a: None)   # (the chip is fed in below)
    motor = StepDirMotor(name, chip_part, pulses, dir_out, enable, clock.now_s, steps_per_deg=steps_per_deg,
                         max_rate_deg_per_s=ax_caps.max_rate_deg_per_s,
                         max_accel_deg_per_s2=ENVELOPE_ACCEL_FACTOR * ax_caps.accel_deg_per_s2,
                         tick_s=1.0 / caps.loop_hz, microsteps=microsteps)
    count_caps = dataclasses.replace(ax_caps.sensor, kind="encoder", absolute=False, modulo_deg=None,
                                     resolution_deg=1.0 / steps_per_deg)
    sensor = StepCountSensor(count_caps, name, motor, microsteps=microsteps, backlash_deg=ax_caps.backlash_deg)
    # (SimLine holds the logical level: ENABLE True = outputs on, whatever the chip's own polarity)
    chip, sync = attach_stepper_model(name, motor, sensor, world, dir_pin=dir_out, enable_pin=enable,
                                      dir_reversed=False, enable_active_low=False)
    return EmulatedStepper(motor, world, sync), sensor, chip, sync
