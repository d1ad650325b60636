"""The Yaesu GS-232A/B wire codec (protocols.md 3, 5.3), both ends: what a host sends and
how Hamlib's backends parse the device's replies, tested the h11 way."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from gs232_hamlib import hamlib_read
from urc.wire.gs232 import (STYLE_A, STYLE_B, STYLE_GENERIC, Command, Gs232ParseError, format_error,
                            format_goto, format_position, parse_command, parse_position_reply)


@pytest.mark.parametrize("line, cmd", [
    (b"C", Command("read", "az")),
    (b"C2", Command("read", "azel")),
    (b"B", Command("read", "el")),
    (b"W100 020", Command("goto", az_deg=100.0, el_deg=20.0)),
    (b"W450 180", Command("goto", az_deg=450.0, el_deg=180.0)),
    (b"W350 006", Command("goto", az_deg=350.0, el_deg=6.0)),
    (b"M270", Command("goto_az", az_deg=270.0)),
    (b"S", Command("stop", None)),
    (b"A", Command("stop", "az")),
    (b"E", Command("stop", "el")),
    (b"L", Command("move", "az", direction=-1)),
    (b"R", Command("move", "az", direction=1)),
    (b"U", Command("move", "el", direction=1)),
    (b"D", Command("move", "el", direction=-1)),
    (b"X1", Command("speed", level=1)),
    (b"X4", Command("speed", level=4)),
    # lower case (GS-232A manual; protocols.md 3.5) and stray spaces
    (b"w100 020", Command("goto", az_deg=100.0, el_deg=20.0)),
    (b"c2", Command("read", "azel")),
    (b" x2 ", Command("speed", level=2)),
    (b"W 90  5", Command("goto", az_deg=90.0, el_deg=5.0)),
])
def test_parse_whole_commands(line, cmd):
    assert parse_command(line) == cmd


@pytest.mark.parametrize("line", [
    b"X5", b"X0", b"X", b"W100", b"W1000 000", b"W100 020 030", b"W-10 020", b"Wnan 020",
    b"W100.5 020", b"Minf", b"M", b"C3", b"CC", b"Q", b"W100,020", b"W100\x00020",
    b"W010 100 020 110 030",  # timed list (with T): not supported
    b"\xff", b"S S",
])
def test_parse_rejects(line):
    with pytest.raises(Gs232ParseError) as info:
        parse_command(line)
    assert info.value.found == line  # the error shows what was received


def test_error_message_names_what_was_expected():
    with pytest.raises(Gs232ParseError, match=r"expected a GS-232 command \(H lists them\), found b'Q'"):
        parse_command(b"Q")


@pytest.mark.parametrize("style, az, el, wire", [
    (STYLE_A, 100, 20, b"+0100+0020\r\n"),
    (STYLE_A, 450, 180, b"+0450+0180\r\n"),
    (STYLE_A, 5, None, b"+0005\r\n"),
    (STYLE_A, None, 45, b"+0045\r\n"),
    (STYLE_B, 100, 20, b"AZ=100  EL=020\r\n"),
    (STYLE_B, 350, 6, b"AZ=350  EL=006\r\n"),
    (STYLE_B, 100, None, b"AZ=100\r\n"),
    (STYLE_B, None, 20, b"EL=020\r\n"),
    (STYLE_GENERIC, 100, 20, b"+0100+0020\r"),
    (STYLE_GENERIC, 0, 0, b"+0000+0000\r"),
    # whole degrees; noise below the bottom stop is not a negative angle
    (STYLE_A, 99.6, 20.4, b"+0100+0020\r\n"),
    (STYLE_A, -0.3, -0.2, b"+0000+0000\r\n"),
])
def test_format_position(style, az, el, wire):
    assert format_position(style, az, el) == wire


def test_format_error():
    assert format_error(STYLE_A) == b"?>\r"
    assert format_error(STYLE_B) == b"?>\r\n"
    assert format_error(STYLE_GENERIC) == b"?>\r"


@given(az=st.integers(0, 450), el=st.integers(0, 180),
       style=st.sampled_from([STYLE_A, STYLE_B, STYLE_GENERIC]))
def test_position_round_trip_through_hamlib_parsers(az, el, style):
    wire = format_position(style, az, el)
    assert parse_position_reply(style, hamlib_read(style, wire)) == (az, el)


@given(az=st.floats(-180.0, 450.0), el=st.floats(0.0, 180.0))
def test_goto_round_trip(az, el):
    """What Hamlib sends for set_position parses back to the same whole degrees."""
    cmd = parse_command(format_goto(az, el)[:-1])
    assert cmd.op == "goto"
    assert cmd.az_deg == (round(az) + 360 if round(az) < 0 else round(az))
    assert cmd.el_deg == round(el)


def test_format_goto_matches_hamlib_capture():
    assert format_goto(100, 20) == b"W100 020\r"
    assert format_goto(-10, 5.6) == b"W350 006\r"  # protocols.md 3.2


@pytest.mark.parametrize("reply, ok", [
    (b"AZ=100EL=020\r", True), (b"AZ=100 EL=020\r", True), (b"AZ=100  EL=020\r", True),
    (b"AZ=100\r", False), (b"+0100+0020\r", False),
])
def test_hamlib_603_parser_matches_captures(reply, ok):
    """The host-side parser behaves like the captured Hamlib 603 (protocols.md 3.3)."""
    if ok:
        assert parse_position_reply(STYLE_B, reply) == (100, 20)
    else:
        with pytest.raises(Gs232ParseError):
            parse_position_reply(STYLE_B, reply)


def test_hamlib_601_rejects_b_style_and_unpadded():
    for reply in (b"AZ=100  EL=020\r\n", b"+100+020\r\n"):
        with pytest.raises(Gs232ParseError):
            parse_position_reply(STYLE_A, reply)


# ============================================================ BIG-RAS extensions (seed 002)
@pytest.mark.parametrize("line, cmd", [
    (b"AZ=100", Command("goto_az", az_deg=100.0)),
    (b"EL=045", Command("goto_el", el_deg=45.0)),
    (b"AZ=120 EL=030", Command("goto", az_deg=120.0, el_deg=30.0)),
    (b"az=120  el=030", Command("goto", az_deg=120.0, el_deg=30.0)),
    (b"K020", Command("goto_el", el_deg=20.0)),
    (b"ML", Command("move", "az", direction=-1)), (b"MR", Command("move", "az", direction=1)),
    (b"MU", Command("move", "el", direction=1)), (b"MD", Command("move", "el", direction=-1)),
    (b"H", Command("help")), (b"h", Command("help")),
    (b"$GPGGA,1", Command("nmea", text=b"$GPGGA,1")),
])
def test_bigras_extensions_parse(line, cmd):
    assert parse_command(line) == cmd


@pytest.mark.parametrize("line", [b"AZ=", b"AZ", b"EL=1000", b"K", b"MX", b"AZ=1 EL"])
def test_bigras_extension_errors(line):
    with pytest.raises(Gs232ParseError):
        parse_command(line)
