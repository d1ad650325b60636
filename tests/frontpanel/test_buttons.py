"""Push-buttons on emulated pins (gpiozero MockFactory) jogging a simulated rotator on
the virtual clock, through the rotator's command gate."""

from __future__ import annotations

import pytest

from urc.errors import CommandRejected
from urc.protocols.tartu import TartuSession


def test_cw_held_jogs_and_release_stops(panel_rig):
    rig = panel_rig()
    rig.settle()
    az0 = rig.rot.status().az.pos_deg
    rig.press("cw")
    st = rig.run(3.0)
    assert st.az.pos_deg > az0 + 5.0, "held CW turns the azimuth clockwise"
    assert rig.led("cw") and not rig.led("ccw"), "the CW direction LED is lit while driving"
    rig.release("cw")
    st = rig.settle()
    stopped_at = st.az.pos_deg
    assert not rig.led("cw")
    st = rig.run(3.0)
    assert abs(st.az.pos_deg - stopped_at) < 0.5, "released: the axis stays stopped"
    # it stopped within a braking distance of where the button came up, not at a limit
    assert stopped_at < st.limits["az"][1] - 10.0


def test_up_down_jog_elevation(panel_rig):
    rig = panel_rig()
    rig.settle()
    el0 = rig.rot.status().el.pos_deg
    rig.press("down")
    st = rig.run(2.0)
    assert st.el.pos_deg < el0 - 2.0 and rig.led("down")
    rig.release("down")
    rig.press("up")
    rig.release("up")  # a tap: starts and stops again
    st = rig.settle()
    assert st.el.target_deg is not None or st.el.mode in ("holding", "idle")


def test_slow_button_jogs_slower(panel_rig):
    rig = panel_rig()
    rig.settle()
    rig.press("cw")
    fast = rig.run(3.0).az.rate_deg_per_s
    rig.release("cw")
    rig.settle()
    rig.press("slow")
    rig.press("cw")
    slow = rig.run(3.0).az.rate_deg_per_s
    rig.release("cw")
    rig.release("slow")
    assert 0 < slow < 0.5 * fast


def test_local_operator_wins_over_protocol_client_until_released(panel_rig):
    rig = panel_rig()
    rig.rot.goto(100.0, 30.0)
    rig.settle()
    tartu = TartuSession(rig.rot)
    rig.press("ccw")
    rig.run(1.0)
    # a protocol client's motion is refused on the wire, with the reason
    reply = b"".join(tartu.receive(b"GOAZ 200\r\n")).decode()
    assert reply.startswith("ERR") and "local control active" in reply and "CCW button" in reply
    with pytest.raises(CommandRejected) as exc:
        rig.rot.goto(200.0, 10.0)
    assert exc.value.reason == "local"
    with pytest.raises(CommandRejected):
        rig.rot.move("az", 1)
    with pytest.raises(CommandRejected):
        rig.rot.park()
    with pytest.raises(CommandRejected):
        rig.rot.set_position(az_deg=10.0)
    assert rig.rot.status().local_control == ("CCW button",)
    st = rig.run(1.0)
    assert st.az.rate_deg_per_s < 0, "the jog goes on: the client's goto did not take over"
    rig.release("ccw")
    rig.settle()
    assert rig.rot.status().local_control == ()
    # released: the client commands again
    reply = b"".join(tartu.receive(b"GOAZ 20\r\n")).decode()
    assert reply.strip() == "OK", reply
    st = rig.settle()
    assert abs(st.az.pos_deg - 20.0) < 1.0


def test_stop_from_anyone_is_accepted_while_held(panel_rig):
    rig = panel_rig()
    rig.settle()
    rig.press("cw")
    rig.run(1.0)
    rig.rot.stop()  # a client's stop: always accepted
    st = rig.settle()
    assert st.az.mode in ("holding", "idle")
    st2 = rig.run(2.0)
    assert abs(st2.az.pos_deg - st.az.pos_deg) < 0.5, "the client's stop holds even with CW still down"
    rig.release("cw")


def test_stop_button_stops_a_remote_goto(panel_rig):
    rig = panel_rig()
    rig.settle()
    rig.rot.goto(300.0, 30.0)
    rig.run(2.0)
    assert rig.rot.status().moving
    rig.press("stop")
    rig.release("stop")
    st = rig.settle()
    assert abs(st.az.pos_deg - 300.0) > 50.0, "stopped on its way, not at the target"


def test_park_button_parks(panel_rig):
    rig = panel_rig()
    rig.rot.goto(90.0, 30.0)
    rig.settle()
    rig.press("park")
    assert rig.rot.local_controls() == ("PARK button",)
    rig.release("park")
    st = rig.run(120.0, until=lambda s: s.parked)
    assert st.parked
