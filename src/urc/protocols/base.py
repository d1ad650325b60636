"""What every protocol session is and what it may do.

Sessions are sans-I/O (h11 style): bytes in, complete replies out, no sockets, no
asyncio, no clock of their own. A thin adapter in :mod:`urc.servers` serves a session
over TCP, a serial port, a pseudo-terminal or UDP, one session per connection.

Sessions act on the rotator only through :class:`RotatorPort`, which the rotator
service implements: limits, keep-out zones, wrap and faults are enforced there, once,
for every protocol. A command the session did not fully understand never reaches it.
"""

from __future__ import annotations

import logging
from typing import Protocol, runtime_checkable

from ..errors import UrcError
from ..service.snapshot import Status

#: no session buffers more than this many bytes of an unfinished command; beyond it the
#: partial input is dropped (and answered with the protocol's error, where it has one).
MAX_PENDING_BYTES = 4096


class RotatorPort(Protocol):
    """The rotator service's public command API (see urc.service.rotator.Rotator).

    Every method validates at once and raises ``urc.errors.CommandRejected`` (with a
    ``reason``: "limit", "keepout", "fault", "uncertain", "invalid") before anything moves.
    Angles are sky azimuth 0..360 (values outside name a cable-wrap pose, e.g. 400 on a
    450 deg rotator) and elevation (past 90 names a flipped pose on 0..180 rotators).
    """

    def status(self) -> Status: ...
    def goto(self, az_deg: float, el_deg: float) -> list: ...
    def goto_az(self, az_deg: float) -> list: ...
    def goto_el(self, el_deg: float) -> list: ...
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
    #: class attribute ``wants_tick = True``; only those are ticked by the adapters.)
    closed: bool

    def receive(self, data: bytes) -> list[bytes]:
        """Feed received bytes (any split, even one byte at a time). Returns the complete
        replies now due, in order; the adapter writes each one with a single write."""

    def tick(self, now_s: float) -> list[bytes]:
        """Unsolicited output due by ``now_s`` (the G4JNT position stream). Most return []."""


class ProtocolError(UrcError, ValueError):
    """Input a protocol could not parse; says what was expected and what was found."""

    def __init__(self, expected: str, found: bytes):
        self.expected, self.found = expected, found
        super().__init__(f"expected {expected}, found {found!r}")


def goto_named_axes(rotator: RotatorPort, az_deg: float | None, el_deg: float | None) -> None:
    """Go to whichever of az/el the command named; the other axis keeps its target."""
    if el_deg is None:
        rotator.goto_az(az_deg)
    elif az_deg is None:
        rotator.goto_el(el_deg)
    else:
        rotator.goto(az_deg, el_deg)


def protocol_logger(name: str) -> logging.Logger:
    return logging.getLogger(f"urc.protocols.{name}")
