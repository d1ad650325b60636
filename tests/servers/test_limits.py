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


def test_http_admits_its_limit_of_connections_and_closes_idle_ones():
    """uvicorn's limit_concurrency answers 503 to requests only: 1500 idle connections
    were all held for good and took every descriptor of the I/O process (issue 21).
    Beyond the limit a connection is closed at once; one that sends nothing is closed
    after a while, so idle ones cannot keep the places of clients."""
    import uvicorn
    from uvicorn.protocols.http.auto import AutoHTTPProtocol

    from urc.servers.limits import capped_http_protocol

    async def app(scope, receive, send):
        await send({"type": "http.response.start", "status": 200, "headers": [(b"content-length", b"2")]})
        await send({"type": "http.response.body", "body": b"ok"})

    async def ask(reader, writer) -> bytes:
        try:
            writer.write(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
            return await asyncio.wait_for(reader.readline(), 30)  # its status line, or EOF
        except ConnectionResetError:  # (closed at once while the request was on its way)
            return b""

    async def main() -> tuple[list[bytes], bytes, bytes]:
        config = uvicorn.Config(app, host="127.0.0.1", port=0, log_level="warning", lifespan="off",
                                http=capped_http_protocol(AutoHTTPProtocol, 3, first_request_s=0.5))
        server = uvicorn.Server(config)
        config.load()
        server.lifespan = config.lifespan_class(config)  # (what Server.serve does first)
        await server.startup()
        port = server.servers[0].sockets[0].getsockname()[1]
        conns = [await asyncio.open_connection("127.0.0.1", port) for _ in range(5)]
        answers = [(await ask(*c))[:12] for c in conns]
        for _reader, writer in conns:
            writer.close()
        silent = await asyncio.open_connection("127.0.0.1", port)  # a place is free again
        dropped = await asyncio.wait_for(silent[0].read(1), 30)     # it says nothing: closed
        later = await asyncio.open_connection("127.0.0.1", port)
        served = (await ask(*later))[:12]
        for _reader, writer in (silent, later):
            writer.close()
        await server.shutdown()
        return answers, dropped, served

    answers, dropped, served = asyncio.run(main())
    assert answers == [b"HTTP/1.1 200"] * 3 + [b""] * 2, answers
    assert dropped == b"", "a connection that sent nothing was kept"
    assert served == b"HTTP/1.1 200"
