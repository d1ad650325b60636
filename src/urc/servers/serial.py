"""Serve a protocol on a real serial device (pyserial), one session for the port's life."""

from __future__ import annotations

import asyncio
import time

import serial

from .common import READ_CHUNK, SessionFactory, feed, log, needs_tick, tick_loop


class SerialEndpoint:
    def __init__(self, factory: SessionFactory, device: str, baud: int, name: str):
        self.name = name
        self.where = f"{name} serial {device}"
        self.session = factory()
        self.port = serial.Serial(device, baudrate=baud, timeout=0, write_timeout=0)
        self._ticker: asyncio.Task | None = None

    def start(self) -> None:
        asyncio.get_running_loop().add_reader(self.port.fileno(), self._readable)
        if needs_tick(self.session):
            self._ticker = asyncio.create_task(tick_loop(self.session, self._write, time.monotonic, self.where))

    def _readable(self) -> None:
        try:
            data = self.port.read(READ_CHUNK)
        except serial.SerialException as exc:
            log.error("%s: read failed: %s", self.where, exc)
            return
        for reply in feed(self.session, data, self.where):
            self._write(reply)

    def _write(self, reply: bytes) -> None:
        try:
            self.port.write(reply)
        except (serial.SerialException, serial.SerialTimeoutException) as exc:
            log.warning("%s: reply dropped (%s)", self.where, exc)

    def close(self) -> None:
        try:
            asyncio.get_running_loop().remove_reader(self.port.fileno())
        except (RuntimeError, ValueError):
            pass
        if self._ticker is not None:
            self._ticker.cancel()
        self.port.close()
