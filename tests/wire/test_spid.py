"""SPID Rot1Prog / Rot2Prog / MD-01/02 frames (protocols.md §4): encoding and decoding
both ways, Hamlib's frames, and cutting frames out of a byte stream."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from urc.wire import spid as codec

STATUS = codec.encode_query(codec.K_STATUS)
STOP = codec.encode_query(codec.K_STOP)


def h(text: str) -> bytes:
    return bytes.fromhex(text)


def test_resolution_to_pulses():
    assert [codec.resolution_to_pulses(r) for r in (1, 0.5, 0.25, 0.1)] == [1, 2, 4, 10]
    for bad in (0, -1, 0.3, 2.0, float("nan")):
        with pytest.raises(ValueError):
            codec.resolution_to_pulses(bad)


def test_reply_encoding_matches_spid_txt_example():
    # spid.txt: 57 03 07 02 05 02 03 09 04 00 02 20 = az 12.5, el 34.0, PH = PV = 2
    frame = h("57 03 07 02 05 02 03 09 04 00 02 20")
    assert codec.encode_rot2_position(12.5, 34.0, 2, 2) == frame
    assert codec.decode_rot2_position(frame) == pytest.approx((12.5, 34.0, 2, 2))


@pytest.mark.parametrize("az, el, ph, frame", [
    (100, 20, 2, "57 30 39 32 30 02 30 37 36 30 02 2f 20"),        # capture 4.2
    (123.5, -10.25, 2, "57 30 39 36 37 02 30 36 39 39 02 2f 20"),  # "0967", "0699" (truncated)
])
def test_rot2_set_frames_as_hamlib_sends(az, el, ph, frame):
    assert codec.encode_rot2_set(az, el, ph, ph) == h(frame)
    cmd = codec.decode_command(h(frame), "rot2", (2, 2))
    assert cmd.kind == "set"
    assert cmd.az_deg == pytest.approx(az, abs=1 / ph)
    assert cmd.el_deg == pytest.approx(el, abs=1 / ph)


@pytest.mark.parametrize("az, frame, decoded", [
    (100, "57 34 36 30 30 00 00 00 00 00 00 2f 20", 100.0),
    (-10.6, "57 33 34 39 30 00 00 00 00 00 00 2f 20", -11.0),       # 349.4 truncated
])
def test_rot1_set_frames_as_hamlib_sends(az, frame, decoded):
    assert codec.encode_rot1_set(az) == h(frame)
    cmd = codec.decode_command(h(frame), "rot1", (1, 1))
    assert (cmd.kind, cmd.az_deg, cmd.el_deg) == ("set", decoded, None)


def test_rot1_reply_example():
    assert codec.encode_rot1_position(100.0) == h("57 04 06 00 20")
    assert codec.decode_rot1_position(h("57 04 06 00 20")) == 100.0


@given(az=st.integers(-1800, 5400), el=st.integers(-200, 2100), ph=st.sampled_from([1, 2, 4]))
def test_set_round_trip(az, el, ph):
    az_deg, el_deg = az / 10, el / 10
    cmd = codec.decode_command(codec.encode_rot2_set(az_deg, el_deg, ph, ph), "rot2", (ph, ph))
    # the set frame truncates to 1/ph degree, never more
    assert az_deg - 1 / ph - 1e-9 <= cmd.az_deg <= az_deg + 1e-9
    assert el_deg - 1 / ph - 1e-9 <= cmd.el_deg <= el_deg + 1e-9


@given(az=st.integers(-1800, 5400), el=st.integers(-200, 2100))
def test_position_round_trip_in_tenths(az, el):
    """The azimuth offset of 360 makes -180..540 representable, in tenths."""
    frame = codec.encode_rot2_position(az / 10, el / 10, 2, 2)
    assert len(frame) == 12 and frame[0] == 0x57 and frame[-1] == 0x20
    assert all(d <= 9 for d in frame[1:5] + frame[6:10])          # raw digits, not ASCII
    got_az, got_el, _, _ = codec.decode_rot2_position(frame)
    assert round(got_az * 10) == az and round(got_el * 10) == el


@given(az=st.integers(-180, 540))
def test_rot1_position_round_trip(az):
    assert codec.decode_rot1_position(codec.encode_rot1_position(az)) == az


def test_position_reply_clamps_out_of_range():
    assert codec.decode_rot2_position(codec.encode_rot2_position(-400, 700, 1, 1))[:2] == \
        pytest.approx((-360.0, 639.9))


def test_bad_set_digits_are_not_a_command():
    frame = bytearray(codec.encode_rot2_set(100, 20, 2, 2))
    frame[3] = 0x00                       # a raw, not ASCII, digit
    with pytest.raises(codec.SpidFrameError):
        codec.decode_command(bytes(frame), "rot2", (2, 2))
    assert not codec.plausible(bytes(frame), "rot2")
    move = codec.encode_move(codec.DIR_UP)
    assert codec.plausible(move, "md01") and not codec.plausible(move, "rot2")
    assert not codec.plausible(STATUS[:11] + b"\x6f\x20", "rot2")    # Onsala's K = 0x6F


# ====================================================================== framing
def _plausible(f):
    return codec.plausible(f, "md01")


def test_split_whole_byte_at_a_time_and_trailing():
    set_frame = codec.encode_rot2_set(100, 20, 2, 2)
    stream = STATUS + set_frame + STOP
    assert codec.split_frames(stream, _plausible) == ([STATUS, set_frame, STOP], b"", 0)
    frames, rest = [], b""
    for byte in stream:
        got, rest, dropped = codec.split_frames(rest + bytes([byte]), _plausible)
        assert dropped == 0
        frames += got
    assert frames == [STATUS, set_frame, STOP] and rest == b""
    got, rest, _ = codec.split_frames(STATUS + set_frame[:5], _plausible)
    assert got == [STATUS] and rest == set_frame[:5]


@pytest.mark.parametrize("cut", range(1, 13))
def test_half_frame_followed_by_a_new_one(cut):
    half = codec.encode_rot2_set(123.5, 10, 2, 2)[:cut]
    full = codec.encode_rot2_set(100, 20, 2, 2)
    frames, rest, dropped = codec.split_frames(half + full, _plausible)
    assert frames == [full] and rest == b"" and dropped == cut


def test_garbage_before_and_between_frames():
    frames, rest, dropped = codec.split_frames(b"\r\nxx" + STATUS + b"\x00W\x20" + STOP + b"\x01", _plausible)
    assert frames == [STATUS, STOP] and rest == b"" and dropped == 4 + 3 + 1
