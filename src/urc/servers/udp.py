"""Serve a datagram protocol (PstRotator): replies go to the sender's host on reply_port."""

from __future__ import annotations

import asyncio

from .common import SessionFactory, SessionRunner


class _Datagrams(asyncio.DatagramProtocol):
    def __init__(self, factory: SessionFactory, reply_port: int, name: str):
        self.runner = SessionRunner(factory(), self._drop, name, stream=False)
        self.reply_port = reply_port
        self.name = name
        self.transport: asyncio.DatagramTransport | None = None

    def connection_made(self, transport) -> None:
        self.transport = transport

    def datagram_received(self, data: bytes, addr) -> None:
        # (each datagram's replies go to its own sender)
        transport = self.transport
        assert transport is not None  # (connection_made came first)
        self.runner.feed(data, lambda reply: transport.sendto(reply, (addr[0], self.reply_port)))

    @staticmethod
    def _drop(reply: bytes) -> None:
        """Output nobody asked for has no address to go to."""


async def serve_udp(factory: SessionFactory, host: str, port: int, reply_port: int,
                    name: str) -> asyncio.DatagramTransport:
    transport, _ = await asyncio.get_running_loop().create_datagram_endpoint(
        lambda: _Datagrams(factory, reply_port, name), local_addr=(host, port))
    return transport
