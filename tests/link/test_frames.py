"""urc.link.frames: multiprocessing's frames read without its blocking reads, checked
against what ``Connection.send_bytes`` really writes."""

from __future__ import annotations

import socket
import struct
from multiprocessing.connection import Connection

import pytest

from urc.link.frames import FrameReader, Frames


def _wire(*messages: bytes) -> bytes:
    """The bytes Connection.send_bytes puts on a socket for ``messages``."""
    ours, theirs = socket.socketpair()
    sender = Connection(ours.detach())
    for m in messages:
        sender.send_bytes(m)
    sender.close()
    out = b""
    while chunk := theirs.recv(1 << 20):
        out += chunk
    theirs.close()
    return out


def test_frames_split_anywhere_come_out_whole_and_in_order():
    messages = [b"", b"a", b"x" * 70_000, b"\x00\xff" * 3]
    wire = _wire(*messages)
    for cut in (1, 3, 4, 5, 1000, len(wire)):
        frames, got = Frames(), []
        for i in range(0, len(wire), cut):
            got += frames.feed(wire[i:i + cut])
        assert got == messages, cut


def test_the_long_size_form_is_read_and_a_negative_size_refused():
    # (2 GiB and more: size -1, then an 8-byte size; built by hand, as sending 2 GiB is not)
    assert Frames().feed(struct.pack("!i", -1) + struct.pack("!Q", 3) + b"abc") == [b"abc"]
    with pytest.raises(ValueError, match="size -2"):
        Frames().feed(struct.pack("!i", -2) + b"junk")


def test_a_reader_reads_without_blocking_and_says_when_the_peer_has_gone():
    ours, theirs = socket.socketpair()
    sender = Connection(ours.detach())
    reader_conn = Connection(theirs.detach())
    reader = FrameReader(reader_conn)
    try:
        assert reader.read() == [] and not reader.wait(0.05)   # nothing yet: no wait in read
        sender.send_bytes(b"one")
        sender.send_bytes(b"two")
        assert reader.wait(1.0) and reader.read() == [b"one", b"two"]
        reader_conn.send_bytes(b"back")   # the connection's own blocking send still works
        assert sender.recv_bytes() == b"back"
        sender.close()
        assert reader.wait(1.0) and reader.read() is None
    finally:
        reader.close()
        reader_conn.close()
    assert reader.closed
