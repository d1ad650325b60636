"""The shared line input/output (urc.protocols.lines) and number helpers
(urc.protocols.numbers) every line-based session uses."""

from __future__ import annotations

import logging
import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from urc.protocols.lines import Line, LineSplitter, TerminalEcho, crlf_line, next_due_s
from urc.protocols.numbers import DECIMAL, compass_tenths, format_deg


# ================================================================ line splitter
def test_line_endings_cr_lf_crlf_split_anywhere():
    data = b"A\rB\nC\r\nD\n\rE\r"
    whole = [l.text for l in LineSplitter().feed(data)]
    assert whole == [b"A", b"B", b"C", b"D", b"", b"E"]
    sp, bytewise = LineSplitter(), []
    for byte in data:
        bytewise += [l.text for l in sp.feed(bytes([byte]))]
    assert bytewise == whole


def test_backspace_and_overflow():
    sp = LineSplitter(max_len=8, backspace=True)
    assert [l.text for l in sp.feed(b"RDX\x7fAZ\x08Z\r")] == [b"RDAZ"]
    out = sp.feed(b"x" * 20)
    assert [l.overflowed for l in out] == [True]
    assert sp.feed(b"y" * 20 + b"\rOK\r") == [Line(b"OK")]


def test_any_split_and_bounded():
    """(The Easycomm / GS-232 line buffer's test. That buffer gave an extra empty line
    for each CRLF, which those sessions skip; the shared splitter counts CRLF once.)"""
    data = b"AZ\nEL\r\nAZ EL \rVE"
    whole = LineSplitter(64).feed(data)
    assert [l.text for l in whole] == [b"AZ", b"EL", b"AZ EL "]
    lb = LineSplitter(64)
    assert [x for i in range(len(data)) for x in lb.feed(data[i:i + 1])] == whole
    assert lb.pending == 2 and lb.partial == b"VE"
    lb = LineSplitter(8)
    assert lb.feed(b"0123456789") == [Line(b"", overflowed=True)] and lb.pending == 0
    assert lb.feed(b"MORE\nAZ\n") == [Line(b"AZ")]          # the overlong line's tail is dropped


def test_backspace_off_keeps_the_bytes():
    assert LineSplitter().feed(b"A\x08B\x7f\n") == [Line(b"A\x08B\x7f")]
    sp = LineSplitter(backspace=True)
    assert sp.feed(b"\x08\x7fAB\x08") == [] and sp.partial == b"A"      # nothing to rub out: no-op


def test_overflow_at_exactly_max_len_and_logged(caplog):
    sp = LineSplitter(4, log=logging.getLogger("urc.protocols.test"))
    assert sp.feed(b"ABCD\r") == [Line(b"ABCD")]                        # max_len itself is fine
    with caplog.at_level(logging.WARNING, logger="urc.protocols.test"):
        assert sp.feed(b"ABCDE") == [Line(b"", overflowed=True)]        # reported at once
        assert sp.feed(b"FGH\r\nOK\r") == [Line(b"OK")]
    assert caplog.text.count("line longer than 4 bytes dropped") == 1
    # with backspace, the bound applies to what is on the line, not to what was typed
    sp = LineSplitter(4, backspace=True)
    assert sp.feed(b"ABCD\x7f\x7fEF\r") == [Line(b"ABEF")]


_BYTES = st.lists(st.sampled_from([b"\r", b"\n", b"\r\n", b"\x08", b"\x7f", b"A", b"BC", b"xxxxx", b" "]),
                  max_size=40).map(b"".join)


@given(data=_BYTES, split=st.integers(1, 7), backspace=st.booleans())
def test_same_lines_whatever_the_split(data, split, backspace):
    whole = LineSplitter(6, backspace=backspace).feed(data)
    sp = LineSplitter(6, backspace=backspace)
    chunked = [line for i in range(0, len(data), split) for line in sp.feed(data[i:i + split])]
    assert chunked == whole
    assert all(len(line.text) <= 6 for line in whole)
    assert len(whole) <= data.count(b"\r") + data.count(b"\n") + 1      # one overflow per line at most


# ================================================================ echo, output
def test_terminal_echo_rubs_out():
    echo = TerminalEcho()
    assert echo.update(b"RD") == b"RD"
    assert echo.update(b"RDX") == b"X"
    assert echo.update(b"R") == b"\b \b\b \b"
    assert echo.end_line(b"RDAZ") == b"DAZ\r\n"
    assert echo.update(b"") == b""


def test_crlf_line():
    assert crlf_line("OK") == b"OK\r\n"
    assert crlf_line("°") == b"?\r\n"


# ===================================================================== numbers
@pytest.mark.parametrize("text", ["123", "-5.5", "+.5", "12.", "0"])
def test_decimal_accepts(text):
    assert re.fullmatch(DECIMAL, text)


@pytest.mark.parametrize("text", ["", ".", "1e3", "nan", "inf", "--1", "1.2.3", "0x10"])
def test_decimal_refuses(text):
    assert not re.fullmatch(DECIMAL, text)


@pytest.mark.parametrize("v, text", [(123.4, "123.4"), (45, "045.0"), (0, "000.0"), (-0.04, "000.0"),
                                     (-5, "-005.0"), (399.96, "400.0"), (7.25, "007.2")])
def test_format_deg(v, text):
    assert format_deg(v) == text


def test_compass_tenths():
    assert [compass_tenths(a) for a in (359.97, 359.94, 0.0, 123.44, -0.01)] == [0.0, 359.9, 0.0, 123.4, 0.0]


def test_stream_pace():
    assert next_due_s(None, 10.0, 0.5) == 10.5                  # the first line at once
    assert next_due_s(10.5, 10.2, 0.5) is None
    assert next_due_s(10.5, 10.5 - 1e-12, 0.5) == 11.0          # float drift is due
    assert next_due_s(10.5, 10.7, 0.5) == 11.0                  # on the grid
    assert next_due_s(11.0, 20.0, 0.5) == 20.5                  # after a stall: from now
