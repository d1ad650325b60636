"""Pin parts over gpiozero's pin API (lgpio on a Pi, MockFactory when emulated).

Only gpiozero's pin layer is used (``factory.pin(n)``: function, pull, edges,
when_changed, frequency, state), so the same code runs on LGPIOFactory and on
MockFactory pins the simulator drives. gpiozero has no quadrature decoder with x4
counting and error detection (RotaryEncoder counts detents), hence :class:`PinQuadrature`.

What lgpio does that shapes this module (lgpio 0.2.2 ``lgpio.py``, gpiozero 2.0.1
``pins/lgpio.py``):

* Edge callbacks run on lgpio's one notification thread, which reads the kernel's
  reports (timestamp, chip, gpio, level) from a FIFO and calls every callback in turn.
  A callback that raises ends that thread for good: every edge callback of the process
  stops, silently. So every handler here is guarded (:func:`guarded`): an exception is
  caught, counted and logged, and the part then reports a fault instead of counts.
* Reports arrive late and in bursts (the thread is a Python thread); each carries the
  level the line went to. The live level (``pin.state``) may have changed many times
  since, so the decoders count from the levels in the reports, never from a read.
* ``factory.pin(n)`` claims the line as an input with its bias disabled (SET_PULL_NONE:
  the boot pull is gone from then on); ``function = "output"`` then claims it as an
  output at level 0, and a pin's ``close()`` makes it an input again (floating).
  Outputs are therefore claimed at their safe level in one call (:func:`claim_output`)
  and never closed: at exit they stay driven at the safe level until the process ends.
  After that, on Raspberry Pi OS, a released output keeps its last level
  (``persist_gpio_outputs``, on by default) — so a killed process's outputs go on
  driving until the takeover or the safety chain stops them; with
  ``dtparam=strict_gpiod`` the lines float instead (no boot pull: gpiozero disabled
  it), and only the external pull resistors hold them.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any, Callable

from ..parts import PartError

log = logging.getLogger(__name__)

# x4 decoding: state = A<<1 | B; forward order 00 -> 01 -> 11 -> 10 -> 00.
#: (previous state << 2 | new state) -> count change; None = both channels changed (an
#: edge was missed: direction unknown, counted as an error, not guessed)
_FWD = {0b00: 0b01, 0b01: 0b11, 0b11: 0b10, 0b10: 0b00}
QUAD_TABLE: dict[int, int | None] = {}
for _p in range(4):
    for _n in range(4):
        QUAD_TABLE[_p << 2 | _n] = (0 if _p == _n else 1 if _FWD[_p] == _n
                                    else -1 if _FWD[_n] == _p else None)


def quad_decode(prev: int, new: int) -> int | None:
    return QUAD_TABLE[prev << 2 | new]


def claim_output(pin: Any, level: bool) -> None:
    """Make ``pin`` an output already driving ``level`` (no glitch through another
    level): on lgpio one ``gpio_claim_output`` with the level, elsewhere gpiozero's
    ``output_with_state``."""
    factory = getattr(pin, "factory", None)
    handle = getattr(factory, "_handle", None)
    if type(pin).__name__ == "LGPIOPin" and handle is not None:
        import lgpio
        lgpio.gpio_claim_output(handle, pin._number, int(bool(level)))
        return
    from gpiozero.pins.mock import MockPin
    if isinstance(pin, MockPin):
        # gpiozero's default output_with_state is "function, then state": a moment at
        # the old level. The emulation models lgpio's one-call claim instead.
        pin._state = bool(level)
        pin.function = "output"
        return
    pin.output_with_state(bool(level))


def guarded(owner: Any, fn: Callable[..., None]) -> Callable[..., None]:
    """``fn`` as a pin callback that never raises into the pin library's thread: an
    exception is counted in ``owner.callback_errors`` and logged (the first, then every
    100th), and the part reports a fault from then on. gpiozero holds a callback only
    weakly, so the owner keeps it (``owner._handlers``)."""
    if not hasattr(owner, "callback_errors"):
        owner.callback_errors = 0

    def handler(*args: Any) -> None:
        try:
            fn(*args)
        except Exception:
            owner.callback_errors += 1
            if owner.callback_errors == 1 or owner.callback_errors % 100 == 0:
                log.exception("%s: edge callback failed (%d so far); its counts are no longer trusted",
                              owner, owner.callback_errors)
    owner.__dict__.setdefault("_handlers", []).append(handler)
    return handler


def _check_callbacks(owner: Any) -> None:
    if owner.callback_errors:
        raise PartError(f"{owner}: {owner.callback_errors} edge callback(s) failed: edges may be "
                        "lost (see the log)")


def _event_level(pin: Any, state: Any) -> bool:
    """The level an edge report carries (the live level only if it carries none)."""
    return bool(pin.state) if state is None else bool(state)


class PinOut:
    """Digital output (also the heartbeat: ``write(bool)``).

    ``active_low``: the load is on when the pin is low (the usual relay modules); the
    driver still writes logical levels. The pin is claimed already at the safe level:
    logical off, i.e. high for an active-low output.
    """

    def __init__(self, factory: Any, pin: int, *, initial: bool = False, active_low: bool = False):
        self.number = pin
        self.active_low = bool(active_low)
        self.pin = factory.pin(pin)
        claim_output(self.pin, bool(initial) != self.active_low)

    def write(self, value: bool) -> None:
        self.pin.state = bool(value) != self.active_low

    def read_back(self) -> bool:
        """The logical level (True = the load is on)."""
        return bool(self.pin.state) != self.active_low

    def __repr__(self) -> str:
        return f"GPIO{self.number} output" + (" (active low)" if self.active_low else "")


class PinPwm:
    """PWM output (lgpio software PWM on any pin; hardware PWM pins 12/13/18/19)."""

    def __init__(self, factory: Any, pin: int, *, frequency_hz: float = 1000.0):
        self.pin = factory.pin(pin)
        self.frequency_hz = frequency_hz
        #: set by stop: the pin stays low for good
        self.closed = False
        claim_output(self.pin, False)
        self.pin.frequency = frequency_hz
        self.pin.state = 0.0

    def write_duty(self, duty: float) -> None:
        # after stop lgpio takes a state as a plain level (gpiozero's LGPIOPin: no PWM,
        # gpio_write(bool(duty))): any duty above 0 would drive the pin high for good
        if self.closed:
            return
        self.pin.state = min(1.0, max(0.0, float(duty)))
        if self.closed:
            # stopped meanwhile from another thread, maybe inside this write: LGPIOPin
            # notes the duty, then calls tx_pwm, so lgpio may run PWM again that gpiozero
            # thinks stopped (and would not stop again): started known, then stopped
            self.pin.frequency = self.frequency_hz
            self._low()

    def read_back(self) -> float:
        return float(self.pin.state)

    def stop(self) -> None:
        """End lgpio's PWM on the pin (``tx_pwm`` 0, 0), then hold it low, for good (a
        later write_duty is refused)."""
        self.closed = True    # first: a write_duty under way sees it after its write
        self._low()

    def _low(self) -> None:
        self.pin.frequency = None
        self.pin.state = False


class PinIn:
    """Digital input with pull-up and edge timing (limit switch, power-fail line).

    ``debounce_s``: :meth:`read` returns a new level only once no edge has come for that
    long (a bouncing contact, pickup on a long cable); ``now_s`` is the clock it is
    timed on (the control loop's). ``urgent_level`` (a limit's active level): that level
    is reported at once — whenever the live level or any edge report since the last read
    has it — and only the way back to the other level waits for ``debounce_s`` of quiet.
    Noise on the cable can then hold a limit active a little longer, never hide it (a
    symmetric debounce held the old level for as long as the noise lasted)."""

    def __init__(self, factory: Any, pin: int, *, pull: str = "up", on_edge: Any = None,
                 debounce_s: float = 0.0, now_s: Callable[[], float] = time.monotonic,
                 urgent_level: bool | None = None):
        self.number = pin
        self.pin = factory.pin(pin)
        self.pin.function = "input"
        self.pin.pull = pull
        self.debounce_s = float(debounce_s)
        self.urgent_level = urgent_level
        self._now_s = now_s
        self._edges = 0
        self._last_edge_s: float | None = None
        self._on_edge = on_edge
        self._stable: bool | None = None       # the first read takes the live level
        # reports of the urgent level: written on lgpio's thread, read by read()
        self._urgent_reports = 0
        self._urgent_seen = 0
        self.pin.edges = "both"
        self.pin.when_changed = guarded(self, self._changed)

    def _changed(self, ticks: Any = None, state: Any = None) -> None:
        self._edges += 1
        self._last_edge_s = self._now_s()
        level = _event_level(self.pin, state)
        if self.urgent_level is not None and level == self.urgent_level:
            self._urgent_reports += 1
        if self._on_edge is not None:
            self._on_edge(level)

    def read(self) -> bool:
        live = bool(self.pin.state)
        if self.urgent_level is not None:
            reports = self._urgent_reports
            urgent = live == self.urgent_level or reports != self._urgent_seen
            self._urgent_seen = reports
            if urgent:
                self._stable = self.urgent_level
                return self._stable
        if self._stable is None or self.debounce_s <= 0.0 or self._last_edge_s is None or \
                self._now_s() - self._last_edge_s >= self.debounce_s - 1e-9:
            self._stable = live
        return self._stable

    def edges(self) -> int:
        return self._edges

    def last_edge_s(self) -> float | None:
        return self._last_edge_s

    def __repr__(self) -> str:
        return f"GPIO{self.number} input"


class PinQuadrature:
    """x4 quadrature counter on two pins (optional index Z latches the count).

    The state machine advances on the level each edge report carries, in the order
    the reports come (lgpio delivers one line's and both lines' reports in time order,
    however late): a report whose level the channel already had means an edge of that
    channel was lost, counted as an error, never guessed."""

    def __init__(self, factory: Any, a: int, b: int, z: int | None = None):
        self.numbers = (a, b, z)
        self.a, self.b = factory.pin(a), factory.pin(b)
        for p in (self.a, self.b):
            p.function = "input"
            p.pull = "up"
        self._lock = threading.Lock()
        self._count = 0
        self._errors = 0
        self._index: int | None = None
        #: index (Z) pulses seen
        self.index_pulses = 0
        self._state = (1 if self.a.state else 0) << 1 | (1 if self.b.state else 0)
        self.a.edges = self.b.edges = "both"
        self.a.when_changed = guarded(self, lambda ticks=None, state=None: self._edge(2, self.a, state))
        self.b.when_changed = guarded(self, lambda ticks=None, state=None: self._edge(1, self.b, state))
        self.z = None
        if z is not None:
            self.z = factory.pin(z)
            self.z.function = "input"
            self.z.pull = "up"
            self.z.edges = "rising"
            self.z.when_changed = guarded(self, self._index_edge)

    def _edge(self, bit: int, pin: Any, state: Any) -> None:
        level = _event_level(pin, state)
        with self._lock:
            old = self._state
            new = (old | bit) if level else (old & ~bit)
            if new == old:
                self._errors += 1          # this channel's previous edge never came
                return
            d = QUAD_TABLE[old << 2 | new]
            if d is None:                  # cannot happen: one channel changes per report
                self._errors += 1
            else:
                self._count += d
            self._state = new

    def _index_edge(self, ticks: Any = None, state: Any = None) -> None:
        with self._lock:
            self._index = self._count
            self.index_pulses += 1

    def count(self) -> int:
        _check_callbacks(self)
        return self._count

    def index_count(self) -> int | None:
        return self._index

    def errors(self) -> int:
        return self._errors

    def __repr__(self) -> str:
        a, b, z = self.numbers
        return f"encoder GPIO{a}/GPIO{b}" + (f"/Z GPIO{z}" if z is not None else "")


class PinPulseCounter:
    """SPID reed contact to ground: one count per closure (falling edge, pin pulled up).

    ``debounce_s``: a falling edge counts only when the line had been high (the contact
    open) for at least that long before it. Both edges are requested, so bounce on
    closing (the contact re-opens for a moment) and on opening (it re-closes for a
    moment) both make short high or low spells and are rejected (counted in
    ``rejected``); a symmetric "time since the last counted pulse" rule counted the
    re-closures of an opening contact, half a period after the pulse. Timed on the
    reports' own timestamps (``factory.ticks_diff``), so late or bunched callbacks do
    not change what is counted. A falling report with no rising one before it (a lost
    report) counts if it is at least ``debounce_s`` after the previous report."""

    def __init__(self, factory: Any, pin: int, *, debounce_s: float = 0.0):
        self.number = pin
        self.factory = factory
        self.pin = factory.pin(pin)
        self.pin.function = "input"
        self.pin.pull = "up"
        self.debounce_s = float(debounce_s)
        self._count = 0
        self._high = bool(self.pin.state)      # the level of the last report
        self._high_since: Any = None           # ticks of the last rising report (None: long ago)
        self._last_ticks: Any = None           # ticks of the last report
        #: falling edges rejected as bounce
        self.rejected = 0
        self.pin.edges = "both"
        self.pin.when_changed = guarded(self, self._edge)

    def _held_s(self, ticks: Any, since: Any) -> float | None:
        if ticks is None or since is None:
            return None
        return float(self.factory.ticks_diff(ticks, since))

    def _edge(self, ticks: Any = None, state: Any = None) -> None:
        level = _event_level(self.pin, state)
        was_high, last = self._high, self._last_ticks
        self._high, self._last_ticks = level, ticks
        if level:
            self._high_since = ticks
            return
        if self.debounce_s > 0.0:
            held = self._held_s(ticks, self._high_since if was_high else last)
            if held is not None and held < self.debounce_s - 1e-9:
                self.rejected += 1
                return
        self._count += 1

    def count(self) -> int:
        _check_callbacks(self)
        return self._count

    def __repr__(self) -> str:
        return f"pulse input GPIO{self.number}"


def release_inputs(factory: Any) -> None:
    """At close: end the inputs' callbacks and give their lines back, but leave every
    output claimed at the level last written (gpiozero's ``close`` would make them
    floating inputs): they stay driven safe until the process ends."""
    for key, pin in list(factory.pins.items()):
        try:
            if pin.function == "input":
                pin.when_changed = None
                pin.close()
                del factory.pins[key]
        except Exception:  # pragma: no cover - closing must go on
            log.exception("gpio: could not release %r", pin)
