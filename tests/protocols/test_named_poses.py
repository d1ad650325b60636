"""What a set azimuth means per protocol (README: Angles; issue 21): the controller's
own azimuth names the pose, wrap turn included; a compass bearing takes the nearest turn."""

from __future__ import annotations

import pytest

from conftest import Bench
from urc.protocols import make_session
from urc.wire import spid
from urc.testing.sessions import fed


def at(b: Bench, az_m: float) -> None:
    b.rot.goto_pose(az_m, 45.0)
    b.settle()


def settle_on(b: Bench) -> float:
    b.settle()
    return b.rot.status().az.pos_deg


@pytest.fixture
def tartu(tmp_path):
    return Bench("tartu-urc", tmp_path / "tartu")   # 0..400 deg of azimuth


@pytest.mark.parametrize("protocol, line, start, end", [
    ("gs232b", b"W010 045\r", 360.0, 10.0),          # went on to 370
    ("gs232b", b"W000 045\r", 370.0, 0.0),           # stayed at 360
    ("gs232a", b"M000\r", 370.0, 0.0),
    ("urc", b"GOAZ 5.0\r\n", 370.0, 5.0),
    ("gs232b", b"W370 045\r", 10.0, 370.0),
])
def test_the_controllers_own_azimuth_names_the_pose(tartu, protocol, line, start, end):
    at(tartu, start)
    s = make_session(protocol, tartu.rot)
    fed(s, line)
    assert settle_on(tartu) == pytest.approx(end, abs=1.0)


def test_spid_names_the_pose(tartu):
    at(tartu, 370.0)
    fed(make_session("rot2prog", tartu.rot), spid.encode_rot2_set(0.0, 45.0, 2, 2))
    assert settle_on(tartu) == pytest.approx(0.0, abs=1.0)


@pytest.mark.parametrize("protocol, line, start, end", [
    ("rotctld", b"P 0 45\n", 370.0, 360.0),          # a bearing: the nearest turn
    ("rotctld", b"P 370 45\n", 10.0, 370.0),         # outside 0..360, in the range: the pose
    ("easycomm2", b"AZ10.0 EL45.0\n", 355.0, 370.0),
])
def test_a_compass_bearing_takes_the_nearest_turn(tartu, protocol, line, start, end):
    at(tartu, start)
    fed(make_session(protocol, tartu.rot), line)
    assert settle_on(tartu) == pytest.approx(end, abs=1.0)
