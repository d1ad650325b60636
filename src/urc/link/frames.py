"""Reading the link's messages without multiprocessing's blocking reads.

Both processes write with ``multiprocessing.connection.Connection.send_bytes`` (a 4-byte
big-endian signed size, then the bytes; size -1: an 8-byte size follows, for 2 GiB and
more). Its ``recv_bytes`` reads a message with two blocking reads, and its ``poll`` builds
a selector for every call. :class:`FrameReader` reads the same frames from a copy of the
socket's descriptor with one non-blocking read for whatever has arrived: the I/O process's
event loop reads the link so (``add_reader``: it must never block), and the control
process's reading thread waits on one ``poll`` object made once. Written here because the
library reads frames only with blocking reads; a set's round trip is a few such reads.
"""

from __future__ import annotations

import os
import select
import socket
import struct
from multiprocessing.connection import Connection

#: how much one read takes of what has arrived
READ_CHUNK = 256 * 1024
_SIZE = struct.Struct("!i")
_BIG_SIZE = struct.Struct("!Q")


class Frames:
    """multiprocessing.connection's frames, taken apart from a byte stream."""

    def __init__(self) -> None:
        self._buf = bytearray()

    def feed(self, chunk: bytes) -> list[bytes]:
        """The messages ``chunk`` completes, in order (a partial one waits for the next)."""
        buf = self._buf
        buf += chunk
        out, at = [], 0
        while len(buf) - at >= 4:
            (size,) = _SIZE.unpack_from(buf, at)
            head = 4
            if size == -1:
                if len(buf) - at < 12:
                    break
                (size,) = _BIG_SIZE.unpack_from(buf, at + 4)
                head = 12
            elif size < 0:
                raise ValueError(f"a frame of size {size}: not multiprocessing's framing")
            if len(buf) - at - head < size:
                break
            out.append(bytes(buf[at + head:at + head + size]))
            at += head + size
        del buf[:at]
        return out


class FrameReader:
    """The messages arriving on ``conn``'s socket, read without blocking. It reads a copy
    of the descriptor (``recv`` with MSG_DONTWAIT, not O_NONBLOCK, which would make the
    Connection's own blocking sends fail with EAGAIN): :meth:`close` closes only the copy."""

    def __init__(self, conn: Connection):
        self.sock = socket.socket(fileno=os.dup(conn.fileno()))
        self._frames = Frames()
        self._poll = select.poll()
        self._poll.register(self.sock.fileno(), select.POLLIN)

    def fileno(self) -> int:
        return self.sock.fileno()

    @property
    def closed(self) -> bool:
        return self.sock.fileno() < 0

    def wait(self, timeout_s: float) -> bool:
        """Something to read (or the peer gone) within ``timeout_s``."""
        return bool(self._poll.poll(max(timeout_s, 0.0) * 1000.0))

    def read(self) -> list[bytes] | None:
        """The messages completed by what has arrived ([] if none: nothing yet, or part
        of one); None once the peer closed. Raises OSError if the socket failed, ValueError
        for bytes that are not frames."""
        try:
            chunk = self.sock.recv(READ_CHUNK, socket.MSG_DONTWAIT)
        except (BlockingIOError, InterruptedError):
            return []
        return self._frames.feed(chunk) if chunk else None

    def close(self) -> None:
        self.sock.close()
