"""The external safety chain, modelled: a motor-power enable that needs urc's heartbeat.

On iron (docs/hardware.md, "Safety chain") the heartbeat output feeds a retriggerable
monostable (CD4538B, pulse width T = RX x CX) whose output holds the motor-supply relay
in. Every rising edge of the heartbeat restarts the timer; when no edge comes for the
timeout (process frozen, killed, hung, the Pi rebooting or still booting) the relay
drops, the motor supply and the brake-coil supply open: the motors coast and the brakes
engage, whatever the GPIO lines do. A line stuck high or low gives no edges, so it
cannot hold the relay in either.

:class:`MotorPowerEnable` is that part on the simulator's clock: the simulated heartbeat
pin reports its rising edges here, and :class:`urc.hardware.sim.world.SimWorld` cuts the
axes' power at ``last_edge + timeout`` while integrating, so a process that freezes
(nothing runs, the clock goes on) or dies (the next world reads the last edge's wall time
from the truth file) stops the simulated motors exactly when the relay would.
"""

from __future__ import annotations

import math
import time
from typing import Any, Callable

#: the timeout the documented circuit gives (RX 220 kOhm x CX 1 uF, CD4538B: T = RX CX)
DEFAULT_TIMEOUT_S = 0.22


class MotorPowerEnable:
    """A retriggerable monostable on the heartbeat: motor power is on from a rising edge
    until ``timeout_s`` after the last one. Off at power-up (no edge yet)."""

    def __init__(self, timeout_s: float, now_s: Callable[[], float], *, trigger_pulled_down: bool = True):
        timeout_s = float(timeout_s)
        if not (math.isfinite(timeout_s) and 0.0 < timeout_s <= 10.0):
            raise ValueError(f"motor enable timeout must be in (0, 10] s, got {timeout_s!r}")
        self.timeout_s = timeout_s
        self._now_s = now_s
        #: clock time / wall time of the last rising edge (None: none yet)
        self.last_edge_s: float | None = None
        self.last_edge_wall_s: float | None = None
        self.edges = 0
        #: times power was cut by the timeout (a relay drop-out on iron)
        self.trips = 0
        self._level = False
        #: the documented circuit's 100 kOhm from +TR to GND: a trigger nothing drives reads
        #: low. Without it a floating CMOS input picks up mains hum, and hum is edges.
        self.trigger_pulled_down = bool(trigger_pulled_down)
        #: nothing drives the trigger (the line released under strict_gpiod, the Pi halted
        #: with its pins Hi-Z, the heartbeat wire broken)
        self.floating = False
        #: called with the clock time of a rising edge, before it is recorded (the
        #: world catches up to it: until then the old deadline holds)
        self.on_edge: Callable[[float], None] | None = None

    def release(self) -> None:
        """Nothing drives the trigger any more. Pulled down, it reads low: no edge, the
        relay drops at the timeout. Floating, hum retriggers it for as long as it floats."""
        self.floating = True
        if self.trigger_pulled_down:
            self._level = False

    def heartbeat(self, level: bool) -> None:
        """The heartbeat pin's new level (only a rising edge retriggers)."""
        self.floating = False
        level = bool(level)
        rising = level and not self._level
        self._level = level
        if not rising:
            return
        now = self._now_s()
        if self.on_edge is not None:
            self.on_edge(now)
        self.last_edge_s = now
        self.last_edge_wall_s = time.time()
        self.edges += 1

    def cut_at_s(self) -> float:
        """Clock time the power goes (or went) off: -inf before the first edge; +inf while
        a trigger with no pull-down floats (hum keeps retriggering it)."""
        if self.floating and not self.trigger_pulled_down:
            return math.inf
        return -math.inf if self.last_edge_s is None else self.last_edge_s + self.timeout_s

    def powered_at(self, t_s: float) -> bool:
        if self.floating and not self.trigger_pulled_down:
            return True
        return self.last_edge_s is not None and self.last_edge_s - 1e-9 <= t_s < self.cut_at_s()

    def cut_at_wall_s(self) -> float | None:
        """Wall time the power goes off if no further edge comes (for the truth file)."""
        return None if self.last_edge_wall_s is None else self.last_edge_wall_s + self.timeout_s

    def truth(self) -> dict[str, Any]:
        now = self._now_s()
        return {"timeout_s": self.timeout_s, "powered": self.powered_at(now), "edges": self.edges,
                "trips": self.trips}
