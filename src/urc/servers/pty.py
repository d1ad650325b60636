"""Serve a protocol on a pseudo-terminal that other programs open like a serial port.

urc creates the pty and keeps a stable symlink to its device (e.g. /tmp/urc-gs232b ->
/dev/pts/7) so that ``rotctl -m 603 -r /tmp/urc-gs232b`` works. Like a real controller
on a serial line, one session lives as long as the port; clients come and go.

Output nobody reads is discarded (issue 13.5), as on a serial line with no one
listening: urc does not hold the slave end open itself, so the master reports a
hang-up while no client has the device open. Meanwhile replies and stream lines are
dropped, and whatever a departing client left unread is flushed, so the next client
reads live data only (a ``RDAZ`` reply is not read 5 s later by someone else, a G4JNT
stream does not pile up). Presence is polled every ``PRESENCE_POLL_S`` (a hung-up
master would make an asyncio reader spin), so a new client's first command waits at
most that long.

The symlink path is only ever replaced when it is a stale link of urc's own kind (a
link into /dev/pts whose device is gone); anything else there is refused, and at
shutdown only the link urc made is removed (issue 12.18).
"""

from __future__ import annotations

import asyncio
import os
import select
import termios
import time
import tty
from pathlib import Path

from .common import READ_CHUNK, SessionFactory, SessionRunner, log, needs_tick, tick_loop

PRESENCE_POLL_S = 0.05
_PTS_DIR = "/dev/pts/"


def claim_link(link: Path, device: str) -> None:
    """Create the symlink ``link`` -> ``device``. Refuses (FileExistsError) to replace
    a file, a directory or any symlink except a stale pty link (target in /dev/pts that
    no longer exists: left by a urc that was killed)."""
    link.parent.mkdir(parents=True, exist_ok=True)
    if link.is_symlink():
        target = os.readlink(link)
        if not (target.startswith(_PTS_DIR) and not os.path.exists(target)):
            raise FileExistsError(f"{link} already exists (a symlink to {target}) and urc did not "
                                  f"make it; remove it or choose another pty path")
        link.unlink()
    elif link.exists():
        raise FileExistsError(f"{link} already exists and is not a symlink urc made; "
                              f"choose another pty path")
    os.symlink(device, link)  # fails if something appeared meanwhile: never clobbers


class PtyEndpoint:
    def __init__(self, factory: SessionFactory, link: str, name: str):
        self.link = Path(link)
        self.name = name
        self.where = f"{name} pty {self.link}"
        self.session = factory()
        self.runner = SessionRunner(self.session, self._write, self.where)
        self.master_fd, slave_fd = os.openpty()
        try:
            # raw: no echo, no line discipline games with CR/LF or binary SPID frames
            # (the settings stay with the pty while the master is open)
            tty.setraw(slave_fd, termios.TCSANOW)
            self.device = os.ttyname(slave_fd)
        finally:
            os.close(slave_fd)
        os.set_blocking(self.master_fd, False)
        self._poll = select.poll()
        self._poll.register(self.master_fd, select.POLLIN)
        try:
            claim_link(self.link, self.device)
        except BaseException:
            os.close(self.master_fd)
            raise
        self.client_present = False
        self.dropped_writes = 0
        self._ticker: asyncio.Task | None = None
        self._watcher: asyncio.Task | None = None

    def start(self) -> None:
        self._watcher = asyncio.create_task(self._watch())
        if needs_tick(self.session):
            self._ticker = asyncio.create_task(tick_loop(self.runner, time.monotonic))

    # ------------------------------------------------------------ client presence
    def _hung_up(self) -> bool:
        """True while no process has the slave end open."""
        return any(ev & select.POLLHUP for _, ev in self._poll.poll(0))

    async def _watch(self) -> None:
        while True:
            present = not self._hung_up()
            if present != self.client_present:
                self._set_present(present)
            elif not present:
                self._read_left_behind()
            await asyncio.sleep(PRESENCE_POLL_S)

    def _read_left_behind(self) -> None:
        """A client that opened the port, wrote and closed it between two looks (Hamlib's
        Easycomm set holds it ~53 ms) was never seen, but what it wrote waits in the pty:
        its commands run, as a controller on a serial line would have run them (their
        replies are dropped: nobody reads). Lost before: 2 of 6 commands at 30 ms."""
        fed = False
        while True:
            try:
                data = os.read(self.master_fd, READ_CHUNK)
            except OSError:  # EIO once the departed client's bytes are read (or none)
                break
            if not data:
                break
            self.runner.feed(data)
            fed = True
        if fed:
            self.runner.hang_up()
            log.debug("%s: a client came and went between two looks: its commands were run", self.where)

    def _set_present(self, present: bool) -> None:
        loop = asyncio.get_running_loop()
        if present:
            self._discard_unread()
            loop.add_reader(self.master_fd, self._readable)
            log.debug("%s: client opened the port", self.where)
        else:
            loop.remove_reader(self.master_fd)
            self._discard_unread()
            self.runner.hang_up()
            log.debug("%s: client closed the port (%d writes dropped so far)", self.where, self.dropped_writes)
        self.client_present = present

    def _discard_unread(self) -> None:
        """Flush output queued toward the slave that nobody read. Only the slave side
        can flush that queue (tcflush on the master does not), so open it briefly."""
        try:
            fd = os.open(self.device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError:
            return
        try:
            termios.tcflush(fd, termios.TCIFLUSH)
        finally:
            os.close(fd)

    # --------------------------------------------------------------------- I/O
    def _readable(self) -> None:
        try:
            data = os.read(self.master_fd, READ_CHUNK)
        except BlockingIOError:
            return
        except OSError:  # EIO: the client closed the port just now
            self._set_present(False)
            return
        self.runner.feed(data)

    def _write(self, reply: bytes) -> None:
        if not self.client_present or self._hung_up():
            self.dropped_writes += 1     # nobody reading: a serial line would lose it too
            return
        try:
            os.write(self.master_fd, reply)
        except (BlockingIOError, OSError) as exc:
            self.dropped_writes += 1     # the client stopped reading (buffer full)
            log.debug("%s: reply dropped (%s)", self.where, exc)

    def close(self) -> None:
        try:
            asyncio.get_running_loop().remove_reader(self.master_fd)
        except (RuntimeError, ValueError):
            pass
        for task in (self._ticker, self._watcher):
            if task is not None:
                task.cancel()
        try:
            os.close(self.master_fd)
        except OSError:
            pass
        try:
            if self.link.is_symlink() and os.readlink(self.link) == self.device:
                self.link.unlink()
        except OSError:
            pass
