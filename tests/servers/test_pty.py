"""Serving a protocol on a pseudo-terminal: output nobody reads is discarded (issue
13.5) and the link path never clobbers what urc did not make (issue 12.18)."""

from __future__ import annotations

import asyncio
import os

import pytest

from urc.protocols import make_session
from urc.servers import pty as pty_module
from urc.servers.pty import PtyEndpoint

PRESENCE_POLL_S = getattr(pty_module, "PRESENCE_POLL_S", 0.05)


def _open(path) -> int:
    return os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)


def _read_all(fd: int) -> bytes:
    out = b""
    while True:
        try:
            chunk = os.read(fd, 4096)
        except (BlockingIOError, OSError):
            return out
        if not chunk:
            return out
        out += chunk


async def _settle(seconds: float = 4 * PRESENCE_POLL_S) -> None:
    await asyncio.sleep(seconds)


def test_a_reply_left_unread_is_not_read_by_the_next_client(bench, tmp_path):
    b = bench("tartu-urc")
    link = tmp_path / "urc-tartu"

    async def scenario() -> tuple[bytes, bytes]:
        ep = PtyEndpoint(lambda: make_session("urc", b.rot), str(link), "urc")
        ep.start()
        try:
            first = _open(link)
            await _settle()
            os.write(first, b"RDAZ\r\n")
            await _settle()
            os.close(first)            # gone without reading its reply
            await _settle()
            second = _open(link)
            await _settle()
            stale = _read_all(second)
            os.write(second, b"RDAZ\r\n")
            await _settle()
            fresh = _read_all(second)
            os.close(second)
            return stale, fresh
        finally:
            ep.close()
    stale, fresh = asyncio.run(scenario())
    assert stale == b""                 # was b"000.0\r\n", the first client's reply
    assert fresh.endswith(b"\r\n") and fresh.count(b"\r\n") == 1


def test_a_stream_does_not_pile_up_while_nobody_listens(bench, tmp_path):
    b = bench("g4jnt")
    link = tmp_path / "urc-g4jnt"

    async def scenario() -> bytes:
        ep = PtyEndpoint(lambda: make_session("g4jnt", b.rot, interval_s=0.1), str(link), "g4jnt")
        ep.start()
        try:
            await asyncio.sleep(1.5)     # ~15 stream lines due, nobody there
            fd = _open(link)
            await asyncio.sleep(0.05)
            got = _read_all(fd)
            os.close(fd)
            return got
        finally:
            ep.close()
    got = asyncio.run(scenario())
    assert got.count(b"\n") <= 2         # live lines only (was every line since start-up)


def test_a_file_at_the_pty_path_is_refused_and_kept(bench, tmp_path):
    b = bench("tartu-urc")
    path = tmp_path / "precious"
    path.write_text("keep me")
    with pytest.raises(FileExistsError, match="already exists"):
        PtyEndpoint(lambda: make_session("urc", b.rot), str(path), "urc")
    assert path.read_text() == "keep me"


def test_a_foreign_symlink_is_refused_and_kept(bench, tmp_path):
    b = bench("tartu-urc")
    target = tmp_path / "target"
    target.write_text("x")
    link = tmp_path / "link"
    link.symlink_to(target)
    with pytest.raises(FileExistsError, match="did not make it"):
        PtyEndpoint(lambda: make_session("urc", b.rot), str(link), "urc")
    assert os.readlink(link) == str(target) and target.read_text() == "x"


def test_a_stale_pty_link_is_replaced_and_only_urcs_link_is_removed(bench, tmp_path):
    b = bench("tartu-urc")
    link = tmp_path / "urc-pty"
    link.symlink_to("/dev/pts/987654")           # left by a urc that was killed

    async def scenario() -> str:
        ep = PtyEndpoint(lambda: make_session("urc", b.rot), str(link), "urc")
        ep.start()
        device = os.readlink(link)
        ep.close()
        return device
    device = asyncio.run(scenario())
    assert device.startswith("/dev/pts/") and device != "/dev/pts/987654"
    assert not link.exists() and not link.is_symlink()


def test_closing_the_port_abandons_a_sarcnet_calibration(bench, tmp_path):
    """Seed 001: the USB cable pulled mid-calibration: nothing saved, the hold released."""
    b = bench("sarcnet-mini")
    link = tmp_path / "urc-sarcnet"
    before = b.rot.hw.axis("az").sensor.calibration()

    async def scenario() -> tuple[tuple, tuple, bytes]:
        ep = PtyEndpoint(lambda: make_session("sarcnet", b.rot), str(link), "sarcnet")
        ep.start()
        try:
            fd = _open(link)
            await _settle()
            os.write(fd, b"c\r")
            await _settle()
            during = b.rot.local_controls()
            said = _read_all(fd)
            os.close(fd)
            await _settle()
            return during, b.rot.local_controls(), said
        finally:
            ep.close()

    during, after, said = asyncio.run(scenario())
    assert said.startswith(b"Calibration in progress") and during == ("SARCNET calibration",)
    assert after == () and b.rot.hw.axis("az").sensor.calibration() == before


def test_a_client_that_comes_and_goes_between_two_looks_is_still_heard(bench, tmp_path):
    """Hamlib's Easycomm set holds the port ~53 ms: a client that opens, writes and
    closes before urc's presence look (every PRESENCE_POLL_S) had its command lost."""
    b = bench("tartu-urc")
    link = tmp_path / "urc-gs232b"

    async def scenario() -> None:
        ep = PtyEndpoint(lambda: make_session("gs232b", b.rot), str(link), "gs232b")
        ep.start()
        try:
            await _settle()
            fd = _open(link)
            os.write(fd, b"W123 030\r")
            os.close(fd)               # gone at once: never seen present
            await _settle()
        finally:
            ep.close()
    asyncio.run(scenario())
    s = b.run(0.1)
    assert (s.target_az_deg, s.target_el_deg) == (123.0, 30.0), (s.target_az_deg, s.target_el_deg)
