"""Bounds on clients and logs (issue 21): a port admits a bounded number of clients and
closes the rest at once; repeated library log lines are bounded."""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path
from types import SimpleNamespace

from urc.protocols.rotctld import RotctldSession
from urc.servers.limits import RepeatFilter
from urc.servers.tcp import serve_tcp


class _Port:
    """Enough of a rotator for rotctld's ``_`` (get_info), which names the profile."""

    def status(self):
        return SimpleNamespace(profile="stub")


async def _ask(reader: asyncio.StreamReader, writer: asyncio.StreamWriter, line: bytes = b"_\n") -> bytes:
    """A line if the connection is served, b"" if urc closed it."""
    try:
        writer.write(line)
        return await asyncio.wait_for(reader.readline(), 30)
    except (ConnectionResetError, BrokenPipeError):
        return b""


def test_a_full_port_closes_its_oldest_idle_clients_for_newcomers():
    """64 idle connections refused every new client for as long as they stayed (issue
    36.1): a newcomer now takes the place of the connection idle the longest."""
    async def main() -> tuple[list[bytes], bytes]:
        server = await serve_tcp(lambda: RotctldSession(_Port()), "127.0.0.1", 0, "rotctld", max_clients=3)
        port = server.sockets[0].getsockname()[1]
        conns = [await asyncio.open_connection("127.0.0.1", port) for _ in range(5)]
        await asyncio.sleep(0.1)  # (every connection_made has run)
        answers = [await _ask(*c) for c in conns]
        for _reader, writer in conns:
            writer.close()
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        again = await _ask(reader, writer)
        writer.close()
        server.close()
        return answers, again

    answers, again = asyncio.run(main())
    assert answers == [b"", b"", b"urc stub\n", b"urc stub\n", b"urc stub\n"], answers
    assert again == b"urc stub\n", "a place freed by a client that left is given to the next"


def test_a_newcomer_replaces_a_connection_that_never_completed_a_command_first(monkeypatch, caplog):
    """Idle but used (a logger polling slowly) outlasts a connection that never sent a
    command, even an older one; one log line says how many were closed in the wave."""
    from urc.servers import limits

    monkeypatch.setattr(limits, "WAVE_S", 0.05, raising=False)

    async def main() -> tuple[bytes, list[bytes], bytes]:
        server = await serve_tcp(lambda: RotctldSession(_Port()), "127.0.0.1", 0, "rotctld", max_clients=3)
        port = server.sockets[0].getsockname()[1]
        silent_old = await asyncio.open_connection("127.0.0.1", port)
        await asyncio.sleep(0.05)
        used = await asyncio.open_connection("127.0.0.1", port)
        first = await _ask(*used)
        silent = await asyncio.open_connection("127.0.0.1", port)  # (after used's last command)
        await asyncio.sleep(0.05)
        newcomers = [await asyncio.open_connection("127.0.0.1", port) for _ in range(2)]
        await asyncio.sleep(0.2)  # (the wave's line is written)
        served = [await _ask(*c) for c in newcomers]
        still = await _ask(*used)
        for _reader, writer in [silent_old, used, silent, *newcomers]:
            writer.close()
        server.close()
        return first, served, still

    with caplog.at_level(logging.WARNING, logger="urc.servers"):
        first, served, still = asyncio.run(main())
    assert first == b"urc stub\n"
    assert served == [b"urc stub\n"] * 2, "a newcomer was not served on a full port"
    assert still == b"urc stub\n", "a client that had used its connection lost it to a newcomer"
    waves = [r.getMessage() for r in caplog.records if "idle connection" in r.getMessage()]
    assert len(waves) == 1 and "closed 2 idle connection(s)" in waves[0], waves


def _keepalive_timer_on(local_port: int, remote_port: int) -> bool:
    """/proc/net/tcp's timer for the connection local_port <-> remote_port is the
    keepalive timer (tr 2); an idle socket without SO_KEEPALIVE has none (tr 0)."""
    for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
        fields = line.split()
        local, remote, timer = fields[1], fields[2], fields[5]
        if int(local.split(":")[1], 16) == local_port and int(remote.split(":")[1], 16) == remote_port:
            return timer.split(":")[0] == "02"
    raise AssertionError("connection not in /proc/net/tcp")


def test_protocol_ports_turn_on_tcp_keepalive():
    """A client that vanished (a laptop asleep) held its place until a restart: no
    SO_KEEPALIVE anywhere in servers/ (issue 36.1)."""
    async def main() -> bool:
        server = await serve_tcp(lambda: RotctldSession(_Port()), "127.0.0.1", 0, "rotctld", max_clients=3)
        port = server.sockets[0].getsockname()[1]
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        assert await _ask(reader, writer) == b"urc stub\n"
        on = _keepalive_timer_on(port, writer.get_extra_info("sockname")[1])
        writer.close()
        server.close()
        return on

    assert asyncio.run(main()), "no keepalive timer on urc's side of an idle connection"


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
    Beyond the limit a newcomer takes the place of the oldest idle connection (256 idle
    ones kept the API away for 11 s per wave: issue 36.1); one that sends nothing is
    closed after a while, so idle ones cannot keep the places of clients."""
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
        await asyncio.sleep(0.1)  # (every connection_made has run)
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
    assert answers == [b""] * 2 + [b"HTTP/1.1 200"] * 3, answers
    assert dropped == b"", "a connection that sent nothing was kept"
    assert served == b"HTTP/1.1 200"
