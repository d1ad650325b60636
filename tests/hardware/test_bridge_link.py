"""The bridge's I/O thread on a real pseudo-terminal: what a closed port does."""

from __future__ import annotations

import os
import time
import tty

import pytest

from urc.hardware.bridge import BridgeClient, make_dialect
from urc.hardware.bridge.link import LinkError, LinkRunner, SyncLink


@pytest.fixture
def pty_pair():
    master, slave = os.openpty()
    tty.setraw(slave)
    yield master, os.ttyname(slave)
    for fd in (master, slave):
        try:
            os.close(fd)
        except OSError:
            pass


def test_a_pty_closed_by_the_controller_is_a_link_error(pty_pair):
    """pyserial flushes a tty with termios, whose error is no OSError: the flush of a pty
    whose other end closed must still come out as a LinkError (it used to escape and end
    the I/O thread)."""
    master, path = pty_pair
    link = SyncLink(path, 9600, 0.2)
    os.close(master)
    with pytest.raises(LinkError, match="Input/output error"):
        link.exchange(make_dialect("gs232b").poll())
    link.close()


def test_the_io_thread_reports_a_closed_pty_as_a_lost_link(pty_pair):
    master, path = pty_pair
    client = BridgeClient(make_dialect("gs232b"))
    runner = LinkRunner(client, path, 9600, reconnect_attempts=2)
    runner.start()
    try:
        # answer the first polls like a GS-232B, then go away
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and not client.wait_report(0.0):
            try:
                if os.read(master, 64).endswith(b"C2\r"):
                    os.write(master, b"AZ=100  EL=020\r\n")
            except BlockingIOError:
                pass
        assert client.reading("az") == 100.0
        os.close(master)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and not client.error().startswith("link lost"):
            time.sleep(0.02)
        assert client.error().startswith("link lost: "), client.error()
        assert runner._thread.is_alive() or "gave up" in client.error()
    finally:
        runner.close()
