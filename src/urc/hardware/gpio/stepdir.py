"""Step/dir stepper drivers on the Pi: their datasheet table and the step pulse train.

The datasheet figures (:data:`STEPDIR_CHIPS`, kept in :mod:`..drivers.stepdir_chips`
where the driver reads them too) are the interface timing a STEP/DIR/ENABLE input needs;
the pulse train writes pulses no shorter and a DIR change no closer to a STEP edge than
the chip allows.

Step pulses are library-timed, never a Python loop per step: lgpio's ``tx_pulse``
(lg 0.2.2, lgGpio.c ``xSetAsPwm`` and lgPthTx.c ``lgPthTx``, read at joan2937/lg
bcccd78). What it does, and what that means here:

* ``tx_pulse(handle, gpio, on_us, off_us, offset, cycles)`` appends an entry (on, off,
  cycles) to the pin's queue of ``LG_TX_BUF`` = 10 entries and returns the free slots
  (``LG_TX_QUEUE_FULL`` when none). Times are whole microseconds and one period must
  exceed ``lgMinTxDelay`` = 10 us. An entry with ``cycles`` > 0 emits exactly that many
  pulses, then the next entry starts; the last finite entry ends with the pin low. So
  the count is exact: a pulse queued is emitted unless the queue is cut
  (``tx_pulse(h, g, 0, 0)``: the record goes inactive at once, mid-entry).
* ``tx_room`` is 10 minus the entries queued, ``tx_busy`` whether any is running. lg
  does not say how many pulses of the running entry are out, so the driver keeps its
  own schedule of the entries it queued (:meth:`..drivers.stepper.StepDirMotor.steps`)
  and reads the count from it. That schedule starts a train when it is queued, but lg
  starts it later: the new record is picked up when lg's thread next wakes, which idle
  is up to 20 ms away (``pthTxDelayMicros = 20000``, lgPthTx.c:61), and its first edge
  is then aligned to its period (lgGpioCreateTxRec). So while a train runs the count
  leads the pulses by up to 20 ms of steps and a period (65 at 3200 steps/s); once lg's
  queue has drained (``tx_busy`` 0, which ``at_rest`` requires: every normal stop) it
  is exact.
* The pulses are timed by lg's own thread (``lgPthTx``), on a Pi 4 and a Pi 5 alike
  (lg has no DMA path; on a Pi 5 the pins are the RP1's: gpiozero 2.0.1's
  LGPIOFactory opens /dev/gpiochip4 on a Pi 5 where it exists, else gpiochip0): it
  sleeps with ``clock_nanosleep`` to an absolute deadline for every edge and writes the
  line through the gpiochip character device. Every pulse is therefore two thread
  wake-ups and two ioctls: the edges jitter by the kernel's wake-up latency (measured
  below on this machine; not on a Pi: there is none) and a late edge is late, never
  dropped, because deadlines are absolute (``pthTxReq`` advances by the nominal period
  whatever the wake-up was).
* lg starts that thread in ``gpiochip_open`` with default attributes, so it inherits
  the opener's scheduling: urc's control process opens the chip after raising itself to
  SCHED_FIFO 5 (``service.control_process._realtime``, with the systemd unit's
  CAP_SYS_NICE), so the pulse thread runs real-time there; elsewhere it runs at normal
  priority.
* After a late wake-up lg writes the overdue edges back to back (each loop pass handles
  one edge and the next deadline is already past): the count stays exact, but the steps
  come as a burst the rotor may not follow. That, not the count, is this method's risk.
* The SatNOGS rate, 3200 steps/s (1/8 microstep, the firmware's top speed), is a period
  of 312 us: 6400 wake-ups a second. ``bench/step_pulse_bench.py`` measures lg's loop
  (without the ioctl) on the machine it runs on. On the shared, loaded 2-core VM this was
  written on, at SCHED_FIFO 5: edge lateness p50 30 us at 3200 steps/s, but p99 29 ms
  and max 54 ms (the VM's stolen time): it kept up (p99 under a quarter period) only at
  800 steps/s; at normal priority p99 was 18 ms. A Pi running only urc should do far
  better (no hypervisor), but that is not measured here: run the bench on the Pi.
  Where the bursts matter, the AS5600 check (:class:`..drivers.stepper.StepCountSensor`)
  turns what they cost into a fault instead of an unseen error.
* 1/16 microstep at the same axis speed doubles the rate (6400 steps/s); the 51 kHz of
  x16 on the firmware's 3200 figure would be 102 000 wake-ups a second, beyond any
  per-edge thread (here each wake-up alone took 16 us). :data:`MAX_LIBRARY_TIMED_HZ` is
  the ceiling this module accepts; a faster axis needs hardware timing.

Not chosen: hardware PWM (the peripheral's clock, jitter-free) has no pulse count, so a
stop cuts the train at an unknown step, and its two (Pi 4) or four (Pi 5) channels serve
the DC bridges on other machines; pigpio's DMA waves are hardware-timed and counted but
pigpio does not run on a Pi 5; the Pi 5's RP1 PIO (Raspberry Pi's ``piolib``) could
generate counted trains in hardware but was not tried here. Those are the upgrade path
if the bench on a Pi shows bursts.
"""

from __future__ import annotations

import logging
from typing import Any

from ..drivers.stepdir_chips import (LG_BAD_PWM_MICROS, LG_ERROR_TEXT, LG_GPIO_NOT_AN_OUTPUT,  # noqa: F401
                                     LG_MIN_PERIOD_US, LG_TX_BUF, LG_TX_QUEUE_FULL, MAX_LIBRARY_TIMED_HZ,
                                     STEPDIR_CHIPS, StepDirChip, lg_error_code, pulse_times_us)

log = logging.getLogger(__name__)

class LgpioStepPulses:
    """The STEP pin as lgpio's pulse queue (on a Pi; the emulation has its own,
    :class:`..gpio.emulate_stepdir.EmulatedTxQueue`, with the same calls)."""

    def __init__(self, factory: Any, pin: int):
        import lgpio
        self._lg = lgpio
        self.handle = factory._handle   # gpiozero's LGPIOFactory chip handle
        self.pin = pin
        lgpio.gpio_claim_output(self.handle, pin, 0)

    def queue(self, high_us: int, low_us: int, cycles: int) -> int:
        """``cycles`` pulses appended; the free entries left, or lg's status when refused
        (negative: e.g. LG_TX_QUEUE_FULL -96, mapped back from the text lgpio raises,
        :func:`lg_error_code`; -1 for a status not known here)."""
        try:
            return int(self._lg.tx_pulse(self.handle, self.pin, high_us, low_us, 0, cycles))
        except self._lg.error as exc:
            log.debug("GPIO%d: pulses not queued (%s)", self.pin, exc)
            return lg_error_code(exc, getattr(self._lg, "error_text", None))

    def room(self) -> int:
        return int(self._lg.tx_room(self.handle, self.pin, self._lg.TX_PWM))

    def busy(self) -> bool:
        return bool(self._lg.tx_busy(self.handle, self.pin, self._lg.TX_PWM) > 0)

    def cut(self) -> None:
        """Every queued pulse dropped now, the pin low (mid-entry: the count is lost).

        lg stops a train with ``tx_pulse(h, g, 0, 0)`` only while one runs: with none
        (at rest) xSetAsPwm's else-branch finds 0 + 0 not over lgMinTxDelay and returns
        LG_BAD_PWM_MICROS (-86; joan2937/lg bcccd78, lgGpio.c xSetAsPwm, lgpio.h:2960),
        which lgpio's Python raises. So it is asked only while busy, and a train that
        ended between the two calls (the same error) is no failure: the pin goes low
        either way."""
        try:
            if self._lg.tx_busy(self.handle, self.pin, self._lg.TX_PWM) > 0:
                self._lg.tx_pulse(self.handle, self.pin, 0, 0, 0, 0)
        except self._lg.error as exc:
            log.debug("GPIO%d: no train to cut (%s)", self.pin, exc)
        finally:
            self._lg.gpio_write(self.handle, self.pin, 0)

    def identify(self) -> str:
        return (f"GPIO{self.pin}: lgpio tx_pulse queue, {LG_TX_BUF - self.room()} of {LG_TX_BUF} entries "
                "queued (library-timed by lg's thread)")

    def __repr__(self) -> str:
        return f"GPIO{self.pin} step pulses (lgpio tx_pulse)"
