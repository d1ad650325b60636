"""What every transport adapter does with a session: feed, write replies, tick, log."""

from __future__ import annotations

import asyncio
import logging
from typing import Callable

from ..protocols.base import Session, internal_error

log = logging.getLogger("urc.servers")

#: how often sessions are asked for unsolicited output (G4JNT stream, monitor modes)
TICK_PERIOD_S = 0.1
READ_CHUNK = 4096

SessionFactory = Callable[[], Session]


def feed(session: Session, data: bytes, where: str) -> list[bytes]:
    """Give bytes to a session; a session bug costs this connection, never the server."""
    try:
        return session.receive(data)
    except Exception:  # sessions must not raise; if one does: logged, counted, input dropped
        internal_error(log, type(session).__name__, "%s: session failed on %r", where, data[:64])
        return []


def hang_up(session: Session, where: str) -> None:
    """The client went away: a session that keeps something under way for it (SARCNET
    calibration) gets ``disconnected()`` to end it cleanly."""
    gone = getattr(session, "disconnected", None)
    if gone is None:
        return
    try:
        gone()
    except Exception:
        internal_error(log, type(session).__name__, "%s: session failed on disconnect", where)


def needs_tick(session: Session) -> bool:
    return bool(getattr(session, "wants_tick", False))


async def tick_loop(session: Session, write: Callable[[bytes], None], clock_now: Callable[[], float],
                    where: str) -> None:
    while not session.closed:
        await asyncio.sleep(TICK_PERIOD_S)
        try:
            replies = session.tick(clock_now())
        except Exception:
            internal_error(log, type(session).__name__, "%s: session tick failed", where)
            continue
        for reply in replies:
            write(reply)
