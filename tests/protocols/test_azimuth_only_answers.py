"""Protocols on a single-axis rotator ([rotator] elevation = false): every protocol
answers the elevation queries as azimuth-only originals do (0), turns the azimuth on
two-axis sets, and never moves anything for an elevation-only command (each answering
it in its own form). Judged by the simulator's truth on the virtual clock."""

from __future__ import annotations

import pytest

from urc.protocols import make_session
from urc.testing.sessions import fed, ticked

AZ_ONLY = {"rotator": {"elevation": False}}


@pytest.fixture
def trc(bench):
    b = bench("tartu-urc", **AZ_ONLY)
    b.rot.goto(100.0, 0.0)
    b.settle()
    return b


def still(b, az_deg: float) -> None:
    """Nothing moved: the azimuth stands where it was, no target elsewhere."""
    s = b.run(3.0)
    assert abs(b.truth("az") - az_deg) < 0.3 and not s.moving


def test_rotctld_reads_el_0_refuses_an_elevation_and_turns_the_azimuth(trc):
    s = make_session("rotctld", trc.rot)
    az, el = fed(s, b"p\n")[0].split(b"\n")[:2]
    assert float(az) == pytest.approx(100.0, abs=0.1) and el == b"0.00"
    state = b"".join(fed(s, b"\\dump_state\n")).decode()
    assert "min_el=0.000000\nmax_el=0.000000\n" in state and "rot_type=Az\n" in state
    # Hamlib's rot_set_position refuses an elevation outside min_el..max_el (0..0) of an
    # azimuth-only rotator with -RIG_EINVAL (rotctl -m 1 -C max_el=0 P 100 45:
    # "Invalid parameter"): RPRT -1, nothing moves
    assert fed(s, b"P 200 45\n") == [b"RPRT -1\n"]
    still(trc, 100.0)
    assert fed(s, b"M UP 50\n") == [b"RPRT -1\n"]
    still(trc, 100.0)
    assert fed(s, b"P 200 0\n") == [b"RPRT 0\n"]
    trc.settle()
    assert abs(trc.truth("az") - 200.0) < 0.3
    az, el = fed(s, b"p\n")[0].split(b"\n")[:2]
    assert float(az) == pytest.approx(200.0, abs=0.1) and el == b"0.00"


@pytest.mark.parametrize("proto, c2", [("gs232a", b"+0100+0000\r\n"), ("gs232b", b"AZ=100  EL=000\r\n")])
def test_gs232_c2_reads_el_0_and_elevation_commands_move_nothing(trc, proto, c2):
    s = make_session(proto, trc.rot)
    assert fed(s, b"C2\r") == [c2]
    assert b"".join(fed(s, b"B\r")).strip() in (b"+0000", b"EL=000")
    # the controller cannot tell no elevation rotator is connected: acknowledged as
    # usual (GS-232A: CR, GS-232B: nothing), nothing moves
    ack = [b"\r"] if proto == "gs232a" else []
    for cmd in (b"K045\r", b"EL=045\r", b"U\r", b"MU\r", b"D\r", b"E\r"):
        assert fed(s, cmd) == ack, cmd
    still(trc, 100.0)
    assert fed(s, b"W150 045\r") == ack  # turns the azimuth, the elevation left aside
    trc.settle()
    assert abs(trc.truth("az") - 150.0) < 0.3
    assert fed(s, b"AZ=120 EL=030\r") == ack
    trc.settle()
    assert abs(trc.truth("az") - 120.0) < 0.3


def test_tartu_serves_the_trc_subset_by_default(trc):
    s = make_session("urc", trc.rot)
    help_text = b"".join(fed(s, b"HELP\r\n")).decode()
    assert "GOAZ" in help_text and "GOEL" not in help_text and "RDEL" not in help_text
    for cmd in (b"GOEL 10\r\n", b"RDEL\r\n", b"RDEP\r\n", b"HLTE\r\n", b"LCDC\r\n"):
        assert fed(s, cmd)[0].startswith(b"ERR 1 "), cmd
    assert fed(s, b"RDAZ\r\n") == [b"100.0\r\n"]
    assert fed(s, b"GOAZ 45\r\n") == [b"OK\r\n"]
    trc.settle()
    assert abs(trc.truth("az") - 45.0) < 0.3


def test_tartu_full_set_on_a_single_axis_rotator_answers_err_7(trc):
    s = make_session("urc", trc.rot, variant="urc")
    assert fed(s, b"RDEL\r\n") == [b"000.0\r\n"]
    assert fed(s, b"RDEP\r\n") == [b"0\r\n"]
    for cmd in (b"GOEL 10\r\n", b"WREL 10\r\n", b"OVRE 1\r\n"):
        assert fed(s, cmd)[0].startswith(b"ERR 7 "), cmd
    still(trc, 100.0)
    assert fed(s, b"HLTE\r\n") == [b"OK\r\n"]
    assert fed(s, b"GOAE 130,40\r\n") == [b"OK\r\n"]
    trc.settle()
    assert abs(trc.truth("az") - 130.0) < 0.3


def test_easycomm_reads_el_0_and_ignores_an_elevation_set(trc):
    s = make_session("easycomm2", trc.rot)
    assert fed(s, b"AZ EL\n") == [b"AZ100.0 EL0.0\n"]
    assert fed(s, b"EL45\n") == []
    still(trc, 100.0)
    assert fed(s, b"AZ140.0 EL45.0\n") == []
    trc.settle()
    assert abs(trc.truth("az") - 140.0) < 0.3


def test_spid_reports_el_0_and_ignores_up(trc):
    from urc.wire.spid import K_STATUS, decode_rot2_position, encode_move, encode_query, encode_rot2_set

    s = make_session("md01", trc.rot)
    az, el, _, _ = decode_rot2_position(fed(s, encode_query(K_STATUS))[0])
    assert az == pytest.approx(100.0) and el == pytest.approx(0.0)
    fed(s, encode_move(0x04))  # up: no elevation, no answer form: ignored
    still(trc, 100.0)
    fed(s, encode_rot2_set(160.0, 45.0, 2, 2))
    trc.settle()
    assert abs(trc.truth("az") - 160.0) < 0.3


#: each protocol's elevation-only commands and queries, as its clients send them
ELEVATION_INPUT = {
    "rotctld": [b"p\n", b"P 10 20\n", b"M UP 50\n", b"M DOWN 50\n", b"\\get_info\n", b"S\n"],
    "easycomm1": [b"EL20.0\n", b"AZ10.0 EL20.0 UP000 XXX DN000 XXX\n"],
    "easycomm2": [b"EL\n", b"EL20.0\n", b"MU\n", b"MD\n", b"SE\n", b"AZ EL\n"],
    "easycomm3": [b"EL\n", b"EL20.0\n", b"MU\n", b"MD\n", b"SE\n", b"GS\n", b"GE\n", b"CR0\n"],
    "gs232a": [b"B\r", b"C2\r", b"K020\r", b"U\r", b"D\r", b"E\r"],
    "gs232b": [b"B\r", b"C2\r", b"EL=020\r", b"MU\r", b"MD\r", b"E\r"],
    "gs232": [b"B\r", b"C2\r", b"K020\r", b"U\r", b"D\r"],
    "foxdelta": [b"B\r", b"C2\r", b"K020\r"],
    "urc": [b"RDEL\r\n", b"RDEP\r\n", b"GOEL 20\r\n", b"WREL 20\r\n", b"OVRE\r\n", b"HLTE\r\n", b"LCDC\r\n"],
    "sarcnet": [b"EL20\n", b"AZ EL\n", b"b\n", b"r\n"],
    "g4jnt": [b"G100,20\r", b"S\r"],
}


@pytest.mark.parametrize("protocol", sorted(ELEVATION_INPUT))
def test_every_protocol_takes_elevation_input_without_a_bug_or_a_move(trc, protocol):
    # (the autouse no_session_bugs fixture fails the test if a session hit an exception)
    s = make_session(protocol, trc.rot)
    for cmd in ELEVATION_INPUT[protocol]:
        fed(s, cmd)
        if hasattr(s, "tick"):
            ticked(s, trc.clock.now_s())
    s = trc.run(3.0)
    assert not s.faults and s.el is None
    # sarcnet's r drives home (az 0), g4jnt's G100 turns the azimuth; the others stand
    if protocol not in ("sarcnet", "g4jnt", "rotctld", "easycomm1"):
        assert abs(trc.truth("az") - 100.0) < 0.3
