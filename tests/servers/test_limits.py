"""Bounds on clients and logs (issue 21): a port admits a bounded number of clients and
closes the rest at once; repeated library log lines are bounded."""

from __future__ import annotations

import asyncio
import logging
from types import SimpleNamespace

from urc.protocols.rotctld import RotctldSession
from urc.servers.limits import RepeatFilter
from urc.servers.tcp import serve_tcp


class _Port:
    """Enough of a rotator for rotctld's ``_`` (get_info), which names the profile."""

    def status(self):
        return SimpleNamespace(profile="stub")


def test_a_port_serves_its_limit_of_clients_and_closes_the_rest_at_once():
    async def main() -> tuple[list[bytes], bytes]:
        server = await serve_tcp(lambda: RotctldSession(_Port()), "127.0.0.1", 0, "rotctld", max_clients=3)
        port = server.sockets[0].getsockname()[1]
        conns = [await asyncio.open_connection("127.0.0.1", port) for _ in range(5)]
        answers = []
        for reader, writer in conns:
            writer.write(b"_\n")
            answers.append(await reader.readline())  # a line if admitted, EOF if not
        for _reader, writer in conns:
            writer.close()
        for _ in range(100):  # (the admitted ones are released as their close arrives)
            await asyncio.sleep(0.05)
            reader, writer = await asyncio.open_connection("127.0.0.1", port)
            writer.write(b"_\n")
            again = await reader.readline()
            writer.close()
            if again:
                break
        server.close()
        return answers, again

    answers, again = asyncio.run(main())
    assert answers[:3] == [b"urc stub\n"] * 3 and answers[3:] == [b"", b""], answers
    assert again == b"urc stub\n", "a place freed by a client that left is given to the next"


def test_repeated_library_messages_are_logged_once_per_interval():
    now = [0.0]
    flt = RepeatFilter(interval_s=10.0, clock=lambda: now[0])

    def record() -> logging.LogRecord:
        return logging.LogRecord("asyncio", logging.WARNING, __file__, 1, "socket.send() raised exception.",
                                 (), None)
    passed = [flt.filter(record()) for _ in range(15000)]
    assert passed.count(True) == 1
    now[0] = 11.0
    last = record()
    assert flt.filter(last) and "14999 more like it" in last.getMessage()
