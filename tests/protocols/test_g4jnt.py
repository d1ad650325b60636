"""G4JNT PIC controller: the b/p position stream, the Z C K M constants, G and S.

The pot model is checked against the simulator's own pot (urc.hardware.sim.sensors),
the stream against the simulator's truth on the g4jnt profile (10-bit ratiometric pot,
relay drive with slow and fast motion).
"""

from __future__ import annotations

import re

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from conftest import Bench
from session_replay import raises_nothing
from urc.protocols import make_session
from urc.protocols import g4jnt_codec as codec
from urc.protocols.g4jnt import PULSE_DEG, G4jntSession
from urc.protocols.g4jnt_codec import G4jntCommand, G4jntSyntaxError
from urc.testing.sessions import fed, ticked

#: bearing vs truth: the pot's coarsest step (0.9 deg), its noise and the relay's 0.9 deg band
TRUTH_TOL_DEG = 1.5


@pytest.fixture
def g4(bench):
    b = bench("g4jnt")
    return b, G4jntSession(b.rot)


def stream(b: Bench, s: G4jntSession) -> tuple[float, int]:
    """The next stream line, whenever it is due."""
    for _ in range(100):
        out = ticked(s, b.clock.now_s())
        if out:                          # (the first tick brings the banner too)
            return codec.parse_stream_line(out[-1])
        b.run(0.02)
    raise AssertionError("no stream line within 2 s")


def sim_pot_p(b: Bench) -> float:
    """The P the simulated G4JNT's own ADC gives now (no noise)."""
    pot = b.rot.hw.az.sensor
    return pot.linearised(pot.adc.read_counts(noisy=False))


# ======================================================================== codec
#: Table 1 of the document: the stream after power-on, as the rotator was turned
TABLE_1_STREAM = b"""b059.3,p1415
b058.6,p1422
b057.8,p1430
b057.8,p1430
b056.7,p1441
b054.3,p1466
b052.5,p1485
b052.5,p1485
b049.9,p1511
b051.0,p1500
b052.2,p1488
b053.9,p1470
"""


def test_table_1_stream_comes_out_of_its_own_constants():
    """Every bearing of Table 1 from its P and its listed constants, byte for byte."""
    for want in TABLE_1_STREAM.splitlines():
        p = int(want.split(b",p")[1])
        assert codec.stream_line(codec.bearing_tenths(p, codec.TABLE_1), p) == want + b"\r\n"


def test_table_1_banner():
    assert codec.banner(codec.TABLE_1) == (
        b"G4JNT Rotator Controller\r\nStored Constants -\r\n"
        b"Z 1807\r\nM -15897\r\nC 3758\r\nK 2048\r\n\r\n"
        b"Commands # + Z/C/K/M + (-)nnnn(n)\r\n")


@pytest.mark.parametrize("line, cmd", [
    (b"#Z1807", G4jntCommand("const", name="Z", value=1807)),
    (b"#m-15897", G4jntCommand("const", name="M", value=-15897)),
    (b" #C 3758 ", G4jntCommand("const", name="C", value=3758)),
    (b"#K2048", G4jntCommand("const", name="K", value=2048)),
    (b"#Z0", G4jntCommand("const", name="Z", value=0)),
    (b"#Z3599", G4jntCommand("const", name="Z", value=3599)),
    (b"?", G4jntCommand("all")),
    (b"L", G4jntCommand("pulse", direction=-1)),
    (b"r", G4jntCommand("pulse", direction=1)),
    (b"G123.4", G4jntCommand("goto", az_deg=123.4)),
    (b"g 123.4 , 45", G4jntCommand("goto", az_deg=123.4, el_deg=45.0)),
    (b"S", G4jntCommand("stop")),
    (b"", None),
])
def test_parse(line, cmd):
    assert codec.parse_line(line) == cmd


@pytest.mark.parametrize("line", [b"#M0", b"#K100", b"#K99999", b"#Z12.5", b"Z12", b"#Q1", b"#Z", b"#Z1234567",
                                  b"#Z3600", b"#Z3700", b"#Z-5", b"#Z-100",
                                  b"Gnan", b"G1e3", b"G", b"G1,", b"X", b"LL", b"SS", b"G" + b"9" * 400, b"\xff"])
def test_parse_errors(line):
    with pytest.raises(G4jntSyntaxError, match="expected|out of range"):
        codec.parse_line(line)


def test_ratiometric_formula():
    # P = 4096 N / (K - N), K = 1024 x the divider gain of 2
    assert codec.linearise(0) == 0 and codec.linearise(512) == 4096 * 512 // 1536
    assert codec.linearise(1023) == 4088
    # the loaded pot: N = 2048 x / (1 + x), so P = 4096 x up to the ADC's step
    for x in (0.0, 0.1, 0.25, 0.5, 0.9, 1.0):
        assert codec.linearise(codec.adc_counts(x)) == pytest.approx(4096 * x, abs=9)


@given(p=st.integers(0, 4096), z=st.integers(-9999, 99999), m=st.integers(-99999, 99999).filter(bool),
       c=st.integers(-99999, 99999))
def test_never_b_minus_000_1(p, z, m, c):
    line = codec.stream_line(codec.bearing_tenths(p, codec.Constants(z=z, m=m, c=c)), p)
    bearing, p_back = codec.parse_stream_line(line)
    assert 0.0 <= bearing <= 359.9 and p_back == p


def test_sensor_units_round_trip():
    assert codec.from_sensor(codec.to_sensor(codec.TABLE_1)) == codec.TABLE_1


# ======================================================================= session
def power_on(b: Bench, s: G4jntSession) -> bytes:
    out = ticked(s, b.clock.now_s())
    assert len(out) == 2
    return out[0]


def test_power_on_banner_lists_the_rotators_pot_constants(g4):
    b, s = g4
    k = codec.from_sensor(b.rot.hw.az.sensor.calibration())
    assert power_on(b, s) == codec.banner(k)
    assert k == codec.TABLE_1.with_value("Z", 0)        # the simulated g4jnt is Table 1's pot
    assert ticked(s, b.clock.now_s() + 0.5)[0].startswith(b"b")            # then the stream only


def turned_deg(a_deg: float, b_deg: float) -> float:
    return (b_deg - a_deg + 180.0) % 360.0 - 180.0


def test_constants_are_the_rotators_calibration_and_persist(g4, bench):
    b, s = g4
    before = b.rot.status().az_deg
    assert fed(s, b"#Z50\r") == [b"Z 50\r\n"]
    b.run(0.1)                                  # the rotator applies it at its next tick
    # Z applied to the bearing the rotator reports (nothing moves)
    assert turned_deg(before, b.rot.status().az_deg) == pytest.approx(5.0, abs=0.3)
    assert b.rot.hw.az.sensor.calibration()["Z"] == pytest.approx(5.0, abs=1e-9)  # as sent, in 0.1 deg
    # another connection, then a restart of urc: the same constants
    assert fed(G4jntSession(b.rot), b"?\r") == [b"Z 50\r\nM -15897\r\nC 3758\r\nK 2048\r\n"]
    b.run(2.0)
    b2 = b.restart()
    again = G4jntSession(b2.rot)
    assert power_on(b2, again).splitlines()[2] == b"Z 50"
    assert turned_deg(before, b2.rot.status().az_deg) == pytest.approx(5.0, abs=0.3)


def test_z_turns_bearings_not_the_travel(g4):
    """Z is the bearing of the end-stop reference: it moves bearings, never the limits
    (a Z of 350.0 used to be refused as 'outside the 0..360 limits')."""
    b, s = g4
    assert fed(s, b"#Z3500\r") == [b"Z 3500\r\n"]
    b.run(0.1)
    st_ = b.rot.status()
    assert st_.limits["az"] == (-10.0, 370.0) and st_.offsets["az"] == pytest.approx(-10.0)
    assert st_.az_deg == pytest.approx((b.truth("az") - 10.0) % 360.0, abs=TRUTH_TOL_DEG)


@pytest.mark.parametrize("line", [b"#Z3700", b"#Z-5", b"#Z3600"])
def test_z_outside_the_documents_range_is_refused(g4, line):
    """Issue 36.17: the document keeps Z "within the range 000 to 359.9"; #Z3700 and #Z-5
    were taken modulo 360. Refused, and nothing changes."""
    b, s = g4
    before = (b.rot.status().offsets["az"], b.rot.hw.az.sensor.calibration()["Z"])
    reply = fed(s, line + b"\r")
    assert len(reply) == 1 and reply[0].startswith(b"? #Z: expected a bearing 0..3599"), reply
    b.run(0.1)
    assert (b.rot.status().offsets["az"], b.rot.hw.az.sensor.calibration()["Z"]) == before
    assert fed(s, b"?\r")[0].startswith(b"Z 0\r\n")


def test_a_constant_the_rotator_refuses_changes_nothing(g4):
    b, s = g4
    b.rot.hold_local("cw", True)              # a button held at the rotator: remote sets wait
    reply = fed(s, b"#Z50\r")
    assert reply[0].startswith(b"? refused (local)")
    b.rot.hold_local("cw", False)
    assert fed(s, b"?\r")[0].startswith(b"Z 0\r\n")


def table_1_session(b: Bench) -> G4jntSession:
    """A PC loading Table 1's constants in the document's order, one line each."""
    s = G4jntSession(b.rot)
    assert fed(s, b"#Z1807\r#M-15897\r#C3758\r") == [b"Z 1807\r\n", b"M -15897\r\n", b"C 3758\r\n"]
    b.run(0.1)
    return s


def bearing_of(theta_deg: float) -> float:
    return (theta_deg + 180.7) % 360.0


def test_table_1_end_to_end(g4):
    """The document's Table 1: Z = 180.7, M = -15897, C = 3758 on its own pot. Bearing =
    theta + Z modulo 360, the travel -10..370 belongs to theta: G10 is reached at theta
    189.3 (it used to drive counter-clockwise into the end stop, FAULT stall), and a
    bearing just across the end stop from where the antenna is goes the long way round."""
    b, _ = g4
    s = table_1_session(b)
    st_ = b.rot.status()
    assert st_.limits["az"] == (-10.0, 370.0) and not st_.faults
    assert st_.az_deg == pytest.approx(bearing_of(b.truth("az")), abs=TRUTH_TOL_DEG)
    # from theta 0 (bearing 180.7): 170 lies 10.7 deg back across the end stop, reached
    # the long way round; then 10 (the reported stall), Table 1's 59.3, and bearings
    # that have two thetas (within 10 deg of the reference): the nearer is taken
    for goal, theta in ((170.0, 349.3), (10.0, 189.3), (59.3, 238.6), (190.0, 369.3), (175.0, 354.3),
                        (185.0, 364.3)):
        assert fed(s, f"G{goal}\r".encode()) == [f"G{goal:g}\r\n".encode()]
        b.settle()
        assert not b.rot.status().faults, b.rot.status().faults
        assert b.truth("az") == pytest.approx(theta, abs=TRUTH_TOL_DEG)
        s._next_s = None
        line = ticked(s, b.clock.now_s())[-1]
        bearing, p = codec.parse_stream_line(line)
        # the stream is Table 1's arithmetic on what the pot reads, and true
        assert line == codec.stream_line(codec.bearing_tenths(p, codec.TABLE_1), p)
        assert bearing == pytest.approx(goal, abs=TRUTH_TOL_DEG)
        if goal == 59.3:                      # Table 1's first line: b059.3,p1415
            assert p == pytest.approx(1415, abs=TRUTH_TOL_DEG / 0.097)   # M: 0.097 deg per P


def test_m_and_c_load_one_after_the_other(g4):
    """A PC calibration routine sends M, then C. With the C in force the new M alone
    puts theta far outside the travel: it is held, not refused (it used to be '?
    refused (limit)'), and stored with C once the pair fits."""
    b, s = g4
    fed(s, b"G180\r")
    b.settle()
    sensor = b.rot.hw.az.sensor
    # the controller's constants before: another pot's (theta still inside the travel)
    from urc.procedures import calibration
    old = codec.Constants(z=0, m=18432, c=-504)
    calibration.apply_sensor_calibration(b.rot, "az", codec.to_sensor(old))
    b.run(0.1)
    (held,) = fed(s, b"#M-15897\r")
    assert held.startswith(b"M -15897 held: ") and b"outside -10..370" in held
    assert codec.from_sensor(sensor.calibration()) == old                 # nothing stored yet
    assert fed(s, b"?\r") == [b"Z 0\r\nM 18432\r\nC -504\r\nK 2048\r\nHeld (not stored) - M -15897\r\n"]
    assert fed(s, b"#C3758\r") == [b"C 3758\r\n"]
    b.run(0.1)
    assert codec.from_sensor(sensor.calibration()) == codec.TABLE_1.with_value("Z", 0)
    assert b.rot.status().az.pos_deg == pytest.approx(b.truth("az"), abs=TRUTH_TOL_DEG)
    assert fed(s, b"?\r") == [b"Z 0\r\nM -15897\r\nC 3758\r\nK 2048\r\n"]
    # the pair works: a goto is reached
    fed(s, b"G100\r")
    b.settle()
    assert b.truth("az") == pytest.approx(100.0, abs=TRUTH_TOL_DEG) and not b.rot.status().faults


def test_stream_p_is_the_pot_reading_and_b_comes_from_it(g4):
    b, s = g4
    for az in (20.0, 180.0, 340.0):
        fed(s, f"G{az}\r".encode())
        b.settle()
        s._next_s = None
        (line,) = ticked(s, b.clock.now_s())[-1:]
        bearing, p = codec.parse_stream_line(line)
        pot = b.rot.hw.az.sensor
        assert p == codec.linearise(pot.last_counts)                      # what the ADC read
        assert line == codec.stream_line(codec.bearing_tenths(p, s.constants), p)
        assert bearing == pytest.approx(b.truth("az"), abs=TRUTH_TOL_DEG)


def test_stream_timing(g4):
    b, s = g4
    t0 = b.clock.now_s()
    assert len(ticked(s, t0)) == 2                  # banner and a line at once
    assert ticked(s, t0 + 0.2) == [] and ticked(s, t0 + 0.49) == []
    assert len(ticked(s, t0 + 0.5)) == 1
    assert len(ticked(s, t0 + 10.0)) == 1           # after a stall: one line, not twenty
    assert ticked(s, t0 + 10.1) == [] and len(ticked(s, t0 + 10.5)) == 1
    fast = G4jntSession(b.rot, interval_s=0.1)
    assert sum(len(ticked(fast, t0 + k * 0.05)) for k in range(21)) == 12
    with pytest.raises(ValueError):
        G4jntSession(b.rot, interval_s=0)


def test_go_left_and_go_right_pulse(g4):
    b, s = g4
    fed(s, b"G100\r")
    b.settle()
    start = b.truth("az")
    assert fed(s, b"R\r") == [b"R\r\n"]
    b.settle()
    right = b.truth("az")
    assert 0.5 < right - start < 2 * PULSE_DEG
    assert fed(s, b"L\rL\r") == [b"L\r\n", b"L\r\n"]
    b.settle()
    assert b.truth("az") < right - 0.5


def test_without_a_pot_the_constants_are_the_connections(bench):
    b = bench("tartu-urc")
    s = G4jntSession(b.rot)
    assert fed(s, b"#Z100\r") == [b"Z 100\r\n"]
    line = ticked(s, b.clock.now_s())[-1]
    bearing, _ = codec.parse_stream_line(line)
    assert bearing == pytest.approx(b.rot.status().az_deg, abs=0.2)
    assert fed(G4jntSession(b.rot), b"?\r")[0].startswith(b"Z 0\r\n")


def test_goto_then_stream_matches_truth(g4):
    b, s = g4
    assert fed(s, b"G123.4,30\r") == [b"G123.4,30\r\n"]
    b.settle()
    bearing, _ = stream(b, s)
    assert bearing == pytest.approx(b.truth("az"), abs=TRUTH_TOL_DEG)
    assert bearing == pytest.approx(123.4, abs=TRUTH_TOL_DEG)
    assert b.truth("el") == pytest.approx(30.0, abs=0.8)


def test_g_keeps_elevation_and_one_chunk_works(g4):
    b, s = g4
    fed(s, b"G50,40\rG200\r")                                # no tick in between
    b.settle()
    assert (b.truth("az"), b.truth("el")) == pytest.approx((200.0, 40.0), abs=TRUTH_TOL_DEG)


def test_stop(g4):
    b, s = g4
    fed(s, b"G300\r")
    b.run(5.0)
    assert fed(s, b"s\r") == [b"S\r\n"]
    b.settle()
    assert 5.0 < b.truth("az") < 100.0
    bearing, _ = stream(b, s)
    assert bearing == pytest.approx(b.truth("az"), abs=TRUTH_TOL_DEG)


def test_errors_do_not_move(g4):
    b, s = g4
    replies = fed(s, b"G400\rGnan\rfoo\rG10,95\r")
    assert [r[:2] for r in replies] == [b"? "] * 4
    assert b"refused (limit)" in replies[0] and b"'foo'" in replies[2]
    b.run(2.0)
    st_ = b.rot.status()
    assert st_.target_az_deg is None and st_.az.target_deg is None
    assert b.truth("az") == pytest.approx(0.0, abs=0.3)


def test_whole_bytewise_chunked_same(bench):
    data = b"?\r#Z1\nfoo\r\n#K2040\r?\r"
    outs = []
    for chunk in (len(data), 1, 3):
        s = G4jntSession(bench("tartu-urc").rot)
        outs.append(b"".join(r for i in range(0, len(data), chunk) for r in fed(s, data[i:i + chunk])))
    assert outs[0] == outs[1] == outs[2]
    assert outs[0].endswith(b"Z 1\r\nM 14400\r\nC 0\r\nK 2040\r\n")


def test_registry_name(g4):
    b, _ = g4
    assert isinstance(make_session("g4jnt", b.rot), G4jntSession)


# ======================================================================== fuzz
@pytest.fixture(scope="module")
def quiet(tmp_path_factory):
    return Bench("g4jnt", tmp_path_factory.mktemp("g4jnt-fuzz"))


_WORDS = st.sampled_from([b"#", b"Z", b"C", b"K", b"M", b"G", b"S", b"L", b"R", b"?", b"\r", b"\n", b"1", b"-",
                          b".", b",", b"nan", b" "])
_DATA = st.lists(st.one_of(st.binary(max_size=20), _WORDS), max_size=24).map(b"".join)


@settings(max_examples=150, deadline=None)
@given(data=_DATA, split=st.integers(1, 9))
@raises_nothing
def test_fuzz_never_raises_or_moves(quiet, data, split):
    data = data.replace(b"\x7f", b"").replace(b"\x08", b"")
    # a goto or a pulse could legitimately move; a constant re-references the rotator
    assume(not re.search(rb"[Gg]\s*[+-]?[\d.]|(^|[\r\n])\s*[LlRr]\s*($|[\r\n])|#\s*[ZCKMzckm]\s*[+-]?\d", data))
    s = G4jntSession(quiet.rot)
    replies = []
    for i in range(0, len(data), split):
        replies += fed(s, data[i:i + split])
    assert all(r.endswith(b"\r\n") and (r.count(b"\n") == 1 or r.startswith(b"Z ")) for r in replies)
    assert len(replies) <= data.count(b"\r") + data.count(b"\n") + 1
    quiet.run(1.0)
    st_ = quiet.rot.status()
    assert st_.target_az_deg is None and st_.az.target_deg is None and st_.el.target_deg is None
    assert abs(quiet.truth("az")) < 0.3 and abs(quiet.truth("el")) < 0.3
