"""Serve a protocol on a pseudo-terminal that other programs open like a serial port.

urc creates the pty and keeps a stable symlink to its device (e.g. /tmp/urc-gs232b ->
/dev/pts/7) so that ``rotctl -m 603 -r /tmp/urc-gs232b`` works. Like a real controller
on a serial line, one session lives as long as the port; clients come and go.
"""

from __future__ import annotations

import asyncio
import os
import termios
import time
import tty
from pathlib import Path

from .common import READ_CHUNK, SessionFactory, feed, log, needs_tick, tick_loop


class PtyEndpoint:
    def __init__(self, factory: SessionFactory, link: str, name: str):
        self.link = Path(link)
        self.name = name
        self.session = factory()
        self.master_fd, self.slave_fd = os.openpty()
        # raw: no echo, no line discipline games with CR/LF or binary SPID frames
        tty.setraw(self.slave_fd, termios.TCSANOW)
        self.device = os.ttyname(self.slave_fd)
        os.set_blocking(self.master_fd, False)
        self.link.parent.mkdir(parents=True, exist_ok=True)
        if self.link.is_symlink() or self.link.exists():
            if not self.link.is_symlink():
                raise FileExistsError(f"{self.link} exists and is not a symlink urc made")
            self.link.unlink()
        self.link.symlink_to(self.device)
        self._ticker: asyncio.Task | None = None

    def start(self) -> None:
        loop = asyncio.get_running_loop()
        loop.add_reader(self.master_fd, self._readable)
        if needs_tick(self.session):
            self._ticker = asyncio.create_task(tick_loop(self.session, self._write, time.monotonic,
                                                     f"{self.name} pty {self.link}"))

    def _readable(self) -> None:
        try:
            data = os.read(self.master_fd, READ_CHUNK)
        except BlockingIOError:
            return
        except OSError:  # EIO: no client has the slave open right now
            return
        for reply in feed(self.session, data, f"{self.name} pty {self.link}"):
            self._write(reply)

    def _write(self, reply: bytes) -> None:
        try:
            os.write(self.master_fd, reply)
        except (BlockingIOError, OSError) as exc:
            # nobody reading (or the buffer is full): a serial line would lose it too
            log.debug("%s pty %s: reply dropped (%s)", self.name, self.link, exc)

    def close(self) -> None:
        try:
            asyncio.get_running_loop().remove_reader(self.master_fd)
        except RuntimeError:
            pass
        if self._ticker is not None:
            self._ticker.cancel()
        for fd in (self.master_fd, self.slave_fd):
            try:
                os.close(fd)
            except OSError:
                pass
        try:
            if self.link.is_symlink() and os.readlink(self.link) == self.device:
                self.link.unlink()
        except OSError:
            pass
