"""The I/O process's end of the link on its event loop (``ControlLink.start(loop)``): no
reader thread, a reply settles its request where it is read, the cases a thread never
had to think of (a blocking call made on that very loop, the peer gone), and the bound on
a request's wait: one timer per loop, however many requests wait (each awaited request
armed a CALL_TIMEOUT_S bound with call_later and never took it back, so at a thousand
rotctld sets a second six thousand timers sat in the loop's heap; then a timer each,
cancelled on the answer: a heap push and pop per set)."""

from __future__ import annotations

import asyncio
import logging
import os
import socket
import threading
from multiprocessing.connection import Connection

import pytest

from urc.link import codec
from urc.link.client import STRICT_ENV, SWEEP_S, ControlLink, ControlUnavailable
from urc.model.messages import Goto, Reply, Stop


def _peer(conn: Connection, answered: list[str]) -> None:
    """The control process reduced to answering each request at once, from a thread
    it names in ``answered``; it ends when the link's end closes."""
    while True:
        try:
            kind, env = codec.loads(conn.recv_bytes())
        except (EOFError, OSError):
            return
        if kind == "request":
            answered.append(type(env.request).__name__)
            conn.send_bytes(codec.dumps(("reply", Reply(env.rid, "value", len(answered), None))))


def _hang_up(conn: Connection) -> None:
    """The control process's end goes away: shut down (which wakes the peer thread's
    read, as a close from another thread does not), then closed."""
    with socket.socket(fileno=os.dup(conn.fileno())) as sock:
        sock.shutdown(socket.SHUT_RDWR)
    conn.close()


@pytest.fixture
def linked():
    """(our Connection, the peer's Connection, the requests the peer answered)."""
    ours, theirs = socket.socketpair()
    peer = Connection(theirs.detach())
    answered: list[str] = []
    threading.Thread(target=_peer, args=(peer, answered), daemon=True).start()
    conn = Connection(ours.detach())
    yield conn, peer, answered
    conn.close()
    if not peer.closed:
        _hang_up(peer)


def test_the_loop_reads_the_link_and_no_thread_does(linked):
    conn, _peer_conn, answered = linked
    link_threads_before = {t.name for t in threading.enumerate()}

    async def main() -> list:
        link = ControlLink(conn).start(asyncio.get_running_loop())
        values = [await link.submit(Goto(float(i), 10.0)) for i in range(5)]
        from_thread = await asyncio.to_thread(link.call, Goto(1.0, 2.0))   # a tracker's call
        assert "urc-control-link" not in {t.name for t in threading.enumerate()} - link_threads_before
        return values + [from_thread]
    assert asyncio.run(main()) == [1, 2, 3, 4, 5, 6]
    assert answered == ["Goto"] * 6


def test_a_blocking_call_on_the_reading_loop_reads_its_own_reply(linked, monkeypatch, caplog):
    """A bug (a round trip not awaited) must still be answered, at once, not wait for
    the loop it blocks (6 s, then "no answer"); it is logged as the bug it is."""
    conn, _peer_conn, _answered = linked
    monkeypatch.delenv(STRICT_ENV, raising=False)

    async def main() -> int:
        link = ControlLink(conn).start(asyncio.get_running_loop())
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        value = link.call(Goto(1.0, 2.0))
        assert loop.time() - t0 < 1.0
        return value
    with caplog.at_level(logging.ERROR, logger="urc.link.client"):
        assert asyncio.run(main()) == 1
    assert "blocks the event loop" in caplog.text


def test_the_peer_gone_fails_what_waits_and_ends_the_link(linked):
    conn, peer_conn, _answered = linked
    lost: list[str] = []

    async def main() -> None:
        loop = asyncio.get_running_loop()
        link = ControlLink(conn, on_lost=lost.append).start(loop)
        _hang_up(peer_conn)   # (the control process dies: its end closes)
        with pytest.raises(ControlUnavailable, match="gone"):
            await link.submit(Stop(), timeout_s=5.0)
        assert await asyncio.to_thread(link.finished.wait, 2.0)
        assert link.lost and lost == [link.lost]
        with pytest.raises(ControlUnavailable, match="gone"):   # and later requests fail at once
            await link.submit(Goto(1.0, 2.0))
    asyncio.run(main())


def test_started_from_another_thread_it_reads_on_the_loop(linked):
    """A control process started again by the watch thread (a takeover): its link is
    made on that thread, and read by the event loop all the same."""
    conn, _peer_conn, _answered = linked

    async def main() -> int:
        loop = asyncio.get_running_loop()
        link = await asyncio.to_thread(lambda: ControlLink(conn).start(loop))
        return await link.submit(Goto(1.0, 2.0))
    assert asyncio.run(main()) == 1


def test_a_stray_status_and_garbage_between_replies_are_taken_in_stride(linked):
    conn, peer_conn, _answered = linked

    async def main() -> None:
        link = ControlLink(conn).start(asyncio.get_running_loop())
        peer_conn.send_bytes(b"\x80\x05not a pickle")          # dropped, one log line
        peer_conn.send_bytes(codec.dumps(("stopped", {"saved": True})))
        assert await link.submit(Goto(1.0, 2.0)) == 1
        assert link.final == {"saved": True} and not link.lost
    asyncio.run(main())


def test_a_callback_request_is_answered_where_its_reply_is_read_and_never_inside_the_call(linked):
    """``submit_then`` (a protocol session's request): the callback runs from the reader
    that read the reply; an answer known at once (the link lost) comes in a loop round of
    its own, never inside the call that made the request (a session's step would run
    inside its own step)."""
    conn, peer_conn, _answered = linked

    async def main() -> None:
        loop = asyncio.get_running_loop()
        link = ControlLink(conn).start(loop)
        got = loop.create_future()
        link.submit_then(Goto(1.0, 2.0), lambda value, error: got.set_result((value, error)))
        assert await asyncio.wait_for(got, 2.0) == (1, None)
        _hang_up(peer_conn)
        assert await asyncio.to_thread(link.finished.wait, 2.0)
        inside = [True]
        answers: list = []
        link.submit_then(Goto(1.0, 2.0), lambda value, error: answers.append((inside[0], value, error)))
        inside[0] = False
        await asyncio.sleep(0)
        await asyncio.sleep(0)
        (was_inside, value, error), = answers
        assert not was_inside and value is None and isinstance(error, ControlUnavailable)
    asyncio.run(main())


def _expiry_timers(loop: asyncio.AbstractEventLoop, link: ControlLink) -> list:
    return [h for h in loop._scheduled  # type: ignore[attr-defined]
            if not h.cancelled() and getattr(h._callback, "__self__", None) is link]


def test_answered_requests_leave_no_timer_on_the_loop(linked):
    conn, _peer_conn, _answered = linked

    async def main() -> tuple[int, list]:
        link = ControlLink(conn).start(asyncio.get_running_loop())
        values = await asyncio.gather(*(link.submit(Stop(), timeout_s=60.0) for _ in range(20)))
        assert sorted(values) == list(range(1, 21))
        armed = len(_expiry_timers(asyncio.get_running_loop(), link))
        await asyncio.sleep(3 * SWEEP_S)
        return armed, _expiry_timers(asyncio.get_running_loop(), link)
    armed, left = asyncio.run(main())
    assert armed <= 1 and left == []   # (20 of them, each due in 60 s, before)


@pytest.mark.parametrize("how", ["awaited", "blocking on the reading loop"])
def test_a_request_nobody_answers_is_answered_no_answer_after_its_bound_once(how, monkeypatch):
    """Awaited: the loop's sweep answers it. Blocking (a bug, logged), on the loop that
    reads the link: it pumps the socket for its bound, and waits no longer."""
    monkeypatch.delenv(STRICT_ENV, raising=False)
    ours, theirs = socket.socketpair()   # (the peer reads nothing and answers nothing)

    async def main() -> float:
        link = ControlLink(Connection(ours.detach())).start(asyncio.get_running_loop())
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        with pytest.raises(ControlUnavailable, match="did not answer within 0.3 s"):
            if how == "awaited":
                await link.submit(Goto(10.0, 20.0), timeout_s=0.3)
            else:
                link.call(Goto(10.0, 20.0), timeout_s=0.3)
        link.conn.close()
        return loop.time() - t0
    try:
        assert 0.3 <= asyncio.run(main()) < 0.3 + 2.5 * SWEEP_S
    finally:
        theirs.close()
