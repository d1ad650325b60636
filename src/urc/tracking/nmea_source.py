"""Read an NMEA 0183 stream (a GPS receiver, a balloon's telemetry) from a serial port,
a pseudo-terminal or a TCP server, and hand the bytes to a sans-I/O consumer.

Sources: a device path ("/dev/ttyACM0", a pty path) or "tcp:HOST:PORT" (e.g. gpsd's
NMEA port, or a balloon decoder's output). A dropped source is retried every few
seconds; nothing here ever raises into the control loop. Tracking's own input (the
station's GPS, an NMEA target), so it lives with tracking, below the servers.
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Callable

from ..config import parse_host_port

log = logging.getLogger("urc.nmea")

RETRY_S = 3.0
READ_CHUNK = 4096

Feed = Callable[[bytes, float], object]  # (data, received_unix_s)


async def read_nmea(source: str, feed: Feed, baud: int = 9600) -> None:
    """Run until cancelled, feeding every chunk read with its arrival time."""
    while True:
        try:
            if source.startswith("tcp:"):
                await _read_tcp(source[4:], feed)
            else:
                await _read_device(source, baud, feed)
            log.warning("NMEA source %s closed; retrying in %.0f s", source, RETRY_S)
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # unreachable, unplugged, refused: keep trying
            log.warning("NMEA source %s: %s; retrying in %.0f s", source, exc, RETRY_S)
        await asyncio.sleep(RETRY_S)


def _feed(feed: Feed, data: bytes) -> None:
    try:
        feed(data, time.time())
    except Exception:  # a parser bug must not end the reader
        log.exception("NMEA consumer failed on %r", data[:80])


async def _read_tcp(where: str, feed: Feed) -> None:
    host, port = parse_host_port(where)
    reader, writer = await asyncio.open_connection(host, port)
    try:
        while data := await reader.read(READ_CHUNK):
            _feed(feed, data)
    finally:
        writer.close()


async def _read_device(path: str, baud: int, feed: Feed) -> None:
    import serial  # pyserial opens real serial ports and pseudo-terminals alike

    port = serial.Serial(path, baudrate=baud, timeout=0)
    loop = asyncio.get_running_loop()
    closed = loop.create_future()

    def readable() -> None:
        try:
            data = port.read(READ_CHUNK)
        except serial.SerialException as exc:
            if not closed.done():
                closed.set_exception(exc)
            return
        if data:
            _feed(feed, data)
    loop.add_reader(port.fileno(), readable)
    try:
        await closed
    finally:
        loop.remove_reader(port.fileno())
        port.close()
