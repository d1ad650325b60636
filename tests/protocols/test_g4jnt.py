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
from urc.protocols import make_session
from urc.protocols import g4jnt_codec as codec
from urc.protocols.g4jnt import G4jntSession
from urc.protocols.g4jnt_codec import G4jntCommand, G4jntSyntaxError

#: bearing vs truth: the pot's coarsest step (0.9 deg), its noise and the relay's 0.9 deg band
TRUTH_TOL_DEG = 1.5


@pytest.fixture
def g4(bench):
    b = bench("g4jnt")
    return b, G4jntSession(b.rot)


def stream(b: Bench, s: G4jntSession) -> tuple[float, int]:
    """The next stream line, whenever it is due."""
    for _ in range(100):
        out = s.tick(b.clock.now_s())
        if out:
            (line,) = out
            return codec.parse_stream_line(line)
        b.run(0.02)
    raise AssertionError("no stream line within 2 s")


def sim_pot_p(b: Bench) -> float:
    """The P the simulated G4JNT's own ADC gives now (no noise)."""
    pot = b.rot.hw.az.sensor
    return pot.linearised(pot.adc_counts(noisy=False))


# ======================================================================== codec
@pytest.mark.parametrize("line, cmd", [
    (b"Z12.5", G4jntCommand("const", name="Z", value=12.5)),
    (b"z", G4jntCommand("const", name="Z")),
    (b"M0.0879", G4jntCommand("const", name="M", value=0.0879)),
    (b"C-3.0", G4jntCommand("const", name="C", value=-3.0)),
    (b" K 5 ", G4jntCommand("const", name="K", value=5.0)),
    (b"?", G4jntCommand("all")),
    (b"G123.4", G4jntCommand("goto", az_deg=123.4)),
    (b"g 123.4 , 45", G4jntCommand("goto", az_deg=123.4, el_deg=45.0)),
    (b"S", G4jntCommand("stop")),
    (b"", None),
])
def test_parse(line, cmd):
    assert codec.parse_line(line) == cmd


@pytest.mark.parametrize("line", [b"M0", b"M-1", b"K-1", b"Gnan", b"G1e3", b"G", b"G1,", b"X", b"Z12.5x",
                                  b"ZZ", b"SS", b"G" + b"9" * 400, b"\xff"])
def test_parse_errors(line):
    with pytest.raises(G4jntSyntaxError, match="expected|must be|out of range"):
        codec.parse_line(line)


def test_ratiometric_formula():
    # P = 4096 N / (2048 - N)
    assert codec.linearise(0) == 0 and codec.linearise(512) == pytest.approx(4096 * 512 / 1536)
    assert codec.linearise(1023) == pytest.approx(4088.0, abs=0.01)
    # the loaded pot: N = 2048 x / (1 + x), so P = 4096 x up to the ADC's step
    for x in (0.0, 0.1, 0.25, 0.5, 0.9, 1.0):
        assert codec.linearise(codec.adc_counts(4096 * x)) == pytest.approx(4096 * x, abs=9)
    assert codec.adc_counts(-50) == 0 and codec.adc_counts(99999) == 1023


@given(bearing=st.floats(0.0, 360.0))
def test_bearing_p_round_trip(bearing):
    m, c, z = 0.1125, -50.4, 0.0            # the simulated g4jnt azimuth pot
    p = codec.p_for_bearing(bearing, m, c, z)
    # back within the ADC's coarsest step (0.9 deg at full scale)
    assert codec.bearing_for_p(p, m, c, z) == pytest.approx(bearing, abs=0.9)


def test_formats():
    assert codec.stream_line(59.3, 1415) == b"b059.3,p1415\r\n"
    assert codec.stream_line(-0.04, 3) == b"b000.0,p0003\r\n"
    assert codec.parse_stream_line(b"b059.3,p1415\r\n") == (59.3, 1415)
    assert [codec.format_constant(n, v) for n, v in (("M", 0.0879), ("C", -3.0), ("K", 5), ("Z", 12.5))] == \
        ["M0.0879", "C-3.0", "K5.0", "Z12.5"]


@given(tenths=st.integers(0, 3600), p=st.integers(0, 4096))
def test_stream_round_trip(tenths, p):
    assert codec.parse_stream_line(codec.stream_line(tenths / 10, p)) == (tenths / 10, p)


# ======================================================================= session
def test_constants_start_from_the_rotators_pot(g4):
    b, s = g4
    cal = b.rot.hw.az.sensor.calibration()
    assert s.receive(b"?\r") == [f"Z{cal['Z']:.1f} C{cal['C']:.1f} K5.0 M{cal['M']:g}\r\n".encode()]


def test_constants_default_without_a_pot(bench):
    s = G4jntSession(bench("tartu-urc").rot)
    assert s.receive(b"?\r") == [b"Z0.0 C0.0 K5.0 M0.0878906\r\n"]


def test_set_and_echo_constants(g4):
    b, s = g4
    assert s.receive(b"Z12.5\rM0.0879\nC-3.0\r\nK3\r") == [b"Z12.5\r\n", b"M0.0879\r\n", b"C-3.0\r\n", b"K3.0\r\n"]
    assert s.receive(b"Z\rM\r") == [b"Z12.5\r\n", b"M0.0879\r\n"]
    assert s.receive(b"M0\r")[0].startswith(b"? M (degrees per P unit) must be > 0")
    assert s.receive(b"M\r") == [b"M0.0879\r\n"]               # unchanged


def test_stream_timing(g4):
    b, s = g4
    t0 = b.clock.now_s()
    assert len(s.tick(t0)) == 1                  # at once
    assert s.tick(t0 + 0.2) == [] and s.tick(t0 + 0.49) == []
    assert len(s.tick(t0 + 0.5)) == 1
    assert len(s.tick(t0 + 10.0)) == 1           # after a stall: one line, not twenty
    assert s.tick(t0 + 10.1) == [] and len(s.tick(t0 + 10.5)) == 1
    fast = G4jntSession(b.rot, interval_s=0.1)
    assert sum(len(fast.tick(t0 + k * 0.05)) for k in range(21)) == 11
    with pytest.raises(ValueError):
        G4jntSession(b.rot, interval_s=0)


def test_p_matches_the_simulated_pot(g4):
    b, s = g4
    for az in (20.0, 180.0, 340.0):
        s.receive(f"G{az}\r".encode())
        b.settle()
        bearing, p = stream(b, s)
        assert bearing == pytest.approx(b.truth("az"), abs=TRUTH_TOL_DEG)
        assert p == pytest.approx(sim_pot_p(b), abs=12)        # a count or two of the ADC
        s._next_s = None


def test_changing_m_c_z_changes_p_not_the_bearing(g4):
    b, s = g4
    b1, p1 = stream(b, s)
    s.receive(b"Z10\r")
    s._next_s = None
    b2, p2 = stream(b, s)
    assert b2 == pytest.approx(b1, abs=0.3)
    assert p2 < p1 - 50                                        # 10 deg / 0.1125 = 89 counts less


def test_goto_then_stream_matches_truth(g4):
    b, s = g4
    assert s.receive(b"G123.4,30\r") == [b"G123.4,30\r\n"]
    b.settle()
    bearing, _ = stream(b, s)
    assert bearing == pytest.approx(b.truth("az"), abs=TRUTH_TOL_DEG)
    assert bearing == pytest.approx(123.4, abs=TRUTH_TOL_DEG)
    assert b.truth("el") == pytest.approx(30.0, abs=0.8)


def test_g_keeps_elevation_and_one_chunk_works(g4):
    b, s = g4
    s.receive(b"G50,40\rG200\r")                                # no tick in between
    b.settle()
    assert (b.truth("az"), b.truth("el")) == pytest.approx((200.0, 40.0), abs=TRUTH_TOL_DEG)


def test_stop(g4):
    b, s = g4
    s.receive(b"G300\r")
    b.run(5.0)
    assert s.receive(b"s\r") == [b"S\r\n"]
    b.settle()
    assert 5.0 < b.truth("az") < 100.0
    bearing, _ = stream(b, s)
    assert bearing == pytest.approx(b.truth("az"), abs=TRUTH_TOL_DEG)


def test_errors_do_not_move(g4):
    b, s = g4
    replies = s.receive(b"G400\rGnan\rfoo\rG10,95\r")
    assert [r[:2] for r in replies] == [b"? "] * 4
    assert b"refused (limit)" in replies[0] and b"'foo'" in replies[2]
    b.run(2.0)
    st_ = b.rot.status()
    assert st_.target_az_deg is None and st_.az.target_deg is None
    assert b.truth("az") == pytest.approx(0.0, abs=0.3)


def test_whole_bytewise_chunked_same(g4):
    b, _ = g4
    data = b"?\rZ1\nfoo\r\nM\rK2.5\r?\r"
    whole = b"".join(G4jntSession(b.rot).receive(data))
    s = G4jntSession(b.rot)
    assert b"".join(r for byte in data for r in s.receive(bytes([byte]))) == whole
    s = G4jntSession(b.rot)
    assert b"".join(r for i in range(0, len(data), 3) for r in s.receive(data[i:i + 3])) == whole
    assert whole.endswith(b"Z1.0 C-50.4 K2.5 M0.1125\r\n")


def test_registry_name(g4):
    b, _ = g4
    assert isinstance(make_session("g4jnt", b.rot), G4jntSession)


# ======================================================================== fuzz
@pytest.fixture(scope="module")
def quiet(tmp_path_factory):
    return Bench("g4jnt", tmp_path_factory.mktemp("g4jnt-fuzz"))


_WORDS = st.sampled_from([b"Z", b"C", b"K", b"M", b"G", b"S", b"?", b"\r", b"\n", b"1", b"-", b".", b",",
                          b"nan", b" "])
_DATA = st.lists(st.one_of(st.binary(max_size=20), _WORDS), max_size=24).map(b"".join)


@settings(max_examples=150, deadline=None)
@given(data=_DATA, split=st.integers(1, 9))
def test_fuzz_never_raises_or_moves(quiet, data, split):
    data = data.replace(b"\x7f", b"").replace(b"\x08", b"")
    assume(not re.search(rb"[Gg]\s*[+-]?[\d.]", data))        # a goto could legitimately move
    s = G4jntSession(quiet.rot)
    replies = []
    for i in range(0, len(data), split):
        replies += s.receive(data[i:i + split])
    assert all(r.endswith(b"\r\n") and r.count(b"\n") == 1 for r in replies)
    assert len(replies) <= data.count(b"\r") + data.count(b"\n") + 1
    quiet.run(1.0)
    st_ = quiet.rot.status()
    assert st_.target_az_deg is None and st_.az.target_deg is None and st_.el.target_deg is None
    assert abs(quiet.truth("az")) < 0.3 and abs(quiet.truth("el")) < 0.3
