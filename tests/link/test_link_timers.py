"""An answered request leaves no timer behind on the event loop: each awaited request
armed a CALL_TIMEOUT_S (6 s) bound with call_later and never took it back, so at a
thousand rotctld sets a second six thousand timers sat in the loop's heap, each one
pushed and later popped and run (a scan of the pending requests) for nothing."""

from __future__ import annotations

import asyncio
import os
import socket
import threading
from multiprocessing.connection import Connection

from urc.link import codec
from urc.model.messages import Reply, Stop
from urc.link.remote import ControlLink


def _answering_peer(conn: Connection) -> None:
    """The control process's side, reduced to answering each request at once."""
    while True:
        try:
            kind, env = codec.loads(conn.recv_bytes())
        except (EOFError, OSError):
            return
        if kind == "request":
            conn.send_bytes(codec.dumps(("reply", Reply(env.rid, "value", 42, None))))


def _expiry_timers(loop: asyncio.AbstractEventLoop, link: ControlLink) -> list:
    return [h for h in loop._scheduled  # type: ignore[attr-defined]
            if not h.cancelled() and getattr(h._callback, "__self__", None) is link]


def test_an_answered_request_leaves_no_timer_on_the_loop():
    ours, theirs = socket.socketpair()
    peer = Connection(os.dup(theirs.fileno()))
    theirs.close()
    threading.Thread(target=_answering_peer, args=(peer,), daemon=True).start()
    link = ControlLink(Connection(os.dup(ours.fileno()))).start()
    ours.close()

    async def main() -> list:
        values = [await link.call_async(Stop(), timeout_s=60.0) for _ in range(20)]
        assert values == [42] * 20
        return _expiry_timers(asyncio.get_running_loop(), link)
    try:
        assert asyncio.run(main()) == []   # (20 of them, each due in 60 s, before)
    finally:
        link.conn.close()
        peer.close()
