"""Tartu URC four-letter command set (the first seed machine).

Codec tests the h11 way, line splitting, session transcripts, and end-to-end runs on the
tartu-urc profile (400 deg azimuth, 0..180 elevation, 10 pulses/degree encoders) judged
by the simulator's truth.
"""

from __future__ import annotations

import re

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from conftest import Bench
from session_replay import raises_nothing
from urc.protocols import MAX_PENDING_BYTES, make_session
from urc.protocols import tartu_codec as codec
from urc.protocols.tartu import TartuSession
from urc.protocols.tartu_codec import Command, TartuSyntaxError
from urc.testing.sessions import fed, ticked

#: 0.1 deg encoders, 0.1 deg position tolerance, 0.1 deg print resolution
TRUTH_TOL_DEG = 0.25
VALUE = re.compile(rb"-?\d{3}\.\d\r\n\Z")


def value(reply: bytes) -> float:
    assert VALUE.match(reply), reply
    return float(reply)


@pytest.fixture
def tartu(bench):
    b = bench("tartu-urc")
    # a fresh encoder rotator estimates the middle of its first count above home
    # (0.05 deg); re-reference so the replies start from round numbers
    b.rot.set_position(0.0, 90.0)
    b.run(0.1)
    return b, TartuSession(b.rot)


def still(b: Bench) -> bool:
    b.run(1.0)
    s = b.rot.status()
    return not s.moving and s.target_az_deg is None and s.az.target_deg is None and s.el.target_deg is None


# ======================================================================== codec
@pytest.mark.parametrize("line, cmd", [
    (b"VERS", Command("VERS", ())),
    (b"vers", Command("VERS", ())),
    (b"  RDAZ  ", Command("RDAZ", ())),
    (b"GOAZ 123.4", Command("GOAZ", (123.4,))),
    (b"GOAZ123.4", Command("GOAZ", (123.4,))),
    (b"GOEL -5", Command("GOEL", (-5.0,))),
    (b"GOAE 123.4,45.0", Command("GOAE", (123.4, 45.0))),
    (b"goae 123.4 , 45", Command("GOAE", (123.4, 45.0))),
    (b"GOAE .5,0.", Command("GOAE", (0.5, 0.0))),
    (b"WRAZ 380", Command("WRAZ", (380.0,))),
    (b"BAUD", Command("BAUD", ())),
    (b"BAUD 9600", Command("BAUD", (9600,))),
    (b"ECHO on", Command("ECHO", (True,))),
    (b"ECHO 0", Command("ECHO", (False,))),
    (b"OVRA", Command("OVRA", ())),
    (b"OVRE 0.5", Command("OVRE", (0.5,))),
    (b"HLTE", Command("HLTE", ())),
    (b"LCDC", Command("LCDC", ())),
    (b"lcdc 40", Command("LCDC", (40,))),
    # the document's syntax: the command and its parameters separated by commas
    (b"GOAZ,10", Command("GOAZ", (10.0,))),
    (b"goae,123.4,45", Command("GOAE", (123.4, 45.0))),
    (b"GOEL , 5", Command("GOEL", (5.0,))),
    (b"LCDC,40", Command("LCDC", (40,))),
])
def test_parse(line, cmd):
    assert codec.parse_line(line) == cmd


@pytest.mark.parametrize("line, code", [
    (b"FOO", codec.E_UNKNOWN), (b"RDAZX", codec.E_UNKNOWN), (b"GO", codec.E_UNKNOWN),
    (b"\xff\xfe\x00", codec.E_UNKNOWN),
    (b"GOAZ", codec.E_SYNTAX), (b"GOAZ nan", codec.E_SYNTAX), (b"GOAZ inf", codec.E_SYNTAX),
    (b"GOAZ 1e3", codec.E_SYNTAX), (b"GOAZ 12,3", codec.E_SYNTAX), (b"GOAE 123.4", codec.E_SYNTAX),
    (b"GOAE 1,2,3", codec.E_SYNTAX), (b"GOAE 1,", codec.E_SYNTAX), (b"GOAZ,", codec.E_SYNTAX),
    (b"GOAZ,,10", codec.E_SYNTAX), (b"GOAE,1,2,3", codec.E_SYNTAX), (b"RDAZ 5", codec.E_SYNTAX),
    (b"BAUD 1234", codec.E_SYNTAX), (b"ECHO maybe", codec.E_SYNTAX), (b"GOAZ " + b"9" * 400, codec.E_SYNTAX),
])
def test_parse_errors(line, code):
    with pytest.raises(TartuSyntaxError) as e:
        codec.parse_line(line)
    assert e.value.code == code
    assert "expected" in str(e.value) or "out of range" in str(e.value)


@pytest.mark.parametrize("v, text", [(123.4, "123.4"), (45, "045.0"), (0, "000.0"), (-0.04, "000.0"),
                                     (-5, "-005.0"), (399.96, "400.0"), (7.25, "007.2")])
def test_format_deg(v, text):
    assert codec.format_deg(v) == text


@given(tenths=st.integers(-3600, 9999))
def test_format_parse_round_trip(tenths):
    text = codec.format_deg(tenths / 10)
    assert re.fullmatch(r"-?\d{3}\.\d", text)
    cmd = codec.parse_line(b"GOAZ " + text.encode())
    assert round(cmd.args[0] * 10) == tenths


def test_error_is_one_line():
    assert codec.error(2, "a\r\nb") == b"ERR 2 a  b\r\n"


# =================================================================== transcripts
def test_vers_help_baud(tartu):
    _, s = tartu
    assert fed(s, b"VERS\r") == [b"URC urc-0.1.0 (Tartu URC command set)\r\n"]
    (help_,) = fed(s, b"HELP\r\n")
    for name in "VERS HELP BAUD ECHO GOAZ GOEL GOAE RDAZ RDEL WRAZ WREL RDAP RDEP OVRA OVRE HALT HLTA HLTE LCDC".split():
        assert re.search(rb"^" + name.encode() + rb"\b", help_, re.M), name
    assert fed(s, b"BAUD\r") == [b"BAUD 115200\r\n"]
    assert fed(s, b"BAUD 9600\r") == [b"OK\r\n"]
    assert fed(s, b"BAUD\r") == [b"BAUD 9600\r\n"]
    assert fed(s, b"BAUD 9601\r")[0].startswith(b"ERR 2 BAUD: expected one of 1200")


def test_reads_at_start(tartu):
    """The Tartu rotator parks at az 0, el 90; the pulse counts are from each axis'
    reference (0 deg), not from the pose the controller was powered up in."""
    _, s = tartu
    assert fed(s, b"RDAZ\rRDEL\r") == [b"000.0\r\n", b"090.0\r\n"]
    assert fed(s, b"RDAP\nRDEP\n") == [b"0\r\n", b"900\r\n"]


def test_rdap_rdep_are_the_pulse_counters(tartu):
    """The document: RDAP/RDEP print the amount of impulses (10 per degree), both
    counted from the axis' reference (RDEP used to count from the power-up pose, el
    90: -100 at el 80, -452 at el 45)."""
    b, s = tartu
    fed(s, b"GOAE 12.3,80\r")
    b.settle()
    az_pulses, el_pulses = (int(r) for r in fed(s, b"RDAP\rRDEP\r"))
    # the counters moved by what the encoders counted since the start (within the half
    # count by which the start estimate sits inside its first count)
    assert abs(el_pulses - 900 - b.rot.hw.el.sensor.counts()) <= 1
    assert abs(az_pulses - b.rot.hw.az.sensor.counts()) <= 1
    assert az_pulses == pytest.approx(123, abs=2) and el_pulses == pytest.approx(800, abs=2)
    fed(s, b"GOEL,45\r")
    b.settle()
    assert int(fed(s, b"RDEP\r")[0]) == pytest.approx(10 * b.truth("el"), abs=2)


def test_lcdc_sets_the_contrast_kept_by_the_controller(tartu):
    b, s = tartu
    assert fed(s, b"LCDC\r") == [b"LCDC 32\r\n"]
    assert fed(s, b"LCDC 40\r") == [b"OK\r\n"]
    assert fed(TartuSession(b.rot), b"LCDC\r") == [b"LCDC 40\r\n"]     # another connection
    assert fed(s, b"LCDC 64\r")[0].startswith(b"ERR 2 LCDC: expected a contrast 0..63")
    assert fed(s, b"LCDC\r") == [b"LCDC 40\r\n"]


def test_baud_change_is_requested_after_the_reply(tartu):
    _, s = tartu
    assert TartuSession.default_baud == 115200                       # the document's setting
    assert fed(s, b"BAUD 9600\r") == [b"OK\r\n"] and s.baud_request == 9600
    s.baud_request = None
    assert fed(s, b"BAUD\r") == [b"BAUD 9600\r\n"] and s.baud_request is None


def test_faults_are_reported_on_the_port_as_they_latch(tartu):
    b, s = tartu
    assert ticked(s, b.clock.now_s()) == []
    b.rot.hw.az.sensor.fault_dead = True
    b.run(0.5)
    (line,) = ticked(s, b.clock.now_s())
    assert line.startswith(b"ERR 5 az fault: ") and line.endswith(b"\r\n")
    assert ticked(s, b.clock.now_s()) == []                                  # once


def test_trc_turntable_knows_only_its_commands(tartu):
    b, s0 = tartu
    s = make_session("urc", b.rot, variant="trc")
    (help_,) = fed(s, b"HELP\r")
    names = [row.split()[0] for row in help_.decode().splitlines()]
    assert sorted(names) == sorted(["VERS", "HELP", "BAUD", "ECHO", "GOAZ", "RDAZ", "WRAZ", "RDAP", "HALT", "OVRA"])
    for cmd in (b"GOEL 10", b"GOAE 1,2", b"RDEL", b"RDEP", b"HLTA", b"LCDC"):
        assert fed(s, cmd + b"\r")[0].startswith(b"ERR 1 unknown command"), cmd
    assert fed(s, b"GOAZ 30\rRDAZ\r") == [b"OK\r\n", b"000.0\r\n"]
    # one motor: HALT is its emergency stop (not "both axes")
    (halt,) = [row for row in help_.decode().splitlines() if row.startswith("HALT")]
    assert "both" not in halt and "emergency stop of the motor" in halt
    (urc_halt,) = [row for row in fed(s0, b"HELP\r")[0].decode().splitlines() if row.startswith("HALT")]
    assert "both axes" in urc_halt
    with pytest.raises(ValueError):
        TartuSession(b.rot, variant="xyz")


def test_same_replies_whole_bytewise_and_chunked(tartu):
    _, s = tartu
    data = b"RDAZ\rRDEL\nRDAP\r\nRDEP\rLCDC\rOVRA\rFOO\rGOAZ x\r"
    whole = b"".join(fed(s, data))
    bytewise = b"".join(r for byte in data for r in fed(s, bytes([byte])))
    chunked = b"".join(r for i in range(0, len(data), 5) for r in fed(s, data[i:i + 5]))
    assert whole == bytewise == chunked
    assert whole.count(b"\r\n") == 8 and whole.count(b"ERR") == 2


def test_echo(tartu):
    _, s = tartu
    assert fed(s, b"ECHO\r") == [b"ECHO OFF\r\n"]
    assert fed(s, b"ECHO ON\r") == [b"OK\r\n"]
    out = []
    for byte in b"RDX\x7fAZ\r":
        out += fed(s, bytes([byte]))
    assert out == [b"R", b"D", b"X", b"\b \b", b"A", b"Z", b"\r\n", b"000.0\r\n"]
    assert fed(s, b"ECHO OFF\r") == [b"ECHO OFF\r\n", b"OK\r\n"]
    assert fed(s, b"RDAZ\r") == [b"000.0\r\n"]
    assert TartuSession(None, echo=True).echo


def test_lcd_rows(tartu):
    b, s = tartu
    rows = s.lcd_rows()
    assert [len(r) for r in rows] == [20, 20]
    assert rows[0].startswith("AZ 000.0") and rows[1].startswith("EL 090.0")
    fed(s, b"GOAE 100,45\r")
    b.run(3.0)
    assert re.fullmatch(r"AZ \d{3}\.\d>100\.0 +RUN", s.lcd_rows()[0]), s.lcd_rows()
    b.settle()
    assert s.lcd_rows() == ["AZ 100.0>100.0   HLD", "EL 045.0>045.0   HLD"]


def test_overshoot_read_and_set(bench):
    """OVRA/OVRE read and set the rotator service's overshoot (coast) estimate."""
    for profile, text in (("tartu-urc", b"000.0"), ("g4jnt", b"000.3")):
        b = bench(profile)
        s = TartuSession(b.rot)
        assert fed(s, b"OVRA\r") == [text + b"\r\n"]
        assert fed(s, b"OVRA 1.5\rOVRE 0.5\r") == [b"OK\r\n", b"OK\r\n"]
        b.run(0.1)                                     # applied on the next control tick
        assert fed(s, b"OVRA\rOVRE\r") == [b"001.5\r\n", b"000.5\r\n"]
        assert b.rot.overshoot_deg("az") == pytest.approx(1.5)
        (err,) = fed(s, b"OVRE 25\r")
        assert err.startswith(b"ERR 9 ") and b"0..20" in err
        b.run(0.1)
        assert fed(s, b"OVRE\r") == [b"000.5\r\n"]




def test_errors_do_not_move(tartu):
    b, s = tartu
    replies = fed(s, b"GOAZ nan\rGOAZ 500\rGOEL 200\rGOAE 1\rFOO 1,2\rGOAZ\r")
    assert [r[:5] for r in replies] == [b"ERR 2", b"ERR 3", b"ERR 3", b"ERR 2", b"ERR 1", b"ERR 2"]
    assert b"400" in replies[1]                       # says what the limits are
    assert all(r.endswith(b"\r\n") and r.count(b"\r\n") == 1 for r in replies)
    assert still(b)


def test_overflow(tartu):
    b, s = tartu
    replies = fed(s, b"G" * (MAX_PENDING_BYTES + 10))
    assert len(replies) == 1 and replies[0].startswith(b"ERR 8 ")
    assert fed(s, b"OAZ 100" * 100) == []           # still the same dropped line
    assert fed(s, b"\rRDAZ\r") == [b"000.0\r\n"]
    assert still(b)


def test_wraz_wrel_re_reference_without_motion(tartu):
    b, s = tartu
    assert fed(s, b"WRAZ 200.0\rWREL 30\r") == [b"OK\r\n", b"OK\r\n"]
    b.run(0.2)
    assert fed(s, b"RDAZ\rRDEL\r") == [b"200.0\r\n", b"030.0\r\n"]
    assert b.truth("az") == pytest.approx(0.0, abs=0.05)           # nothing moved
    assert fed(s, b"WRAZ 450\r")[0].startswith(b"ERR 3")
    assert still(b)


# =================================================================== end to end
def test_goae_then_read_matches_truth(tartu):
    b, s = tartu
    assert fed(s, b"GOAE 123.4,45.0\r") == [b"OK\r\n"]
    b.settle()
    az, el = (value(r) for r in fed(s, b"RDAZ\rRDEL\r"))
    assert az == pytest.approx(b.truth("az"), abs=TRUTH_TOL_DEG)
    assert el == pytest.approx(b.truth("el"), abs=TRUTH_TOL_DEG)
    assert (az, el) == pytest.approx((123.4, 45.0), abs=0.15)
    assert abs(int(fed(s, b"RDAP\r")[0]) - b.rot.hw.az.sensor.counts()) <= 1


def test_the_documents_comma_form_moves(tartu):
    b, s = tartu
    assert fed(s, b"GOAZ,10\rGOEL,60\r") == [b"OK\r\n", b"OK\r\n"]
    b.settle()
    assert (b.truth("az"), b.truth("el")) == pytest.approx((10.0, 60.0), abs=TRUTH_TOL_DEG)


def test_goaz_and_goel_in_one_chunk_both_happen(tartu):
    b, s = tartu
    assert fed(s, b"GOAZ 100\rGOEL 20\r") == [b"OK\r\n", b"OK\r\n"]
    b.settle()
    assert b.truth("az") == pytest.approx(100.0, abs=TRUTH_TOL_DEG)
    assert b.truth("el") == pytest.approx(20.0, abs=TRUTH_TOL_DEG)


def test_wrap_and_flip_in_the_controller_frame(tartu):
    """380 is the overlap of the 400 deg azimuth; 120 elevation is over the top."""
    b, s = tartu
    fed(s, b"GOAE 380,120\r")
    b.settle()
    assert [value(r) for r in fed(s, b"RDAZ\rRDEL\r")] == pytest.approx([380.0, 120.0], abs=0.15)
    assert (b.truth("az"), b.truth("el")) == pytest.approx((380.0, 120.0), abs=TRUTH_TOL_DEG)
    fed(s, b"GOEL 60\r")                            # azimuth stays in the overlap
    b.settle()
    assert b.truth("az") == pytest.approx(380.0, abs=TRUTH_TOL_DEG)
    assert value(fed(s, b"RDEL\r")[0]) == pytest.approx(60.0, abs=0.15)


def test_halt_then_goaz_keeps_elevation_where_it_stopped(tartu):
    b, s = tartu
    fed(s, b"GOAE 200,10\r")
    b.run(4.0)
    assert fed(s, b"HALT\r") == [b"OK\r\n"]
    b.settle()
    el_stop = b.truth("el")
    assert el_stop > 40                                # stopped on the way down from 90
    fed(s, b"GOAZ 50\r")
    b.settle()
    assert b.truth("el") == pytest.approx(el_stop, abs=0.5)
    assert b.truth("az") == pytest.approx(50.0, abs=TRUTH_TOL_DEG)


def test_hlte_stops_only_elevation(tartu):
    b, s = tartu
    fed(s, b"GOAE 60,10\r")
    b.run(3.0)
    assert fed(s, b"HLTE\r") == [b"OK\r\n"]
    b.settle()
    assert b.truth("az") == pytest.approx(60.0, abs=TRUTH_TOL_DEG)
    assert b.truth("el") > 40
    (rdel,) = fed(s, b"RDEL\r")
    assert float(rdel) == pytest.approx(b.truth("el"), abs=TRUTH_TOL_DEG)


def test_hlta_mid_move(tartu):
    b, s = tartu
    fed(s, b"GOAZ 300\r")
    b.run(3.0)
    fed(s, b"HLTA\r")
    b.settle()
    assert 5.0 < b.truth("az") < 100.0


def test_registry_name(tartu):
    b, _ = tartu
    assert isinstance(make_session("urc", b.rot), TartuSession)


# ======================================================================== fuzz
@pytest.fixture(scope="module")
def quiet(tmp_path_factory):
    return Bench("tartu-urc", tmp_path_factory.mktemp("tartu-fuzz"))


_WORDS = st.sampled_from([b"GOAZ", b"GOAE", b"WRAZ", b"RDAZ", b"LCDC", b"nan", b"1e9", b",", b" ",
                          b"\r", b"\n", b"\x7f", b"\x00", b"-", b"."])
_DATA = st.lists(st.one_of(st.binary(max_size=20), _WORDS), max_size=20).map(b"".join)


@settings(max_examples=150, deadline=None)
@given(data=_DATA, split=st.integers(1, 9))
@raises_nothing
def test_fuzz_never_raises_or_moves(quiet, data, split):
    # a well-formed motion command could legitimately move: keep those out
    assume(not re.search(rb"(?i)(GO(AZ|EL|AE)|WR(AZ|EL))\s*[+-]?[\d.]", data))
    s = TartuSession(quiet.rot)
    replies = []
    for i in range(0, len(data), split):
        replies += fed(s, data[i:i + split])
    assert all(r.endswith(b"\r\n") for r in replies)
    assert len(replies) <= data.count(b"\r") + data.count(b"\n") + 1
    assert still(quiet)
