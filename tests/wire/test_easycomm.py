"""The Easycomm I/II/III wire codec (protocols.md 2), both ends: the lines a device
parses, the replies it formats, and what Hamlib sends and accepts, tested the h11 way."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from urc.wire.easycomm import (COMMANDS_II, COMMANDS_III, Command, EasycommParseError, format_axis,
                               format_az_el, format_set_position, format_value, parse_axis_reply,
                               parse_az_el_reply, parse_line)


@pytest.mark.parametrize("line, cmds", [
    # what Hamlib sends (protocols.md 2.2)
    (b"AZ100.0 EL20.0", [Command("AZ", 100.0), Command("EL", 20.0)]),
    (b"AZ-10.0 EL5.5", [Command("AZ", -10.0), Command("EL", 5.5)]),
    (b"AZ EL ", [Command("AZ"), Command("EL")]),
    (b"AZ", [Command("AZ")]),
    (b"EL", [Command("EL")]),
    (b"SA SE ", [Command("SA"), Command("SE")]),
    (b"PARK", [Command("PARK")]),
    (b"RESET", [Command("RESET")]),
    (b"MU", [Command("MU")]), (b"MD", [Command("MD")]),
    (b"ML", [Command("ML")]), (b"MR", [Command("MR")]),
    (b"VU4900", [Command("VU", 4900.0)]), (b"VD0000", [Command("VD", 0.0)]),
    (b"VL9900", [Command("VL", 9900.0)]), (b"VR3000", [Command("VR", 3000.0)]),
    (b"GS", [Command("GS")]), (b";GE", [Command("GE")]), (b";VE", [Command("VE")]),
    (b"CR 1", [Command("CR", "1")]),
    (b"CW1,5", [Command("CW", "1,5")]),
    (b"IP0", [Command("IP", 0.0)]), (b"AN1", [Command("AN", 1.0)]),
    # Easycomm I: frequency and mode words are accepted (and ignored by the session)
    (b"AZ100.0 EL20.0 UP000 XXX DN000 XXX",
     [Command("AZ", 100.0), Command("EL", 20.0), Command("UP", 0.0), Command("DN", 0.0)]),
    (b"AZ123.4 EL45.6 UP145800000 FM DN435000000 USB",
     [Command("AZ", 123.4), Command("EL", 45.6), Command("UP", 145800000.0),
      Command("DN", 435000000.0)]),
    # lenient: lower case, a value in its own token, extra spaces and tabs
    (b"az100 el20", [Command("AZ", 100.0), Command("EL", 20.0)]),
    (b"AZ 100  EL\t+20.", [Command("AZ", 100.0), Command("EL", 20.0)]),
    (b"AZ.5", [Command("AZ", 0.5)]),
    (b"", []), (b" ;; ", []),
])
def test_parse_whole_lines(line, cmds):
    assert parse_line(line) == cmds


@pytest.mark.parametrize("line", [
    b"AZnan", b"AZinf", b"AZ1e3", b"AZ100.0 ELxyz", b"AZ100.0 EL20.0 BOGUS", b"QQ",
    b"AZ100,0", b"AZ--1", b"AZ+", b"AZ.", b"VU", b"VUx", b"CR", b"CW", b"SAX", b"VE1",
    b"AZ\x00100", b"AZ100.0\xffEL20.0", b"AZ1234567890123", b"A", b"PAR",
])
def test_parse_rejects_whole_line(line):
    with pytest.raises(EasycommParseError) as info:
        parse_line(line)
    assert info.value.found  # says what it found
    assert "expected" in str(info.value)


def test_version_ii_lacks_iii_commands():
    for line in (b"GS", b"GE", b"VU4900", b"CR 1", b"CW1,5"):
        assert parse_line(line, COMMANDS_III)
        with pytest.raises(EasycommParseError):
            parse_line(line, COMMANDS_II)


def test_reply_formats():
    assert format_az_el(100, 20) == b"AZ100.0 EL20.0\n"
    assert format_axis("AZ", 100) == b"AZ100.0\n"
    assert format_axis("EL", 20) == b"EL20.0\n"
    assert format_az_el(359.96, -0.04) == b"AZ360.0 EL0.0\n"
    assert format_value("VE", "x" * 100) == b"VE" + b"x" * 28 + b"\n"   # Hamlib reads 31


@given(az=st.floats(0.0, 359.94), el=st.floats(-5.0, 180.0))
def test_round_trips(az, el):
    """Host format -> device parse, and device format -> Hamlib's parse, agree to 0.1."""
    az1, el1 = round(az, 1), round(el, 1)
    assert parse_line(format_set_position(az, el)[:-1]) == [Command("AZ", az1), Command("EL", el1)]
    assert parse_az_el_reply(format_az_el(az, el)) == pytest.approx((az1, el1), abs=1e-9)
    assert parse_axis_reply(format_axis("AZ", az), "AZ") == pytest.approx(az1, abs=1e-9)
    assert parse_axis_reply(format_axis("EL", el), "EL") == pytest.approx(el1, abs=1e-9)


def test_hamlib_reply_parsers_match_captures():
    """protocols.md 2.3: which replies Hamlib 4.5 accepts for ``AZ EL ``."""
    for ok in (b"AZ100.0 EL20.0\n", b"AZ100.0 EL20.0\r\n", b"AZ 100 EL 20", b"AZ+100 EL+20",
               b"AZ100.0EL20.0\n"):
        assert parse_az_el_reply(ok) == (100.0, 20.0)
    for bad in (b"AZ EL \n", b"AZ100.0\n"):
        with pytest.raises(EasycommParseError):
            parse_az_el_reply(bad)
    with pytest.raises(EasycommParseError):
        parse_axis_reply(b"AZ100.0 EL20.0\n", "EL")   # a combined reply fails EL%f
