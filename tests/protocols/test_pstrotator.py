"""PstRotator UDP protocol (protocols.md §5.2): datagram in, reply datagrams out.

Hamlib 4.6.5's model 3 datagrams as transcripts, parser tests, fuzzing, and end-to-end
runs on the simulator (bigras: the BIG-RAS controller emulates PstRotator).
"""

from __future__ import annotations

import logging
import re

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from conftest import Bench
from session_replay import raises_nothing
from urc.protocols import MAX_PENDING_BYTES, make_session
from urc.protocols import pstrotator_codec as codec
from urc.protocols.pstrotator import PstRotatorSession
from urc.protocols.pstrotator_codec import PstItem
from urc.testing.sessions import fed

TRUTH_TOL_DEG = 1.2          # BIG-RAS pulse feedback, 0.5 deg steps and tolerance
REPLY = re.compile(rb"(AZ|EL|TGA|TGE):(-?\d+\.\d)\r\Z")


def hamlib_parse(reply: bytes) -> tuple[str, float]:
    """What Hamlib's listener does: cut at the first CR/LF, then sscanf AZ:%g / EL:%g."""
    text = re.split(rb"[\r\n]", reply)[0].decode()
    m = re.fullmatch(r"(AZ|EL):([-+0-9.eE]+)", text)
    assert m, reply
    return m.group(1), float(m.group(2))


def still(b: Bench) -> bool:
    b.run(1.0)
    s = b.rot.status()
    return not s.moving and s.target_az_deg is None and s.az.target_deg is None and s.el.target_deg is None


@pytest.fixture
def pst(bench):
    b = bench("bigras")
    # a fresh pulse-counting rotator estimates the middle of its first count above home
    # (0.25 deg); re-reference so the replies start from round numbers
    b.rot.set_position(0.0, 0.0)
    b.run(0.1)
    return b, PstRotatorSession(b.rot)


# ======================================================================== codec
def test_parse_hamlib_datagrams():
    assert codec.parse_datagram(b"<PST><AZIMUTH>100.000000.2</AZIMUTH></PST>") == \
        [PstItem("set", "AZIMUTH", "100.000000.2")]
    assert codec.parse_datagram(b"<PST>AZ?</PST>") == [PstItem("query", "AZ")]
    assert codec.parse_datagram(b"<pst><Park>1</park></PST>") == [PstItem("set", "PARK", "1")]


def test_parse_batched_and_garbage():
    items = codec.parse_datagram(b"junk<PST><AZIMUTH>1</AZIMUTH> EL? <XX>2</YY>AZ?</PST>tail")
    assert [(i.kind, i.name) for i in items] == [("garbage", ""), ("set", "AZIMUTH"), ("query", "EL"),
                                                  ("garbage", ""), ("query", "AZ"), ("garbage", "")]
    assert [i.raw for i in items if i.kind == "garbage"] == [b"junk", b"<XX>2</YY>", b"tail"]
    assert codec.parse_datagram(b"") == [] and codec.parse_datagram(b"<PST>") == [PstItem("garbage", raw=b"<PST>")]


@pytest.mark.parametrize("text, v", [("100.000000.2", 100.0), ("20.000000.2", 20.0), ("-5.5", -5.5),
                                     (" 7 ", 7.0), (".5", 0.5), ("12.", 12.0)])
def test_lenient_numbers(text, v):
    assert codec.parse_number(text) == v


@pytest.mark.parametrize("text", ["", "nan", "inf", "1e3", "12abc", "--1", "1.2.x", "9" * 400])
def test_bad_numbers(text):
    with pytest.raises(ValueError):
        codec.parse_number(text)


@given(az=st.floats(-180.0, 540.0), el=st.floats(-10.0, 180.0))
def test_hamlib_format_round_trip(az, el):
    """Hamlib 4.6 writes %f.2: the value survives to the microdegree."""
    for name, v in (("AZIMUTH", az), ("ELEVATION", el)):
        (item,) = codec.parse_datagram(codec.format_set(name, f"{v:f}.2"))
        assert codec.parse_number(item.value) == pytest.approx(v, abs=1e-6)


def test_reply_format():
    assert codec.format_reply("AZ", 123.44) == b"AZ:123.4\r"
    assert hamlib_parse(codec.format_reply("EL", 45.6)) == ("EL", 45.6)


# =================================================================== transcripts
def test_hamlib_set_then_get_position(pst):
    """rotctl -m 3: P 100 20 (two datagrams, no tick between them), then p."""
    b, s = pst
    assert fed(s, b"<PST><AZIMUTH>100.000000.2</AZIMUTH></PST>") == []
    assert fed(s, b"<PST><ELEVATION>20.000000.2</ELEVATION></PST>") == []
    b.settle()
    (az_reply,) = fed(s, b"<PST>AZ?</PST>")
    (el_reply,) = fed(s, b"<PST>EL?</PST>")
    assert REPLY.match(az_reply) and REPLY.match(el_reply)
    (_, az), (_, el) = hamlib_parse(az_reply), hamlib_parse(el_reply)
    assert az == pytest.approx(b.truth("az"), abs=TRUTH_TOL_DEG)
    assert el == pytest.approx(b.truth("el"), abs=TRUTH_TOL_DEG)
    assert (az, el) == pytest.approx((100.0, 20.0), abs=0.6)


def test_position_is_current_while_moving(pst):
    b, s = pst
    fed(s, b"<PST><AZIMUTH>200</AZIMUTH><ELEVATION>60</ELEVATION></PST>")
    b.run(5.0)
    (_, az), (_, el) = (hamlib_parse(r) for r in fed(s, b"<PST>AZ?EL?</PST>"))
    assert 5.0 < az < 195.0 and 5.0 < el < 58.0
    assert az == pytest.approx(b.rot.status().az_deg, abs=0.06)


def test_targets_and_batched_queries(pst):
    b, s = pst
    assert fed(s, b"<PST>TGA?TGE?</PST>") == [b"TGA:0.0\r", b"TGE:0.0\r"]   # none: the position
    fed(s, b"<PST><AZIMUTH>45.5</AZIMUTH><ELEVATION>30</ELEVATION></PST>")
    b.run(0.1)
    assert fed(s, b"<PST>TGA?</PST><PST>TGE?</PST>") == [b"TGA:45.5\r", b"TGE:30.0\r"]


def test_stop_and_park(pst):
    b, s = pst
    fed(s, b"<PST><AZIMUTH>300</AZIMUTH><ELEVATION>80</ELEVATION></PST>")
    b.run(4.0)
    assert fed(s, b"<PST><STOP>1</STOP></PST>") == []
    b.settle()
    az_stop = b.truth("az")
    assert 5.0 < az_stop < 60.0
    fed(s, b"<PST><ELEVATION>10</ELEVATION></PST>")      # azimuth stays where it stopped
    b.settle()
    assert b.truth("az") == pytest.approx(az_stop, abs=TRUTH_TOL_DEG)
    fed(s, b"<PST><PARK>1</PARK></PST>")
    b.settle()
    st_ = b.rot.status()
    assert st_.parked and (st_.target_az_deg, st_.target_el_deg) == (0.0, 0.0)
    # park (0, 0) sits on the soft limits: the service's guard may stop a little short
    assert (b.truth("az"), b.truth("el")) == pytest.approx((0.0, 0.0), abs=3.0)


def test_track_is_accepted(pst):
    b, s = pst
    assert fed(s, b"<PST><TRACK>1</TRACK></PST>") == []
    assert fed(s, b"<PST><TRACK>0</TRACK></PST>") == []
    assert still(b)


def test_garbage_is_logged_and_ignored(pst, caplog):
    b, s = pst
    with caplog.at_level(logging.WARNING, logger="urc.protocols.pstrotator"):
        for dgram in (b"hello", b"<PST><AZIMUTH>nan</AZIMUTH></PST>", b"<PST><AZIMUTH>1e9</AZIMUTH></PST>",
                      b"<PST><AZIMUTH>12abc</AZIMUTH></PST>", b"<PST><PARK>2</PARK></PST>",
                      b"<PST><FOO>1</FOO>BAR?</PST>", b"<PST><AZIMUTH>100", b"\xff" * 10,
                      b"<PST><ELEVATION>500</ELEVATION></PST>", b"<PST>" + b"x" * MAX_PENDING_BYTES + b"</PST>"):
            assert fed(s, dgram) == []
    # one line per kind of bad input (repeats of a kind within 5 s are only counted)
    assert caplog.text.count("WARNING") >= 7
    assert still(b)


def test_good_items_run_despite_a_bad_one(pst):
    b, s = pst
    replies = fed(s, b"<PST><AZIMUTH>x</AZIMUTH>??<ELEVATION>15</ELEVATION>EL?</PST>")
    assert len(replies) == 1 and replies[0].startswith(b"EL:")
    b.settle()
    assert b.truth("el") == pytest.approx(15.0, abs=TRUTH_TOL_DEG)
    assert b.truth("az") == pytest.approx(0.0, abs=TRUTH_TOL_DEG)


def test_registry_name(pst):
    b, _ = pst
    assert isinstance(make_session("pstrotator", b.rot), PstRotatorSession)


# ======================================================================== fuzz
@pytest.fixture(scope="module")
def quiet(tmp_path_factory):
    return Bench("bigras", tmp_path_factory.mktemp("pst-fuzz"))


_WORDS = st.sampled_from([b"<PST>", b"</PST>", b"<AZIMUTH>", b"</AZIMUTH>", b"<ELEVATION>", b"AZ?",
                          b"EL?", b"<STOP>1</STOP>", b"nan", b"1", b".", b"<", b">", b"/"])
_DATA = st.lists(st.one_of(st.binary(max_size=20), _WORDS), max_size=20).map(b"".join)


@settings(max_examples=150, deadline=None)
@given(data=_DATA)
@raises_nothing
def test_fuzz_never_raises_or_moves(quiet, data):
    # a well-formed set or park could legitimately move: keep those out
    assume(not re.search(rb"(?i)<(AZIMUTH|ELEVATION)>\s*[+-]?[\d.]|<PARK>\s*1", data))
    s = PstRotatorSession(quiet.rot)
    replies = fed(s, data)
    assert all(REPLY.match(r) for r in replies)
    assert len(replies) <= data.count(b"?")
    assert still(quiet)
