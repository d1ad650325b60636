"""Serving a protocol on a serial port (here a pseudo-terminal opened with pyserial)."""

from __future__ import annotations

import asyncio
import os
import termios
import tty

from urc.protocols import make_session
from urc.servers.serial import SerialEndpoint


def test_tartu_baud_changes_the_ports_rate_after_its_reply(bench):
    b = bench("tartu-urc")
    master, slave = os.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)

    async def scenario() -> tuple[bytes, int, int]:
        ep = SerialEndpoint(lambda: make_session("urc", b.rot), os.ttyname(slave), 115200, "urc")
        ep.start()
        try:
            before = termios.tcgetattr(slave)[5]          # output speed
            os.write(master, b"BAUD 9600\r")
            reply = b""
            for _ in range(50):
                await asyncio.sleep(0.02)
                try:
                    reply += os.read(master, 100)
                except BlockingIOError:
                    pass
                if reply.endswith(b"\r\n"):
                    break
            await asyncio.sleep(0.05)
            return reply, before, termios.tcgetattr(slave)[5]
        finally:
            ep.close()
            os.close(master)
            os.close(slave)
    reply, before, after = asyncio.run(scenario())
    assert reply == b"OK\r\n"
    assert before == termios.B115200 and after == termios.B9600
