"""Junk input on every protocol (issue 13.1): skipped cheaply, logged at a bounded rate,
answered briefly. (bench/junk_bench.py measures the stall and lateness on a real urc.)"""

from __future__ import annotations

import logging

import pytest

from urc.protocols import make_session
from urc.testing.sessions import fed

LINE_PROTOCOLS = ["urc", "sarcnet", "g4jnt", "gs232a", "gs232b", "easycomm2", "easycomm3"]


class FakeClock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def _protocol_records(caplog) -> list[logging.LogRecord]:
    return [r for r in caplog.records if r.name.startswith("urc.protocols")]


def test_rate_limited_log_logs_first_then_one_summary_per_interval(caplog):
    from urc.protocols.base import RateLimitedLog

    clock = FakeClock()
    limited = RateLimitedLog(logging.getLogger("urc.test.junk"), interval_s=5.0, clock=clock)
    caplog.set_level("INFO", logger="urc.test.junk")
    for _ in range(10_000):
        limited.info("bad %r", "x")
    limited.info("other kind %d", 1)          # another kind is not hidden by the flood
    assert [r.getMessage() for r in caplog.records] == ["bad 'x'", "other kind 1"]
    clock.t = 5.0
    limited.info("bad %r", "y", count=3)
    assert caplog.records[-1].getMessage() == "bad 'y' [and 9999 more like it since the last such line]"
    clock.t = 10.0
    limited.info("bad %r", "z")
    assert caplog.records[-1].getMessage().endswith("[and 2 more like it since the last such line]")


def test_rotctld_junk_is_logged_at_a_bounded_rate_and_answered_with_nothing(bench, caplog):
    b = bench("tartu-urc")
    s = make_session("rotctld", b.rot)
    caplog.set_level("INFO", logger="urc.protocols")
    replies = fed(s, b"Z" * 65536) + fed(s, b"Zz\r\n" * 20_000) + fed(s, b"p\n")
    assert len(replies) == 1 and replies[0].count(b"\n") == 2   # only p is answered
    junk_lines = [r for r in _protocol_records(caplog) if "not found" in r.getMessage()]
    assert len(junk_lines) == 1              # was one line per byte (85 536 here)


@pytest.mark.parametrize("protocol", LINE_PROTOCOLS)
def test_junk_lines_are_answered_briefly_and_logged_at_a_bounded_rate(bench, caplog, protocol):
    b = bench("tartu-urc")
    s = make_session(protocol, b.rot)
    caplog.set_level("INFO", logger="urc.protocols")
    replies = []
    for _ in range(20):
        replies += fed(s, b"x\r\n" * 100 + b"\x01\x02 ??? \r\n")
    # at most one short line per bad line: no command list (was ~160 bytes a line on
    # Tartu, 3.4 MB for 64 KiB of junk)
    assert len(replies) <= 2020
    assert all(len(r) <= 80 for r in replies), max(replies, key=len)
    assert len(_protocol_records(caplog)) <= 4


def test_spid_junk_is_logged_at_a_bounded_rate(bench, caplog):
    b = bench("tartu-urc")
    s = make_session("rot2prog", b.rot)
    caplog.set_level("INFO", logger="urc.protocols")
    for _ in range(2000):
        assert fed(s, b"junk junk junk\r\n") == []
    assert len(_protocol_records(caplog)) <= 2
