"""Serve a protocol on TCP: one session per connection, many connections at once.

Built on asyncio's Protocol/Transport layer rather than streams: replies are written
straight from ``data_received``, which roughly halves the per-request cost of a
``p`` round trip (a tracker polls it several times a second, loggers more).
"""

from __future__ import annotations

import asyncio
import socket
import time

from .common import SessionFactory, SessionRunner, log, needs_tick, tick_loop
from .limits import MAX_CLIENTS_PER_PORT, ClientCap, enable_keepalive

#: Hamlib's rotctld listens with a backlog of 4; a burst of 64 clients (a logger, SDR
#: software and a tracker all reconnecting) must all get in.
LISTEN_BACKLOG = 256
#: a client that stops reading gets its replies dropped beyond this, not buffered forever
MAX_WRITE_BUFFER = 256 * 1024


class _Connection(asyncio.Protocol):
    def __init__(self, factory: SessionFactory, name: str, cap: ClientCap):
        self.factory = factory
        self.name = name
        self.cap = cap
        self.admitted = False
        self.transport: asyncio.Transport  # (from connection_made on: every other call comes after it)
        self.ticker: asyncio.Task | None = None
        # (what the cap weighs when a newcomer needs a place: see limits.pick_idle)
        self.used = False  # a reply answered something it sent
        self.idle_since_s = time.monotonic()

    @property
    def evictable(self) -> bool:
        return self.admitted and not self.runner.busy

    def evict(self) -> None:
        log.debug("%s: closed for a newcomer (idle)", self.where)
        self.transport.close()

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        self.where = f"{self.name} tcp {transport.get_extra_info('peername')}"
        self.admitted = self.cap.admit(self)
        if not self.admitted:  # (its descriptor is freed now, not when the client gives up)
            transport.abort()
            return
        sock = transport.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            enable_keepalive(sock)
        self.runner = SessionRunner(self.factory(), self.write, self.where, after=self._close_if_asked,
                                    pause=self._pause)
        if needs_tick(self.runner.session):
            self.ticker = asyncio.get_running_loop().create_task(tick_loop(self.runner, time.monotonic))

    def write(self, reply: bytes) -> None:
        if not self.transport.is_closing() and self.transport.get_write_buffer_size() < MAX_WRITE_BUFFER:
            self.transport.write(reply)  # one write per complete reply (gpredict needs it whole)

    def _pause(self, paused: bool) -> None:
        if self.transport.is_closing():
            return
        if paused:
            self.transport.pause_reading()
        else:
            self.transport.resume_reading()

    def _close_if_asked(self) -> None:
        if self.runner.session.closed:
            self.transport.close()

    def _answer(self, reply: bytes) -> None:
        self.used = True
        self.write(reply)

    def data_received(self, data: bytes) -> None:
        if self.admitted:
            self.idle_since_s = time.monotonic()
            self.runner.feed(data, self._answer)

    def connection_lost(self, exc: Exception | None) -> None:
        if not self.admitted:
            return
        self.cap.release(self)
        if self.ticker is not None:
            self.ticker.cancel()
        self.runner.hang_up()
        log.debug("%s: closed", self.where)


async def serve_tcp(factory: SessionFactory, host: str, port: int, name: str,
                    max_clients: int = MAX_CLIENTS_PER_PORT) -> asyncio.Server:
    cap = ClientCap(f"{name} tcp {host}:{port}", max_clients)
    return await asyncio.get_running_loop().create_server(
        lambda: _Connection(factory, name, cap), host, port, backlog=LISTEN_BACKLOG, reuse_address=True)
