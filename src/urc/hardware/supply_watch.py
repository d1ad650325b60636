"""The safety chain's read-back watched while urc runs (review of issue 35, finding 1).

The start-up self-test (:mod:`.safety_test`) shows that the chain cuts when the heartbeat
stops. This watch shows the opposite case: the motor supply gone while the heartbeat
runs. The relay can drop on its own: its coil supply sags, an e-stop sits in the coil
circuit, a contact bounces. The drivers then get no power while urc goes on driving. A
step count goes on counting steps that a driver without its supply never made, so the
count is wrong and nothing shows it. On an axis with only a ``limit_min`` switch
(satnogs-v3), that count can drive the axis past its soft maximum.

:meth:`SupplyWatch.beat` is the hardware's part of each tick, right after the heartbeat
write (:meth:`Hardware.beat`): one read of the read-back input. Two OFF readings in a
row, while the heartbeat runs and the chain has had time to pick up, trip the watch; one
OFF reading is a contact bounce. :meth:`Hardware.motor_power_fault` then hands the guard
a ``motor_power`` fault. It latches like any other fault: it stops the rotator, shows in
status and never clears by itself. Each motor that keeps an open-loop count
(``supply_lost``: the step/dir driver) marks its position lost.

Every OFF episode is also passed to the motors (``supply_off``), the self-test's cut
included, and so is a heartbeat gap long enough to have let the relay drop (a frozen
controller) in which no reading saw OFF: the edge that ends it picks the relay up again
before the tick's read, and a Q read-back then reads ON at once. A step/dir chip whose logic runs on the motor supply resets its indexer then,
so the rotor can snap by up to 2 full steps when power returns.

What it cannot see: a supply lost upstream of the relay's contact (an e-stop in the
motor supply itself). The contact stays closed, so the read-back reads ON. A read-back
on Q (``motor_enable_sense_point = "q"``) also misses a relay that drops while Q still
drives its coil. Without a read-back input nothing shows either case.
"""

from __future__ import annotations

import logging
from typing import Any, Callable, Iterable

from .safety_test import DEFAULT_MARGIN_S

log = logging.getLogger(__name__)

#: after a new run of heartbeat edges (the first one, or one after a gap the relay may
#: have dropped in), the relay picks up and its contact stops bouncing (a few ms for
#: the small relays of docs/hardware.md) before an OFF reading counts
ARM_S = 0.1
#: OFF readings in a row that trip the watch (one is a contact bounce)
OFF_READINGS = 2


class SupplyWatch:
    """The read-back on each tick. ``motors()``: the axes' motors now, for their
    ``supply_lost(why)`` (on a trip) and ``supply_off()`` (on each OFF episode), where
    they have them."""

    def __init__(self, sense: Any, timeout_s: float, motors: Callable[[], Iterable[Any]],
                 margin_s: float = DEFAULT_MARGIN_S):
        self.sense, self.motors = sense, motors
        #: rising edges further apart than this may have let the relay drop: the
        #: monostable's period can be shorter than configured by the self-test's margin
        self.max_gap_s = max(float(timeout_s) - margin_s, 0.5 * float(timeout_s))
        self.what = "the relay's contact" if getattr(sense, "point", "contact") == "contact" else "Q"
        self._level = False
        self._rise_s: float | None = None
        self._armed_s: float | None = None
        #: OFF readings in a row while the heartbeat runs
        self.off_run = 0
        #: readings taken (the self-test's included): for tests and ``urc hw check``
        self.reads = 0
        self.trips = 0
        self.reason = ""
        self._pending = ""
        self._last_on: bool | None = None
        #: an OFF episode counted since the last rising edge (read, or by a gap)
        self._off_since_rise = False

    def running(self, now_s: float) -> bool:
        """The heartbeat's edges have kept the chain armed for at least ``ARM_S``."""
        return (self._armed_s is not None and self._rise_s is not None
                and now_s - self._armed_s >= ARM_S and now_s - self._rise_s <= self.max_gap_s)

    def beat(self, level: bool, now_s: float) -> None:
        """The heartbeat was just written to ``level`` at ``now_s``: read the enable."""
        level = bool(level)
        if level and not self._level:
            if self._rise_s is None or now_s - self._rise_s > self.max_gap_s:
                self._armed_s = now_s     # the chain (re)armed by this edge
                if self._rise_s is not None and not self._off_since_rise:
                    # the gap may have let the relay drop (a frozen controller: the cut by
                    # design), and this edge picks it up again before the read below: a Q
                    # read-back, or the model's instant relay, reads ON and the OFF episode
                    # goes unseen, while a DRV8825's indexer did reset. Counted as one.
                    self._off_episode()
            self._rise_s = now_s
            self._off_since_rise = False
        self._level = level
        running = self.running(now_s)
        try:
            on = bool(self.sense.read())
        except Exception as exc:  # (an unreadable read-back proves nothing: a fault, as a fault pin's)
            self.off_run = OFF_READINGS if running else 0
            if running:
                self._trip(f"the safety chain's read-back cannot be read ({exc}): urc cannot see "
                           "whether the motors have their supply")
            return
        self.observe(on)
        if on or not running:
            self.off_run = 0
            return
        self.off_run += 1
        if self.off_run == OFF_READINGS:
            self._trip(
                f"motor supply lost while urc drives: {self.what} read OFF {OFF_READINGS} ticks in a row with "
                "the heartbeat running (the relay dropped on its own: its coil supply, an e-stop in the coil "
                "circuit, a loose wire). Mend it, then clear the fault; a step count is lost (home the axes)")

    def observe(self, on: bool) -> None:
        """One reading of the enable (the tick's or the self-test's): each OFF episode
        goes to the motors' ``supply_off`` (a step/dir chip's indexer resets)."""
        self.reads += 1
        if not on and self._last_on is not False:
            self._off_episode()
        self._last_on = on

    def _off_episode(self) -> None:
        self._off_since_rise = True
        self._last_on = False
        for motor in self.motors():
            off = getattr(motor, "supply_off", None)
            if off is not None:
                off()

    def _trip(self, why: str) -> None:
        self.trips += 1
        self.reason = self._pending = why
        log.error("%s", why)
        for motor in self.motors():
            lost = getattr(motor, "supply_lost", None)
            if lost is not None:
                lost(why)

    def take_fault(self) -> str:
        """The trip's reason, once; again while the enable still reads OFF (a fault
        cleared with the supply still gone latches again)."""
        why = self._pending or (self.reason if self.off_run >= OFF_READINGS else "")
        self._pending = ""
        return why


__all__ = ["SupplyWatch", "ARM_S", "OFF_READINGS"]
