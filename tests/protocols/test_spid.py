"""SPID Rot2Prog / Rot1Prog / MD-01/02 sessions (protocols.md §4).

Hamlib 4.5.4/4.6.5 byte captures as transcripts, resynchronisation, fuzzing, and
end-to-end runs on the simulator (bigras: the BIG-RAS is a SPID rotator, 0..450 az,
0..90 el, 0.5 deg pulse feedback) judged by its truth. The frames' own tests (encoding,
decoding, cutting frames from a stream) are in tests/wire/test_spid.py.
"""

from __future__ import annotations

import logging

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from conftest import Bench
from session_replay import raises_nothing
from urc.protocols import make_session
from urc.wire import spid as codec
from urc.protocols.spid import Md01Session, Rot1ProgSession, Rot2ProgSession
from urc.testing.sessions import fed

STATUS = codec.encode_query(codec.K_STATUS)
STOP = codec.encode_query(codec.K_STOP)
#: reported angle vs the simulator's truth: the BIG-RAS pulse counter has 0.5 deg steps
#: and miscounts a little on reversals; the position controller stops within 0.5 deg.
TRUTH_TOL_DEG = 1.2


def h(text: str) -> bytes:
    return bytes.fromhex(text)


def place(b: Bench, az: float, el: float) -> None:
    """Drive there, then re-reference to exactly (az, el) so replies are exact."""
    b.rot.goto(az, el)
    b.settle()
    b.rot.set_position(az, el)
    b.run(0.1)


def still(b: Bench) -> bool:
    b.run(1.0)
    s = b.rot.status()
    return not s.moving and s.az.target_deg is None and s.el.target_deg is None \
        and s.target_az_deg is None


@pytest.fixture
def big(bench):
    return bench("bigras")


# ================================================================ transcripts
def test_hamlib_901_transcript(big):
    """protocols.md 4.2: Hamlib `P 100 20` then `p` then `S` against a Rot2Prog."""
    place(big, 123.4, 45.6)
    s = Rot2ProgSession(big.rot)
    assert fed(s, h("57 00 00 00 00 00 00 00 00 00 00 1f 20")) == \
        [h("57 04 08 03 04 02 04 00 05 06 02 20")]                   # 123.4 / 45.6, PH = PV = 2
    assert fed(s, h("57 30 39 32 30 02 30 37 36 30 02 2f 20")) == []   # set: no answer
    big.settle()
    (reply,) = fed(s, STATUS)
    az, el, ph, pv = codec.decode_rot2_position(reply)
    assert (ph, pv) == (2, 2)
    assert az == pytest.approx(big.truth("az"), abs=TRUTH_TOL_DEG)
    assert el == pytest.approx(big.truth("el"), abs=TRUTH_TOL_DEG)
    assert az == pytest.approx(100.0, abs=0.6) and el == pytest.approx(20.0, abs=0.6)
    (reply,) = fed(s, h("57 00 00 00 00 00 00 00 00 00 00 0f 20"))     # S
    assert len(reply) == 12


def test_hamlib_903_set_gets_a_position_answer(big):
    place(big, 10.0, 5.0)
    s = Md01Session(big.rot)
    assert fed(s, STATUS) == [codec.encode_rot2_position(10.0, 5.0, 2, 2)]
    (reply,) = fed(s, h("57 30 39 32 30 02 30 37 36 30 02 2f 20"))
    assert codec.decode_rot2_position(reply)[:2] == pytest.approx((10.0, 5.0))  # where it is now
    big.settle()
    az, el, _, _ = codec.decode_rot2_position(fed(s, STATUS)[0])
    assert (az, el) == pytest.approx((100.0, 20.0), abs=0.6)


def test_hamlib_903_move_frames(big):
    """4.4: stop frame, then the move frame (junk in bytes 5 and 10), no answer."""
    place(big, 100.0, 20.0)
    s = Md01Session(big.rot)
    assert len(fed(s, STOP)[0]) == 12
    assert fed(s, h("57 04 00 00 00 7f 00 00 00 00 4c 14 20")) == []      # M 2 = UP
    big.run(2.0)
    assert big.rot.status().el.pos_deg > 21.0
    assert big.rot.status().az.pos_deg == pytest.approx(100.0, abs=0.6)
    fed(s, STOP)
    big.settle()
    assert fed(s, h("57 06 00 00 00 7f 00 00 00 00 99 14 20")) == []      # UP_RIGHT (4.6)
    big.run(2.0)
    st_ = big.rot.status()
    assert st_.az.rate_deg_per_s > 0.5 and st_.el.rate_deg_per_s > 0.5
    fed(s, STOP)
    big.settle()
    assert not big.rot.status().moving


def test_hamlib_902_transcript(big):
    place(big, 100.0, 30.0)
    s = Rot1ProgSession(big.rot)
    assert fed(s, STATUS) == [h("57 04 06 00 20")]                       # 100 deg
    assert fed(s, h("57 34 35 30 30 00 00 00 00 00 00 2f 20")) == []     # set(90)
    big.settle()
    assert codec.decode_rot1_position(fed(s, STATUS)[0]) == pytest.approx(big.truth("az"), abs=TRUTH_TOL_DEG)
    assert big.rot.status().el.pos_deg == pytest.approx(30.0, abs=0.01)       # elevation untouched


# ===================================================================== session
def test_status_byte_at_a_time(big):
    s = Rot2ProgSession(big.rot)
    for byte in STATUS[:-1]:
        assert fed(s, bytes([byte])) == []
    assert len(fed(s, STATUS[-1:])[0]) == 12


def test_several_frames_in_one_chunk_with_trailing_half(big):
    s = Rot2ProgSession(big.rot)
    replies = fed(s, STATUS + STATUS + STOP + STATUS[:7])
    assert len(replies) == 3 and all(len(r) == 12 for r in replies)
    assert len(fed(s, STATUS[7:])) == 1


@pytest.mark.parametrize("cut", [1, 6, 12])
def test_half_set_frame_never_moves(big, cut):
    s = Rot2ProgSession(big.rot)
    assert fed(s, codec.encode_rot2_set(200, 40, 2, 2)[:cut]) == []
    assert still(big)
    # and a new frame after it is read correctly; the half frame is not
    assert len(fed(s, STATUS)) == 1
    assert still(big)


def test_half_set_then_full_set_goes_to_the_full_one(big):
    s = Rot2ProgSession(big.rot)
    fed(s, codec.encode_rot2_set(300, 80, 2, 2)[:9])
    fed(s, codec.encode_rot2_set(50, 10, 2, 2))
    big.settle()
    az, el, _, _ = codec.decode_rot2_position(fed(s, STATUS)[0])
    assert (az, el) == pytest.approx((50.0, 10.0), abs=0.6)


def test_resolution_option(big):
    place(big, 12.5, 34.0)
    s = Rot2ProgSession(big.rot, resolution_deg=1)
    assert fed(s, STATUS) == [codec.encode_rot2_position(12.5, 34.0, 1, 1)]
    # a set frame with PH = PV = 0 is decoded with this resolution (H = 360 + az)
    frame = bytearray(codec.encode_rot2_set(40, 20, 1, 1))
    frame[5] = frame[10] = 0
    fed(s, bytes(frame))
    big.settle()
    assert big.rot.status().target_az_deg == pytest.approx(40.0)
    assert Rot1ProgSession(big.rot).pulses == 1 and Md01Session(big.rot).pulses == 2
    with pytest.raises(ValueError):
        Rot2ProgSession(big.rot, resolution_deg=0.3)


def test_overturn_reported_and_commanded(big):
    """Azimuth 400 on a 0..450 rotator is the overlap: set and reported as 400."""
    s = Rot2ProgSession(big.rot)
    fed(s, codec.encode_rot2_set(400, 10, 2, 2))
    big.settle()
    az, _, _, _ = codec.decode_rot2_position(fed(s, STATUS)[0])
    assert az == pytest.approx(400.0, abs=0.6)
    assert big.truth("az") == pytest.approx(400.0, abs=TRUTH_TOL_DEG)


def test_negative_azimuth_goes_the_same_direction(big):
    """-10 (Hamlib's -180..540) on a 0..450 rotator: the same direction, 350."""
    s = Rot2ProgSession(big.rot)
    fed(s, codec.encode_rot2_set(-10, 10, 2, 2))
    big.settle()
    az, _, _, _ = codec.decode_rot2_position(fed(s, STATUS)[0])
    assert az == pytest.approx(350.0, abs=0.6)


def test_refused_set_is_logged_and_silent(big, caplog):
    s = Rot2ProgSession(big.rot)
    with caplog.at_level(logging.WARNING, logger="urc.protocols.spid"):
        assert fed(s, codec.encode_rot2_set(100, 150, 2, 2)) == []     # el 150 > 90
    assert "refused" in caplog.text
    assert still(big)


def test_rot2_ignores_md01_move(big):
    s = Rot2ProgSession(big.rot)
    assert fed(s, codec.encode_move(codec.DIR_UP)) == []
    assert still(big)


@pytest.mark.parametrize("direction", [0x00, 0x03, 0x0C, 0x10, 0xFF])
def test_md01_bad_move_directions_do_nothing(big, direction):
    s = Md01Session(big.rot)
    assert fed(s, codec.encode_move(direction)) == []
    assert still(big)


def test_stop_halts_a_move(big):
    s = Rot2ProgSession(big.rot)
    fed(s, codec.encode_rot2_set(300, 60, 2, 2))
    big.run(3.0)
    assert big.rot.status().moving
    (reply,) = fed(s, STOP)
    big.settle()
    az, el, _, _ = codec.decode_rot2_position(fed(s, STATUS)[0])
    assert az < 100 and el < 50                    # stopped well short of the target
    assert az == pytest.approx(big.truth("az"), abs=TRUTH_TOL_DEG)


def test_registry_names(big):
    for name, cls in (("rot2prog", Rot2ProgSession), ("rot1prog", Rot1ProgSession), ("md01", Md01Session)):
        assert isinstance(make_session(name, big.rot), cls)
    assert make_session("rot2prog", big.rot, resolution_deg=0.25).pulses == 4


# ======================================================================== fuzz
@pytest.fixture(scope="module")
def quiet(tmp_path_factory):
    return Bench("bigras", tmp_path_factory.mktemp("spid-fuzz"))


_PIECES = st.one_of(
    st.binary(max_size=40),
    st.binary(min_size=1, max_size=12).map(lambda b: b"W" + b),
    st.builds(lambda az, el, n: codec.encode_rot2_set(az, el, 2, 2)[:n],
              st.integers(0, 450), st.integers(0, 90), st.integers(1, 12)),
    st.just(STATUS), st.just(STOP),
)


@settings(max_examples=150, deadline=None)
@given(pieces=st.lists(_PIECES, max_size=8), cls=st.sampled_from([Rot2ProgSession, Rot1ProgSession, Md01Session]),
       split=st.integers(1, 13))
@raises_nothing
def test_fuzz_never_raises_or_moves(quiet, pieces, cls, split):
    data = b"".join(pieces)
    # no whole set or move frame can be in it (both end K 0x20 with K = 0x2F / 0x14)
    assume(b"\x2f\x20" not in data and b"\x14\x20" not in data)
    s = cls(quiet.rot)
    replies = []
    for i in range(0, len(data), split):
        replies += fed(s, data[i:i + split])
    size = 5 if cls is Rot1ProgSession else 12
    assert all(len(r) == size and r[0] == 0x57 and r[-1] == 0x20 for r in replies)
    assert len(replies) <= len(data) // 13
    assert len(s._buf) < 13
    assert still(quiet)


@pytest.mark.parametrize("cls", [Rot1ProgSession, Rot2ProgSession, Md01Session])
@pytest.mark.parametrize("az", [639, 500, -360, -181])
def test_azimuth_outside_the_range_is_refused_not_folded(big, cls, az):
    """Issue 21: Rot1Prog folded Hamlib's 639 to 279 and -360 to 0. Outside the
    BIG-RAS's 0..450 (and below the -180 compass bearings) nothing moves."""
    s = cls(big.rot)
    frame = codec.encode_rot1_set(az) if cls is Rot1ProgSession else codec.encode_rot2_set(az, 10, 2, 2)
    fed(s, frame)
    assert still(big)
    assert big.rot.status().target_az_deg is None
