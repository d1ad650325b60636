"""Push-buttons on emulated pins (gpiozero MockFactory) jogging a simulated rotator on
the virtual clock, through the rotator's command gate."""

from __future__ import annotations

import pytest

from urc.errors import CommandRejected
from urc.protocols.tartu import TartuSession
from urc.protocols.tartu_codec import lcd_rows
from urc.testing.sessions import fed


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


def test_a_lost_release_stops_the_jog_when_the_button_reads_up(panel_rig):
    """Review 20 #7: the release's callback never comes (a report lgpio dropped, a
    failed callback); the panel's update sees the button up and releases the jog
    instead of jogging on to the end of travel."""
    rig = panel_rig()
    rig.settle()
    rig.press("cw")
    assert rig.run(2.0).az.rate_deg_per_s > 1.0
    real = rig.panel.dispatch
    rig.panel.dispatch = lambda fn, *args: None      # the release report is lost
    rig.release("cw")
    rig.panel.dispatch = real
    rig.run(0.05)
    assert rig.panel.controls.held("cw")              # not cut at once (a bounce would be)
    st = rig.settle()
    stopped_at = st.az.pos_deg
    assert not rig.panel.controls.held("cw")
    st = rig.run(3.0)
    assert abs(st.az.pos_deg - stopped_at) < 0.5 and stopped_at < st.limits["az"][1] - 10.0


def test_a_raising_button_callback_never_reaches_the_pin_thread(panel_rig):
    """Review 20 #7: dispatch raises once the event loop is closed; on a Pi the callback
    runs on lgpio's one notification thread, which an exception would end."""
    rig = panel_rig()

    def closed_loop(fn, *args):
        raise RuntimeError("Event loop is closed")
    rig.panel.dispatch = closed_loop
    rig.press("cw")                                   # the mock pin calls back right here
    rig.release("cw")
    assert rig.panel.callback_errors == 2


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
    reply = b"".join(fed(tartu, b"GOAZ 200\r\n")).decode()
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
    reply = b"".join(fed(tartu, b"GOAZ 20\r\n")).decode()
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


def test_rotctld_client_gets_rejected_while_held(panel_rig):
    from urc.protocols.rotctld.session import RotctldSession

    rig = panel_rig()
    rig.rot.goto(100.0, 30.0)
    rig.settle()
    rotctld = RotctldSession(rig.rot)
    rig.press("up")
    assert b"".join(fed(rotctld, b"P 150 20\n")) == b"RPRT -9\n"  # RIG_ERJCTED
    assert b"".join(fed(rotctld, b"S\n")) == b"RPRT 0\n"          # stop: accepted
    rig.release("up")
    assert b"".join(fed(rotctld, b"P 150 20\n")) == b"RPRT 0\n"


def test_run_panel_carries_pin_callbacks_onto_the_event_loop(bench):
    """Under urc run, gpiozero calls back on lgpio's thread; the panel hands each press
    to the event loop (where protocol sessions talk to the rotator) and refreshes the
    display from a worker thread."""
    import asyncio
    import threading

    from gpiozero.pins.mock import MockFactory

    from urc.frontpanel.lcd import CharLcd, Pcf8574Hd44780
    from urc.frontpanel.panel import FrontPanel, run_panel

    b = bench()
    b.rot.goto(100.0, 30.0)
    b.settle()
    factory = MockFactory()
    chip = Pcf8574Hd44780(0x27, 20, 2)
    threads = []
    real_move = b.rot.move

    def move(*args, **kw):
        threads.append(threading.get_ident())
        return real_move(*args, **kw)
    b.rot.move = move

    async def main():
        loop = asyncio.get_running_loop()
        panel = FrontPanel(b.rot, pin_factory=factory, buttons={"cw": 5}, display=CharLcd(chip, 0x27, 20, 2),
                           dispatch=lambda fn, *a: loop.call_soon_threadsafe(fn, *a))
        panel.power_on()
        stop = asyncio.Event()
        task = asyncio.create_task(run_panel(panel, stop, refresh_hz=20.0))
        pin_thread = threading.Thread(target=factory.pin(5).drive_low)
        pin_thread.start()
        pin_thread.join()
        await asyncio.sleep(0.3)
        stop.set()
        await task
        shown.extend(chip.text())
        panel.close()
        return threading.get_ident()

    shown: list[str] = []
    loop_thread = asyncio.run(main())
    assert threads == [loop_thread], "the press ran on the event loop's thread"
    assert shown == lcd_rows(b.rot.status())  # (no tick ran: the status is the settled one)
    assert b.rot.local_controls() == (), "closing the panel released the button's hold"


def test_urc_status_says_which_local_control_is_held(panel_rig):
    from urc.status_text import format_status as _format_status

    rig = panel_rig()
    rig.press("stop")
    st = rig.run(0.1)
    assert "LOCAL     STOP button held at the rotator" in _format_status(st.as_dict())
    rig.release("stop")
    assert "LOCAL" not in _format_status(rig.run(0.1).as_dict())


def test_tracking_gives_way_to_the_panel_and_resumes_on_release(panel_rig, tmp_path):
    """The tracker is a source like any other: its updates are refused while a button
    is held (its status says why) and it takes over again once released."""
    from urc.config import Config
    from urc.tracking.service import TrackingService

    rig = panel_rig()
    cfg = Config.from_dict({"station": {"lat_deg": 58.378, "lon_deg": 26.729, "alt_m": 70},
                            "tracking": {"catalog_dir": str(tmp_path / "cat")}})
    svc = TrackingService(rig.rot, cfg, unix_at=lambda now_s: 1.7e9 + now_s)
    svc.track_sync({"kind": "azel", "az_deg": 200.0, "el_deg": 30.0})
    step = lambda s: svc.step_sync(s.t_s)  # noqa: E731
    st = rig.run(60.0, on_tick=step, until=lambda s: abs(s.az.pos_deg - 200.0) < 0.5 and not s.moving)
    assert abs(st.az.pos_deg - 200.0) < 0.5
    rig.press("ccw")
    st = rig.run(3.0, on_tick=step)
    assert st.az.pos_deg < 195.0, "the operator's jog wins over the tracker"
    assert "local control active" in (svc.tracker.last_error or "")
    rig.release("ccw")
    st = rig.run(30.0, on_tick=step, until=lambda s: abs(s.az.pos_deg - 200.0) < 0.5 and not s.moving)
    assert abs(st.az.pos_deg - 200.0) < 0.5, "released: the tracker took over again"


@pytest.mark.parametrize("name, line, says", [
    ("urc", b"GOAZ 200\r\n", b"local control active (CCW button held at the rotator)"),
    ("sarcnet", b"200 10\r", b"Error: refused: local control active (CCW button held at the rotator)"),
    ("rotctld", b"P 200 10\n", b"RPRT -"),       # Hamlib's reply carries a code, no text
    ("gs232b", b"W200 010\r", b"?>"),
])
def test_protocols_refuse_during_a_held_button_and_say_why_where_they_can(panel_rig, name, line, says):
    from urc.protocols import make_session

    rig = panel_rig()
    rig.settle()
    session = make_session(name, rig.rot)
    rig.press("ccw")
    rig.run(0.5)
    reply = b"".join(fed(session, line))
    assert says in reply, reply
    rig.release("ccw")
    st = rig.settle()
    assert st.target_az_deg is None or abs(st.target_az_deg - 200.0) > 1.0, "the refused move did not happen"
