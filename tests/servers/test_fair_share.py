"""One flooding client cannot hold the event loop (issue 21: 60 kB of junk on one
connection stalled every other client's ``p`` for seconds): streams are fed in slices,
a session gives the loop back after its share, and a transport stops reading while too
much of its input waits."""

from __future__ import annotations

import asyncio
import time

from urc.model.messages import Stop
from urc.servers import common
from urc.servers.common import SessionRunner


class SlowSession:
    """Answers each line with its own text; every receive costs work (as parsing and
    answering junk does)."""

    closed = False

    def __init__(self, name: str, events: list[str], cost_s: float = 0.0005):
        self.name, self.events, self.cost_s = name, events, cost_s
        self.pending = b""

    def receive(self, data: bytes) -> list[bytes]:
        end = time.perf_counter() + self.cost_s
        while time.perf_counter() < end:
            pass
        *lines, self.pending = (self.pending + data).split(b"\n")
        self.events.extend(f"{self.name}:{line.decode()}" for line in lines)
        return [line + b"\n" for line in lines]


def test_another_client_is_answered_while_a_flood_is_still_being_worked_through():
    events: list[str] = []
    flood_lines = 4000
    flood = b"".join(b"x%d\n" % i for i in range(flood_lines))   # ~24 kB in one read

    async def main() -> None:
        loop = asyncio.get_running_loop()
        a = SessionRunner(SlowSession("a", events), lambda _r: None, "a")
        b = SessionRunner(SlowSession("b", events), lambda _r: None, "b")
        a.feed(flood)
        loop.call_soon(b.feed, b"p\n")
        while len(events) < flood_lines + 1:
            await asyncio.sleep(0.001)

    asyncio.run(main())
    # every line answered, each session's in order
    assert [e for e in events if e.startswith("a:")] == [f"a:x{i}" for i in range(flood_lines)]
    # b's line was served long before the flood was through (one read used to be worked
    # through to its end before anyone else was served)
    assert events.index("b:p") < flood_lines // 2


def test_a_transport_stops_reading_while_too_much_input_waits_and_reads_again_after():
    """While a command waits for the control process, a client's further reads queue up:
    past the high mark the transport is paused, below the low mark it reads again."""
    events: list[str] = []
    calls: list[tuple[bool, int]] = []

    class WaitsFirst(SlowSession):
        reply: asyncio.Future | None = None

        @property
        def rotator(self):
            return self

        async def call(self, request):  # (a round trip to the control process)
            await self.reply

        def receive(self, data: bytes):
            if self.reply is not None and not self.reply.done():
                yield Stop()
            return super().receive(data)

    async def main() -> None:
        session = WaitsFirst("a", events, cost_s=0.0)
        session.reply = asyncio.get_running_loop().create_future()
        runner = SessionRunner(session, lambda _r: None, "a",
                               pause=lambda paused: calls.append((paused, len(events))))
        chunk = b"y" * 15 + b"\n"
        runner.feed(b"P 1 2\n")                # waits for its reply
        for _ in range(6):                     # 6 reads of 16 kB arrive meanwhile
            runner.feed(chunk * 1024)
        assert calls == [(True, 0)]
        session.reply.set_result(None)
        while len(events) < 1 + 6 * 1024:
            await asyncio.sleep(0.001)

    asyncio.run(main())
    assert [paused for paused, _ in calls] == [True, False]
    # resumed only once the backlog (16 bytes a line) fell below the low mark (counted as
    # each slice is taken up, so the lines seen lag by at most one slice)
    assert (1 + 6 * 1024 - calls[1][1]) * 16 <= common.RESUME_BELOW_BYTES + common.SLICE_BYTES


def test_datagrams_stay_whole():
    events: list[str] = []
    runner = SessionRunner(SlowSession("u", events, cost_s=0.0), lambda _r: None, "u", stream=False)
    seen: list[bytes] = []
    runner.session.receive = lambda data: seen.append(data) or []  # type: ignore[method-assign]
    big = b"z" * (3 * common.SLICE_BYTES)
    runner.feed(big)
    assert seen == [big]
