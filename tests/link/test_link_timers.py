"""Requests awaited on the event loop keep one timer there, whatever their number, and none
once they are answered: each awaited request armed a CALL_TIMEOUT_S (6 s) bound with
call_later and never took it back, so at a thousand rotctld sets a second six thousand
timers sat in the loop's heap, each one pushed and later popped and run (a scan of the
pending requests) for nothing; then a timer each, cancelled on the answer (a heap push
and pop per set). And a request that is not answered is still answered "no answer"."""

from __future__ import annotations

import asyncio
import os
import socket
import threading
from multiprocessing.connection import Connection

from urc.link import codec
from urc.model.messages import Goto, Reply, Stop
import pytest

from urc.link.client import SWEEP_S, ControlLink, ControlUnavailable


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

    async def main() -> tuple[int, list]:
        values = await asyncio.gather(*(link.submit(Stop(), timeout_s=60.0) for _ in range(20)))
        assert values == [42] * 20
        armed = len(_expiry_timers(asyncio.get_running_loop(), link))
        await asyncio.sleep(3 * SWEEP_S)
        return armed, _expiry_timers(asyncio.get_running_loop(), link)
    try:
        armed, left = asyncio.run(main())
        assert armed <= 1 and left == []   # (20 of them, each due in 60 s, before)
    finally:
        link.conn.close()
        peer.close()


def test_a_request_nobody_answers_is_answered_no_answer_after_its_bound():
    ours, theirs = socket.socketpair()   # (the peer reads nothing and answers nothing)
    link = ControlLink(Connection(os.dup(ours.fileno()))).start()
    ours.close()

    async def main() -> float:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        with pytest.raises(ControlUnavailable, match="did not answer within 0.3 s"):
            await link.submit(Goto(10.0, 20.0), timeout_s=0.3)
        return loop.time() - t0
    try:
        waited_s = asyncio.run(main())
        assert 0.3 <= waited_s < 0.3 + 3 * SWEEP_S
    finally:
        link.conn.close()
        theirs.close()
