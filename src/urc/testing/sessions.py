"""Drive a protocol session synchronously against an in-process rotator (tests, the
bridged rig): each port request its generator yields is performed at once
(urc.model.effects.drive), as the server adapter performs it by awaiting the
control process."""

from __future__ import annotations

from typing import Any

from ..model.effects import as_effects, drive


def fed(session: Any, data: bytes) -> list[bytes]:
    """``session.receive(data)`` run to its replies (a stand-in that answers at once,
    a device simulator, needs no rotator)."""
    return drive(as_effects(session.receive(data)), getattr(session, "rotator", None))


def ticked(session: Any, now_s: float) -> list[bytes]:
    """``session.tick(now_s)`` run to its replies (a stream, SARCNET's demo)."""
    return drive(as_effects(session.tick(now_s)), session.rotator)


def hung_up(session: Any) -> Any:
    """``session.disconnected()`` run to its end (the client hung up)."""
    return drive(as_effects(session.disconnected()), session.rotator)
