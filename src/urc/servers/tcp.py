"""Serve a protocol on TCP: one session per connection, many connections at once."""

from __future__ import annotations

import asyncio
import socket
import time

from .common import READ_CHUNK, SessionFactory, feed, log, tick_loop

#: Hamlib's rotctld listens with a backlog of 4; a burst of 64 clients (a logger, SDR
#: software and a tracker all reconnecting) must all get in.
LISTEN_BACKLOG = 256
#: a client that stops reading gets its replies dropped beyond this, not buffered forever
MAX_WRITE_BUFFER = 256 * 1024


async def serve_tcp(factory: SessionFactory, host: str, port: int, name: str) -> asyncio.Server:
    async def handle(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        peer = writer.get_extra_info("peername")
        where = f"{name} tcp {peer}"
        sock = writer.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        session = factory()

        def write(reply: bytes) -> None:
            if writer.transport.get_write_buffer_size() < MAX_WRITE_BUFFER:
                writer.write(reply)

        ticker = asyncio.create_task(tick_loop(session, write, time.monotonic, where))
        try:
            while not session.closed:
                data = await reader.read(READ_CHUNK)
                if not data:
                    break
                for reply in feed(session, data, where):
                    write(reply)  # one write per complete reply (gpredict needs it whole)
                await writer.drain()
        except (ConnectionError, asyncio.IncompleteReadError):
            pass  # a vanished client is normal
        finally:
            ticker.cancel()
            writer.close()
            try:
                await writer.wait_closed()
            except (ConnectionError, OSError):
                pass
            log.debug("%s: closed", where)

    return await asyncio.start_server(handle, host, port, backlog=LISTEN_BACKLOG, reuse_address=True)
