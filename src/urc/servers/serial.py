"""Serve a protocol on a real serial device (pyserial), one session for the port's life."""

from __future__ import annotations

import asyncio
import time
from typing import Any

import serial

from .common import READ_CHUNK, SessionFactory, SessionRunner, log, needs_tick, tick_loop


class SerialEndpoint:
    def __init__(self, factory: SessionFactory, device: str, baud: int, name: str):
        self.name = name
        self.where = f"{name} serial {device}"
        self.session = factory()
        self.port = serial.Serial(device, baudrate=baud, timeout=0, write_timeout=0)
        self.runner = SessionRunner(self.session, self._write, self.where, after=self._apply_baud_request)
        self._ticker: asyncio.Task | None = None

    def start(self) -> None:
        asyncio.get_running_loop().add_reader(self.port.fileno(), self._readable)
        if needs_tick(self.session):
            self._ticker = asyncio.create_task(tick_loop(self.runner, time.monotonic))

    def _readable(self) -> None:
        try:
            data = self.port.read(READ_CHUNK)
        except serial.SerialException as exc:
            log.error("%s: read failed: %s", self.where, exc)
            return
        self.runner.feed(data)

    def _apply_baud_request(self) -> None:
        """A session may ask for a new line rate (Tartu ``BAUD 9600``): it takes effect
        once its reply has gone out at the old rate, as on the controller."""
        session: Any = self.session  # (the attribute is a Tartu session's own)
        rate = getattr(session, "baud_request", None)
        if rate is None:
            return
        session.baud_request = None
        try:
            self.port.flush()
            self.port.baudrate = rate
            log.info("%s: line rate now %d baud", self.where, rate)
        except (serial.SerialException, ValueError, OSError) as exc:
            log.warning("%s: cannot change the rate to %d baud: %s", self.where, rate, exc)

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
        self.runner.hang_up()
        self.port.close()
