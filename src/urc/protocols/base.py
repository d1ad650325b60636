"""What every protocol session is and what it may do.

Sessions are sans-I/O (h11 style): bytes in, complete replies out, no sockets, no
asyncio, no clock of their own. A thin adapter in :mod:`urc.servers` serves a session
over TCP, a serial port, a pseudo-terminal or UDP, one session per connection.

Sessions act on the rotator only through :class:`RotatorPort`, which the rotator
service implements: limits, keep-out zones, wrap and faults are enforced there, once,
for every protocol. A command the session did not fully understand never reaches it.
A session reads the status from the port directly (no round trip: the I/O process
keeps the newest), and asks for everything else by yielding a request
(:mod:`urc.model.effects`): ``receive()`` is a generator, ``value = yield Goto(az, el)``,
that returns its replies; its driver performs each request (a test at once, the server
adapter by awaiting the control process) and sends back the result or throws the
rotator's exception in at that ``yield``.
"""

from __future__ import annotations

import logging
import time
from collections import Counter
from typing import Any, Callable, Generator, Protocol, runtime_checkable

from ..errors import UrcError
from ..model.snapshot import Status

#: no session buffers more than this many bytes of an unfinished command; beyond it the
#: partial input is dropped (and answered with the protocol's error, where it has one).
MAX_PENDING_BYTES = 4096


class RotatorPort(Protocol):
    """The rotator service's public command API (see urc.rotator.rotator.Rotator).

    Every method validates at once and raises ``urc.errors.CommandRejected`` (with a
    ``reason``: "limit", "keepout", "fault", "uncertain", "invalid") before anything moves.
    Angles are sky azimuth 0..360 (values outside name a cable-wrap pose, e.g. 400 on a
    450 deg rotator) and elevation (past 90 names a flipped pose on 0..180 rotators).
    """

    def status(self) -> Status: ...
    def goto(self, az_deg: float, el_deg: float) -> list: ...
    def goto_az(self, az_deg: float) -> list: ...
    def goto_el(self, el_deg: float) -> list: ...
    def goto_pose(self, az_m_deg: float, el_m_deg: float) -> list: ...
    def park(self) -> list: ...
    def stop(self, axis: str | None = None) -> None: ...
    def move(self, axis: str, direction: int, speed_frac: float = 1.0) -> None: ...
    def set_position(self, az_deg: float | None = None, el_deg: float | None = None) -> None: ...
    def clear_faults(self) -> None: ...
    def set_overshoot(self, axis: str, overshoot_deg: float) -> None: ...
    def overshoot_deg(self, axis: str) -> float: ...


@runtime_checkable
class Session(Protocol):
    """One client connection's protocol state."""

    #: set when the client asked to close (rotctld ``q``); the adapter then closes.
    #: (Sessions with unsolicited output — G4JNT stream, SARCNET monitor — also set a
    #: class attribute ``wants_tick = True``; only those are ticked by the adapters.
    #: A session that changes its line rate (Tartu ``BAUD``) sets ``baud_request`` to
    #: the new rate; a serial adapter applies it after writing the replies and clears
    #: it. ``default_baud`` on the class: its serial rate when the config names none.)
    closed: bool
    #: (its generators are urc.model.effects.Effects: not imported here, since the
    #: codecs beside this module are imported by the bridge backend, which must not load
    #: the link's messages)
    #: the port its status is read from and its requests are performed on
    rotator: RotatorPort

    def receive(self, data: bytes) -> Generator[Any, Any, list[bytes]]:
        """Feed received bytes (any split, even one byte at a time): yields the port
        requests its commands make, in order, and returns the complete replies now due,
        in order; the adapter writes each one with a single write."""

    def tick(self, now_s: float) -> list[bytes] | Generator[Any, Any, list[bytes]]:
        """Unsolicited output due by ``now_s`` (the G4JNT position stream). Most return [];
        one that acts on the rotator (SARCNET's demo) is a generator as ``receive``."""


#: what a session answers with its protocol's error reply: bad input (urc.errors.ProtocolError
#: and each protocol's subclass), a refusal by the rotator (CommandRejected), a hardware
#: failure. Every one of them is a UrcError; any other exception is a bug in urc.
EXPECTED_ERRORS: tuple[type[BaseException], ...] = (UrcError,)

#: unexpected exceptions caught in sessions (and the adapters around them), per
#: protocol: each is a bug. Tests assert this stays unchanged (tests/protocols).
INTERNAL_ERRORS: Counter[str] = Counter()


def internal_error(log: logging.Logger, protocol: str, what: str, *args: object) -> None:
    """Call from an ``except Exception`` block around one command: the connection
    survives (the protocol answers its generic error), but the bug is logged with its
    traceback and counted in :data:`INTERNAL_ERRORS`."""
    INTERNAL_ERRORS[protocol] += 1
    log.error("internal error (a bug in urc): " + what, *args, exc_info=True)


def internal_error_count() -> int:
    return sum(INTERNAL_ERRORS.values())


class RateLimitedLog:
    """Log repeated bad input at a bounded rate (issue 13.1: 64 KiB of junk wrote one
    log line per byte, 7.5 MB, and stalled every client).

    Each message format is a kind: its first occurrence is logged at once; further ones
    within ``interval_s`` are only counted, and the next one after the interval is
    logged with how many were left out (``... [and 21844 more like it in 5.0 s]``).
    So a flood costs a counter increment per bad input and at most one line per kind
    per interval, whatever its size. One instance per protocol (module level), shared
    by all its connections, bounds the total however many clients send junk.
    """

    def __init__(self, log: logging.Logger, interval_s: float = 5.0,
                 clock: Callable[[], float] = time.monotonic):
        self.log = log
        self.interval_s = interval_s
        self._clock = clock
        self._kinds: dict[str, list[float]] = {}   # msg -> [last logged s, suppressed count]

    def reset(self) -> None:
        self._kinds.clear()

    def __call__(self, level: int, msg: str, *args: object, count: int = 1) -> None:
        """Log ``msg % args`` (``count`` occurrences of it) unless this kind was logged
        within the interval."""
        now = self._clock()
        kind = self._kinds.get(msg)
        if kind is not None and now - kind[0] < self.interval_s:
            kind[1] += count
            return
        suppressed = 0 if kind is None else int(kind[1])
        self._kinds[msg] = [now, count - 1]
        if not self.log.isEnabledFor(level):
            return
        if suppressed:
            self.log.log(level, msg + " [and %d more like it since the last such line]",
                         *args, suppressed)
        else:
            self.log.log(level, msg, *args)

    def info(self, msg: str, *args: object, count: int = 1) -> None:
        self(logging.INFO, msg, *args, count=count)

    def warning(self, msg: str, *args: object, count: int = 1) -> None:
        self(logging.WARNING, msg, *args, count=count)



def protocol_logger(name: str) -> logging.Logger:
    return logging.getLogger(f"urc.protocols.{name}")


_BAD_INPUT_LOGS: dict[str, "RateLimitedLog"] = {}


def reset_bad_input_logs() -> None:
    """Forget what was logged (tests: each starts with every kind not yet seen)."""
    for rate_limited in _BAD_INPUT_LOGS.values():
        rate_limited.reset()


def bad_input_log(name: str) -> "RateLimitedLog":
    """One protocol's shared, rate-limited log of bad input and refusals."""
    if name not in _BAD_INPUT_LOGS:
        _BAD_INPUT_LOGS[name] = RateLimitedLog(protocol_logger(name))
    return _BAD_INPUT_LOGS[name]
