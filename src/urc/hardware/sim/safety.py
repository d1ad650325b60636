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

The chain's own faults are modelled too (injected as the world's ``"chain"`` faults,
:data:`CHAIN_FAULT_KINDS`), so the start-up self-test (:mod:`urc.hardware.safety_test`)
can be shown to catch them: ``enable_stuck`` (Q, or Q1 failed shorted, holds the coil on
whatever the trigger does), ``trigger_floating`` (+TR cut off from the heartbeat and
its pull-down: hum retriggers it, the relay never drops), ``relay_dropout`` (delay_s:
the contact opens that long after Q falls; an edge meanwhile keeps it closed) and
``contact_welded`` (the contact stays closed), and ``contact_open`` (the relay drops
while Q still drives it: its coil supply sagging, an e-stop in the coil circuit, a loose
wire; the heartbeat cannot bring it back until the fault is cleared: what the read-back
watch, :mod:`urc.hardware.supply_watch`, must see). Two points can be read back: Q
(:meth:`MotorPowerEnable.q_at`) and the contact (:meth:`MotorPowerEnable.powered_at`,
which is also what the motors get).
"""

from __future__ import annotations

import math
import time
from typing import Any, Callable

#: the timeout the documented circuit gives (RX 220 kOhm x CX 1 uF, CD4538B: T = RX CX)
DEFAULT_TIMEOUT_S = 0.22

#: the chain's faults (``SimWorld.inject("chain", kind, ...)``)
CHAIN_FAULT_KINDS = ("enable_stuck", "trigger_floating", "relay_dropout", "contact_welded", "contact_open")
#: a relay_dropout fault's delay when none is given (a DC relay with a plain diode across
#: its coil releases in tens of ms; with the documented Zener in a few)
DEFAULT_DROPOUT_S = 0.03


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
        #: the contact opens this long after Q falls (0: at once; the relay_dropout fault)
        self.dropout_s = 0.0
        #: the injected faults, {kind: kwargs}
        self.faults: dict[str, dict[str, Any]] = {}

    # ------------------------------------------------------------------ faults
    def inject(self, kind: str, **kw: Any) -> None:
        if kind not in CHAIN_FAULT_KINDS:
            raise ValueError(f"unknown safety chain fault {kind!r}; expected one of {', '.join(CHAIN_FAULT_KINDS)}")
        if kind == "relay_dropout":
            delay_s = float(kw.get("delay_s", DEFAULT_DROPOUT_S))
            if not (math.isfinite(delay_s) and 0.0 <= delay_s <= 10.0):
                raise ValueError(f"relay_dropout delay_s must be in [0, 10] s, got {delay_s!r}")
            self.dropout_s = delay_s
        self.faults[kind] = dict(kw)

    def clear(self, kind: str | None = None) -> None:
        for k in list(self.faults) if kind is None else [kind]:
            if k not in self.faults:
                continue
            hummed = self._hum()
            del self.faults[k]
            if k == "relay_dropout":
                self.dropout_s = 0.0
            if hummed and not self._hum():
                self._retriggered()       # hum's last edge was just now

    def _hum(self) -> bool:
        """Hum retriggers the trigger: it floats with nothing holding it low."""
        return "trigger_floating" in self.faults or (self.floating and not self.trigger_pulled_down)

    def _q_stuck(self) -> bool:
        return "enable_stuck" in self.faults or self._hum()

    def _retriggered(self) -> None:
        self.last_edge_s = self._now_s()
        self.last_edge_wall_s = time.time()

    def release(self) -> None:
        """Nothing drives the trigger any more. Pulled down, it reads low: no edge, the
        relay drops at the timeout. Floating, hum retriggers it for as long as it floats."""
        self.floating = True
        if self.trigger_pulled_down:
            self._level = False

    def heartbeat(self, level: bool) -> None:
        """The heartbeat pin's new level (only a rising edge retriggers). With the
        trigger_floating fault the pin no longer reaches +TR: hum drives it instead."""
        if "trigger_floating" in self.faults:
            return
        if self.floating and not self.trigger_pulled_down:
            self._retriggered()           # hum until now
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

    def q_off_at_s(self) -> float:
        """Clock time Q falls (or fell): -inf before the first edge; +inf while Q is
        stuck on or hum retriggers the trigger."""
        if self._q_stuck():
            return math.inf
        return -math.inf if self.last_edge_s is None else self.last_edge_s + self.timeout_s

    def held_open(self) -> bool:
        """The contact is open whatever Q does (the contact_open fault)."""
        return "contact_open" in self.faults and "contact_welded" not in self.faults

    def cut_at_s(self) -> float:
        """Clock time the relay's contact opens (or opened), cutting the power: Q's fall
        plus the relay's drop-out time; -inf before the first edge or while it is held
        open, +inf if it never will (Q stuck on, a floating trigger, a welded contact)."""
        if "contact_welded" in self.faults:
            return math.inf
        if self.held_open():
            return -math.inf
        q_off_s = self.q_off_at_s()
        return q_off_s + self.dropout_s if math.isfinite(q_off_s) else q_off_s

    def q_at(self, t_s: float) -> bool:
        """The monostable's output Q (the relay's coil drive) at clock time ``t_s``."""
        if self._q_stuck():
            return True
        return self.last_edge_s is not None and self.last_edge_s - 1e-9 <= t_s < self.q_off_at_s()

    def powered_at(self, t_s: float) -> bool:
        """The relay's contact closed (motor power on) at clock time ``t_s``."""
        if "contact_welded" in self.faults:
            return True
        if self.held_open():
            return False
        if self._q_stuck():
            return True
        return self.last_edge_s is not None and self.last_edge_s - 1e-9 <= t_s < self.cut_at_s()

    def cut_at_wall_s(self) -> float | None:
        """Wall time the power goes off if no further edge comes (for the truth file):
        None before the first edge (off), +inf if it never will."""
        if self.cut_at_s() == math.inf:
            return math.inf
        if self.last_edge_wall_s is None or self.held_open():
            return None
        return self.last_edge_wall_s + self.timeout_s + self.dropout_s

    def truth(self) -> dict[str, Any]:
        now = self._now_s()
        return {"timeout_s": self.timeout_s, "powered": self.powered_at(now), "q": self.q_at(now),
                "edges": self.edges, "trips": self.trips, "faults": sorted(self.faults)}


class SimEnableSense:
    """The chain's read-back input on the simulator: the contact (the default) or Q, read
    from the model (``read()``: True while the enable is on)."""

    def __init__(self, enable: MotorPowerEnable, now_s: Callable[[], float], point: str = "contact"):
        if point not in ("contact", "q"):
            raise ValueError(f"motor_enable_sense must be contact or q, got {point!r}")
        self.enable, self._now_s, self.point = enable, now_s, point

    def read(self) -> bool:
        t_s = self._now_s()
        return self.enable.powered_at(t_s) if self.point == "contact" else self.enable.q_at(t_s)
