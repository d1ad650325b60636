"""GS-232A / GS-232B / generic GS-232 / FoxDelta ST2 sessions (protocols.md 3, 5.3, 6).

Hamlib's byte captures as transcripts, and end-to-end runs on the simulator (g5500:
0..450 az, 0..180 el) judged by the simulator's truth. The codec's own tests are in
tests/wire/test_gs232.py.
"""

from __future__ import annotations


import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from conftest import Bench
from gs232_hamlib import hamlib_read
from session_replay import at, replay_splits, raises_nothing
from urc.protocols import MAX_PENDING_BYTES, Session, make_session
from urc.protocols.gs232 import (FoxDeltaSession, Gs232aSession, Gs232bSession,
                                 Gs232GenericSession, controller_pose)
from urc.wire.gs232 import (STYLE_A, STYLE_B, STYLE_GENERIC, Gs232ParseError,
                            format_error, format_goto, format_help, format_position,
                            parse_command, parse_position_reply)
from urc.protocols.lines import LineSplitter
from urc.testing.sessions import fed, ticked

SESSIONS = [Gs232aSession, Gs232bSession, Gs232GenericSession, FoxDeltaSession]
STYLE = {Gs232aSession: STYLE_A, Gs232bSession: STYLE_B, Gs232GenericSession: STYLE_GENERIC,
         FoxDeltaSession: STYLE_GENERIC}
#: reported whole degrees vs the simulator's truth: rounding (0.5) plus the G-5500 pot's
#: quantisation, noise and the position controller's tolerance
AZ_TOL_DEG, EL_TOL_DEG = 1.6, 1.0


def c2(session, style: str) -> tuple[float, float]:
    replies = fed(session, b"C2\r")
    assert len(replies) == 1
    return parse_position_reply(style, hamlib_read(style, replies[0]))


# ================================================================ session basics
@pytest.fixture
def g5500(bench):
    return bench("g5500")


@pytest.fixture
def tartu(bench):
    """Exact encoders (0.1 deg, no noise): positions read back exactly."""
    return bench("tartu-urc")


@pytest.mark.parametrize("name, cls", [("gs232a", Gs232aSession), ("gs232b", Gs232bSession),
                                       ("gs232", Gs232GenericSession), ("foxdelta", FoxDeltaSession)])
def test_registry_names(g5500, name, cls):
    s = make_session(name, g5500.rot)
    assert type(s) is cls and isinstance(s, Session)
    assert s.closed is False and ticked(s, 0.0) == []


def test_601_capture_transcript(tartu):
    """protocols.md 3.2, Hamlib 601 against a GS-232A: replies byte for byte."""
    s = Gs232aSession(tartu.rot)
    at(tartu, 100, 20)
    assert fed(s, b"W100 020\r") == [b"\r"]
    assert fed(s, b"C2\r") == [b"+0100+0020\r\n"]
    at(tartu, 350, 6)
    for cmd in (b"S\r", b"X2\r", b"U\r", b"X1\r", b"D\r", b"X4\r", b"L\r", b"R\r", b"X2\r", b"S\r"):
        assert fed(s, cmd) == [b"\r"]
    tartu.settle()
    at(tartu, 350, 6)
    assert fed(s, b"C2\r") == [b"+0350+0006\r\n"]   # Hamlib prints 350.00 / 6.00


def test_603_capture_transcript(tartu):
    """protocols.md 3.3: the extra bare CR after every write gets no reply at all, so
    nothing can be read as the answer to the next C2."""
    s = Gs232bSession(tartu.rot)
    at(tartu, 100, 20)
    assert fed(s, b"W100 020\r") == []
    assert fed(s, b"\r") == []
    assert fed(s, b"C2\r") == [b"AZ=100  EL=020\r\n"]
    at(tartu, 350, 6)
    for cmd in (b"S\r", b"X2\r", b"U\r", b"X1\r", b"D\r", b"X4\r", b"L\r", b"R\r", b"X2\r", b"S\r"):
        assert fed(s, cmd) == [] and fed(s, b"\r") == []
    tartu.settle()
    at(tartu, 350, 6)
    assert fed(s, b"C2\r") == [b"AZ=350  EL=006\r\n"]


@pytest.mark.parametrize("cls", [Gs232GenericSession, FoxDeltaSession])
def test_602_608_capture_transcript(tartu, cls):
    """protocols.md 3.4: writes go out back to back (`W350 006\\rS\\r` in one read);
    sets are never answered; C2 -> +0aaa+0eee CR (11 bytes, what 4.6 reads at most)."""
    s = cls(tartu.rot)
    at(tartu, 100, 20)
    assert fed(s, b"W100 020\r") == []
    assert fed(s, b"C2\r") == [b"+0100+0020\r"]
    assert fed(s, b"S\rW350 006\rS\r") == []
    tartu.settle()
    at(tartu, 350, 6)
    assert fed(s, b"C2\r") == [b"+0350+0006\r"]


@pytest.mark.parametrize("cls", SESSIONS)
def test_single_axis_reads(tartu, cls):
    s, style = cls(tartu.rot), STYLE[cls]
    at(tartu, 123.4, 45.6)
    term = b"\r" if style == STYLE_GENERIC else b"\r\n"
    az, el = (b"AZ=123", b"EL=046") if style == STYLE_B else (b"+0123", b"+0046")
    assert fed(s, b"C\r") == [az + term]
    assert fed(s, b"B\r") == [el + term]
    assert fed(s, b"c\rb\r") == [az + term, el + term]


@pytest.mark.parametrize("cls", SESSIONS)
def test_byte_at_a_time_equals_whole(bench, cls):
    """Same replies, same motion, whatever the split."""
    script = b"W100 020\rC2\rX2\r\rC\r\nB\rbogus\rS\rc2\r"
    results = replay_splits(bench, cls, script, (5, 13))
    assert results[0] == results[1] == results[2]
    out = results[0][0]
    assert out.count(format_error(STYLE[cls])) == 1   # "bogus"
    assert results[0][1:] == (None, None)  # the final S stopped it: no target any more


@pytest.mark.parametrize("cls", SESSIONS)
def test_terminators_crlf_lf_and_trailing_partial(tartu, cls):
    s, style = cls(tartu.rot), STYLE[cls]
    at(tartu, 200, 30)
    expect = format_position(style, 200, 30)
    # CR, LF and CRLF each end a command; the CRLF's empty half gets no reply
    assert fed(s, b"C2\r\nC2\nC2\rC") == [expect] * 3
    assert fed(s, b"2\r") == [expect]          # the trailing partial completes later


@pytest.mark.parametrize("cls", [Gs232aSession, Gs232bSession])
def test_errors_answered_with_question_prompt(g5500, cls):
    s = cls(g5500.rot)
    err = format_error(STYLE[cls])
    assert fed(s, b"Q\r") == [err]
    assert fed(s, b"X9\r") == [err]
    assert fed(s, b"W100\r") == [err]
    # refused by the rotator (beyond the 450 deg limit): the same prompt, nothing moves
    assert fed(s, b"W460 000\r") == [err]
    assert fed(s, b"W100 181\r") == [err]
    g5500.run(1.0)
    assert not g5500.rot.status().moving and g5500.rot.status().target_az_deg is None


@pytest.mark.parametrize("cls", [Gs232GenericSession, FoxDeltaSession])
def test_generic_silent_on_refused_set(g5500, cls):
    """Hamlib 602/608 write back to back and read nothing after W: a refused W is silent
    (a late ?> would be read as the next C2's answer); garbage still gets ?>."""
    s = cls(g5500.rot)
    assert fed(s, b"W460 000\r") == []
    assert fed(s, b"Q\r") == [b"?>\r"]
    assert hamlib_read(STYLE_GENERIC, fed(s, b"C2\r")[0]) == b"+0000+0000\r"


def test_rotator_fault_maps_to_error(bench):
    """A jammed axis latches a stall fault: further motion is answered ?> and nothing
    moves; position reads still work."""
    b = bench("tartu-urc", faults={"overcurrent_a": 100.0})
    s = Gs232aSession(b.rot)
    assert fed(s, b"W200 045\r") == [b"\r"]
    b.run(1.5)
    b.world.inject("az", "jam")
    b.run(5.0)
    assert [f.kind for f in b.rot.status().faults] == ["stall"]
    assert fed(s, b"W100 020\rR\rM010\r") == [b"?>\r"] * 3
    assert fed(s, b"S\r") == [b"\r"]           # stop is always accepted
    assert fed(s, b"C2\r")[0].startswith(b"+0")
    b.run(1.0)
    assert not b.rot.status().moving


# ===================================================== end to end on the simulator
@pytest.mark.parametrize("cls", SESSIONS)
def test_set_then_read_back_matches_truth(g5500, cls):
    s, style = cls(g5500.rot), STYLE[cls]
    for az, el in ((100, 20), (300, 75), (30, 5)):
        fed(s, format_goto(az, el))
        g5500.settle()
        raz, rel = c2(s, style)
        assert abs(raz - g5500.truth("az")) <= AZ_TOL_DEG
        assert abs(rel - g5500.truth("el")) <= EL_TOL_DEG
        # below 360 the rotator picks the wrap side (30 may be reached as 390)
        assert abs((raz - az + 180) % 360 - 180) <= AZ_TOL_DEG and abs(rel - el) <= EL_TOL_DEG


@pytest.mark.parametrize("cls", SESSIONS)
def test_450_azimuth_names_the_wrap_pose(g5500, cls):
    """W400 and W120 elevation go to the overlap and the flipped side, not 40/60: the
    controller frame is the mechanical one, and it is reported back the same way."""
    s, style = cls(g5500.rot), STYLE[cls]
    fed(s, b"W400 120\r")
    g5500.settle()
    assert abs(g5500.truth("az") - 400) <= AZ_TOL_DEG     # mechanically past 360
    assert abs(g5500.truth("el") - 120) <= EL_TOL_DEG
    raz, rel = c2(s, style)
    assert abs(raz - 400) <= 1 and abs(rel - 120) <= 1
    st_ = g5500.rot.status()
    assert abs(st_.az_deg - 220) < 1.5 and abs(st_.el_deg - 60) < 1.5   # the sky direction
    fed(s, b"W450 000\r")
    g5500.settle()
    assert c2(s, style)[0] in (449, 450, 451) and abs(g5500.truth("az") - 450) <= AZ_TOL_DEG


def test_m_turns_azimuth_only_keeping_flipped_elevation(g5500):
    s = Gs232bSession(g5500.rot)
    fed(s, b"W100 120\r")
    g5500.settle()
    fed(s, b"M200\r")
    g5500.settle()
    raz, rel = c2(s, STYLE_B)
    assert abs(raz - 200) <= 1 and abs(rel - 120) <= 1
    assert abs(g5500.truth("el") - 120) <= EL_TOL_DEG


def test_m_at_bottom_stop_with_noisy_elevation(bench):
    """At el 0 a noisy sensor reads a little below zero at times (sarcnet-mini's
    magnetometer, half of the time): M must still be accepted."""
    b = bench("sarcnet-mini")
    s = Gs232aSession(b.rot)
    for az in (50, 10, 80):
        assert b.run(5.0, until=lambda st_: st_.el_deg < 0).el_deg < 0
        assert fed(s, f"M{az:03d}\r".encode()) == [b"\r"]
        b.settle()
        assert abs(c2(s, STYLE_A)[0] - az) <= 1


def test_query_while_moving_reports_where_it_is_now(g5500):
    s = Gs232aSession(g5500.rot)
    fed(s, b"W300 090\r")
    seen = []
    for _ in range(5):
        g5500.run(2.0)
        seen.append(c2(s, STYLE_A))
        assert abs(seen[-1][0] - controller_pose(g5500.rot.status())[0]) <= 0.5
    assert seen[0][0] < seen[-1][0] < 300 or seen[-1][0] == 300
    assert len({p for p in seen}) == len(seen)              # a fresh reading every time


@pytest.mark.parametrize("cls", SESSIONS)
def test_stop_all_and_single_axis(g5500, cls):
    s = cls(g5500.rot)
    fed(s, b"W300 150\r")
    g5500.run(3.0)
    fed(s, b"A\r")              # stop azimuth only: elevation goes on
    g5500.run(3.0)
    az1 = g5500.truth("az")
    g5500.settle()
    assert abs(g5500.truth("az") - az1) < 2.0 and g5500.truth("az") < 250
    assert abs(g5500.truth("el") - 150) <= EL_TOL_DEG
    fed(s, b"W300 000\r")
    g5500.run(3.0)
    fed(s, b"S\r")             # stop all, both axes halfway
    g5500.settle()
    st_ = g5500.rot.status()
    assert not st_.moving
    assert az1 + 5 < g5500.truth("az") < 250 and 100 < g5500.truth("el") < 148


@pytest.mark.parametrize("cmd, axis, sign", [(b"R", "az", 1), (b"L", "az", -1),
                                             (b"U", "el", 1), (b"D", "el", -1),
                                             # BIG-RAS's M forms (seed 002)
                                             (b"MR", "az", 1), (b"ML", "az", -1),
                                             (b"MU", "el", 1), (b"MD", "el", -1)])
def test_manual_moves(g5500, cmd, axis, sign):
    s = Gs232aSession(g5500.rot)
    fed(s, b"W200 090\r")
    g5500.settle()
    before = g5500.truth(axis)
    assert fed(s, cmd + b"\r") == [b"\r"]
    g5500.run(3.0)
    assert (g5500.truth(axis) - before) * sign > 5
    fed(s, b"E\r" if axis == "el" else b"A\r")
    g5500.settle()
    assert not g5500.rot.status().moving


def test_x_speed_levels(tartu):
    """X1..X4 set the speed of the following manual move (on a PWM-driven axis)."""
    rates = {}
    for level in (1, 2, 4):
        s = Gs232aSession(tartu.rot)
        fed(s, b"W100 045\r")
        tartu.settle()
        fed(s, f"X{level}\rR\r".encode())
        tartu.run(1.0)   # past the start ramp; then measure the true speed
        a0 = tartu.truth("az")
        tartu.run(3.0)
        rates[level] = (tartu.truth("az") - a0) / 3.0
        fed(s, b"S\r")
        tartu.settle()
    # X1 = 1/4, X2 = 1/2 of the top speed
    assert 0.5 < rates[1] < rates[2] < rates[4]
    assert abs(rates[2] / rates[1] - 2.0) < 0.1 and abs(rates[4] / rates[1] - 4.0) < 0.2


def test_mount_offset_reported_in_controller_frame(bench):
    b = bench("g5500", offsets={"az_deg": 10.0})
    s = Gs232aSession(b.rot)
    fed(s, b"W100 020\r")
    b.settle()
    assert abs(c2(s, STYLE_A)[0] - 100) <= 1
    assert abs(b.truth("az") - 90) <= AZ_TOL_DEG          # the mechanics sit 10 deg back
    fed(s, b"W400 020\r")
    b.settle()
    assert abs(c2(s, STYLE_A)[0] - 400) <= 1 and abs(b.truth("az") - 390) <= AZ_TOL_DEG


def test_negative_range_reported_as_compass(bench):
    """A rotator whose range starts below 0 (sarcnet-mini: -90..450): GS-232 has no sign,
    so -30 is reported as 330 (what Hamlib would have sent for -30)."""
    b = bench("sarcnet-mini")
    b.rot.goto(-30.0, 10.0)
    b.settle()
    s = Gs232bSession(b.rot)
    raz, _ = c2(s, STYLE_B)
    assert abs(raz - 330) <= 1.5


# ============================================================= bounded & fuzzed
@pytest.mark.parametrize("cls", SESSIONS)
def test_overlong_line_dropped_and_resynchronised(g5500, cls):
    s = cls(g5500.rot)
    err = format_error(STYLE[cls])
    junk = b"W" * (MAX_PENDING_BYTES + 10)
    replies = []
    for i in range(0, len(junk), 1000):
        replies += fed(s, junk[i:i + 1000])
    assert s._lines.pending <= MAX_PENDING_BYTES
    assert replies == [err]
    # the rest of that overlong line is not a command, even if it looks like one
    assert fed(s, b"W100 020\r") == []
    g5500.run(1.0)
    assert g5500.rot.status().target_az_deg is None
    assert len(fed(s, b"C2\r")) == 1                 # back in step


def _moves(data: bytes) -> bool:
    """Would any complete line of ``data`` be a valid motion command? (the fuzz oracle)"""
    for item in LineSplitter(MAX_PENDING_BYTES).feed(data):
        try:
            if not item.overflowed and parse_command(item.text).op in ("goto", "goto_az", "goto_el", "move",
                                                                         "nmea"):
                return True
        except Gs232ParseError:
            pass
    return False


_PIECES = st.sampled_from([b"W", b"M", b"C", b"C2", b"X", b"R", b"U", b"1", b"100", b"450",
                           b"999", b" ", b"\r", b"\n", b"\r\n", b"-", b".", b"nan", b"inf",
                           b"\x00", b"\xff", b"?>", b"S"])
GARBAGE = st.one_of(st.binary(max_size=300),
                    st.lists(st.one_of(_PIECES, st.binary(max_size=4)), max_size=60).map(b"".join))


@pytest.fixture(scope="module")
def fuzz_bench(tmp_path_factory):
    return Bench("g5500", tmp_path_factory.mktemp("gs232-fuzz"))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=GARBAGE, cls=st.sampled_from(SESSIONS), split=st.integers(1, 7))
@example(data=b"h\r", cls=Gs232aSession, split=1)  # (found by a CI run: H's list is long)
@raises_nothing
def test_fuzz_garbage_never_moves_or_raises(fuzz_bench, data, cls, split):
    assume(not _moves(data))
    b = fuzz_bench
    s = cls(b.rot)
    replies = []
    for i in range(0, len(data), split):
        replies += fed(s, data[i:i + split])
    lines = data.count(b"\r") + data.count(b"\n") + 1
    assert len(replies) <= lines
    # every reply is short, but for H's command list (the BIG-RAS extension): garbage such
    # as b"h\r" is that command, and its answer is the list
    assert all(isinstance(r, bytes) and (0 < len(r) <= 16 or r == format_help()) for r in replies)
    assert s._lines.pending <= MAX_PENDING_BYTES
    b.run(0.5)
    st_ = b.rot.status()
    assert not st_.moving and st_.target_az_deg is None and st_.az.target_deg is None


@pytest.mark.filterwarnings("ignore:Using `assume` outside")   # the fuzz body, called directly
def test_fuzz_test_fails_on_an_injected_bug(fuzz_bench, monkeypatch):
    """Issue 12.21: a TypeError injected into the GS-232 parser used to pass the fuzz
    test (the session answered it with ``?>``). Now it is counted and the test fails."""
    import urc.protocols.base as base
    import urc.protocols.gs232 as gs232

    saved = base.INTERNAL_ERRORS.copy()

    def broken(line):
        raise TypeError("injected")
    monkeypatch.setattr(gs232, "parse_command", broken)
    fuzz = test_fuzz_garbage_never_moves_or_raises.hypothesis.inner_test
    try:
        with pytest.raises(AssertionError, match="unexpected exception"):
            fuzz(fuzz_bench, b"C2\r", Gs232aSession, 1)
        assert base.internal_error_count() == sum(saved.values()) + 1
    finally:
        base.INTERNAL_ERRORS.clear()
        base.INTERNAL_ERRORS.update(saved)


# ============================================================ BIG-RAS extensions (seed 002)
def test_bigras_command_list_transcript(bench):
    """The document's command list, in its order, on a BIG-RAS (GS-232B emulation)."""
    b = bench("bigras")
    s = Gs232bSession(b.rot)
    (help_,) = fed(s, b"H\r")
    firsts = [row.split(" - ")[0] for row in help_.decode().splitlines()]
    for doc in ("Waaa eee", "A", "AZ=aaa", "AZ=aaa EL=eee", "E", "EL=eee", "S", "Maaa", "Keee",
                "ML", "MR", "MU", "MD", "L", "R", "U", "D", "C", "C2", "B"):
        assert doc in firsts, doc
    assert fed(s, b"AZ=100\r") == []
    b.settle()
    assert fed(s, b"C2\r") == [b"AZ=100  EL=000\r\n"]
    assert fed(s, b"EL=045\r") == []
    b.settle()
    assert fed(s, b"C2\r") == [b"AZ=100  EL=045\r\n"]
    assert fed(s, b"AZ=120 EL=030\r") == []
    b.settle()
    assert fed(s, b"C2\r") == [b"AZ=120  EL=030\r\n"]
    assert fed(s, b"K020\r") == []
    b.settle()
    assert fed(s, b"C\rB\r") == [b"AZ=120\r\n", b"EL=020\r\n"]
    assert fed(s, b"EL=100\r") == [b"?>\r\n"]                    # above its 90: refused


def _gga(lat: float, lon: float, alt_m: float) -> bytes:
    import pynmea2

    def dm(v: float, width: int) -> str:
        d = int(abs(v))
        return f"{d:0{width}d}{(abs(v) - d) * 60:07.4f}"
    msg = pynmea2.GGA("GP", "GGA", ("120000.00", dm(lat, 2), "N" if lat >= 0 else "S", dm(lon, 3),
                                    "E" if lon >= 0 else "W", "1", "08", "0.9", f"{alt_m:.1f}", "M",
                                    "0.0", "M", "", ""))
    return str(msg).encode()


def test_bigras_nmea_gga_turns_to_the_reported_point(bench):
    from urc.tracking.station import Station
    from urc.tracking.targets import GeoPointTarget

    b = bench("bigras")
    station = dict(station_lat_deg=47.5, station_lon_deg=19.0, station_alt_m=100.0)
    s = make_session("gs232b", b.rot, **station)
    point = GeoPointTarget(Station(47.5, 19.0, 100.0), 47.6, 19.1, 9000.0)
    assert 0 < point.el_deg < 90
    assert fed(s, _gga(47.6, 19.1, 9000.0) + b"\r\n") == []
    b.settle()
    az, el = (float(v) for v in fed(s, b"C2\r")[0][3:].split(b"EL="))
    assert (az, el) == pytest.approx((point.az_deg, point.el_deg), abs=1.0)


def test_bigras_nmea_without_coordinates_or_checksum_is_refused(bench):
    b = bench("bigras")
    sentence = _gga(47.6, 19.1, 9000.0)
    assert fed(Gs232bSession(b.rot), sentence + b"\r") == [b"?>\r\n"]      # no station set
    s = Gs232bSession(b.rot, station_lat_deg=47.5, station_lon_deg=19.0)
    bad = sentence[:-2] + (b"00" if sentence[-2:] != b"00" else b"11")
    assert fed(s, bad + b"\r") == [b"?>\r\n"]
    b.run(2.0)
    assert b.rot.status().target_az_deg is None


def test_bigras_nmea_without_station_options_answers_and_says_why(bench, caplog):
    """Issue 36.18: a GGA sentence on a GS-232B port with no station options: `?>`, and
    the log names the options that are missing."""
    b = bench("bigras")
    with caplog.at_level("WARNING", logger="urc.protocols.gs232b"):
        assert fed(make_session("gs232b", b.rot), _gga(47.6, 19.1, 9000.0) + b"\r\n") == [b"?>\r\n"]
    assert any("station_lat_deg" in r.getMessage() and "NMEA" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize("options, said", [
    ({"station_lat_deg": 47.5}, "go together"),
    ({"station_lon_deg": 19.0}, "go together"),
    ({"station_lat_deg": "north", "station_lon_deg": 19.0}, "lat_deg"),
    ({"station_lat_deg": 123.0, "station_lon_deg": 19.0}, "lat_deg"),
    ({"station_lat_deg": 47.5, "station_lon_deg": 19.0, "station_alt_m": 1e9}, "alt_m"),
])
def test_station_options_that_are_no_position_are_bad_options(bench, options, said):
    """Half a pair said "float() argument must be ... not 'NoneType'"; a latitude of 123
    or "north" crashed the start (the server reports a TypeError as bad options, at start)."""
    b = bench("bigras")
    with pytest.raises(TypeError, match=said):
        Gs232bSession(b.rot, **options)
