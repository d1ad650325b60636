"""Every protocol command costs at most one round trip to the control process (issue 19).

A real control process (the simulator) and the RemoteRotator view protocol sessions get
in ``urc run``; the link's requests are counted as they are sent. Tartu RDAP/RDEP, the
G4JNT constants and stream, and SARCNET's calibration commands reach the hardware: each
is one typed query now (they were 2-5 round trips of attribute paths).
"""

from __future__ import annotations


import pytest

from urc.protocols.registry import make_session
from urc.testing.sessions import fed, ticked

#: (profile, protocol, commands): every command of the session, each sent alone
CASES = {
    "tartu": ("tartu-urc", "urc", [
        b"VERS", b"HELP", b"BAUD", b"ECHO", b"RDAZ", b"RDEL", b"RDAP", b"RDEP", b"GOAZ 10", b"GOEL 20",
        b"GOAE 15,25", b"OVRA", b"OVRA 0.5", b"OVRE", b"HLTA", b"HLTE", b"HALT", b"WRAZ 15", b"WREL 25",
        b"LCDC", b"LCDC 40", b"XYZZY"]),
    "g4jnt": ("g4jnt", "g4jnt", [
        b"?", b"#Z1807", b"#M-15897", b"#C3758", b"?", b"#K2048", b"G100", b"L", b"R", b"S", b"Q"]),
    "sarcnet": ("sarcnet-mini", "sarcnet", [
        b"r", b"e", b"e 10.0", b"h", b"m", b"a", b"b", b"a", b"10 20", b"p", b"p", b"AZ EL", b"AZ30 EL20", b"SA SE",
        b"c", b"a", b"c", b"s", b"a", b"d", b"a"]),
}


@pytest.fixture(params=sorted(CASES))
def counted(start_control, request):
    profile, protocol, commands = CASES[request.param]
    _proc, rot = start_control(profile)
    sent: list[str] = []
    link = rot._link
    real_send = link.send

    def send(msg: tuple) -> None:
        if msg[0] == "request":
            sent.append(type(msg[1].request).__name__)
        real_send(msg)
    link.send = send
    return make_session(protocol, rot.for_sessions()), commands, sent


def test_each_protocol_command_costs_at_most_one_round_trip(counted):
    session, commands, sent = counted
    costs = {}
    for command in commands:
        before = len(sent)
        replies = fed(session, command + b"\r")
        costs[command] = sent[before:]
        if getattr(session, "wants_tick", False):  # (a stream line: one query at most too)
            before = len(sent)
            ticked(session, 1e9 + len(costs))
            assert len(sent) - before <= 1, (command, "tick", sent[before:])
        assert replies is not None
    over = {c.decode(): names for c, names in costs.items() if len(names) > 1}
    assert not over, over
    assert any(costs.values())  # (the count sees the link: some commands do reach it)


def test_a_hardware_query_is_one_typed_request(counted):
    session, commands, sent = counted
    first = {"tartu": b"RDAP", "g4jnt": b"?", "sarcnet": b"e"}
    name = type(session).__name__.lower()
    command = next(v for k, v in first.items() if k in name)
    fed(session, command + b"\r")
    assert len(sent) == 1 and sent[0] in ("SensorCount", "PotState", "SensorCalibrations"), sent
