"""The bridge's client engine and dialects, sans-I/O: what goes on the wire when, and
what an answer does (nothing, when it is not fully understood)."""

from __future__ import annotations

import pytest

from urc.errors import SensorError
from urc.hardware.bridge import BRIDGE_PROTOCOLS, BridgeClient, ClientOptions, make_dialect
from urc.protocols.registry import PROTOCOLS
from urc.hardware.bridge.dialects import Reply
from urc.wire import spid
from urc.testing.sessions import fed

#: the protocols urc also serves as a controller (a device session to bridge to); the
#: SatNOGS firmware's dialect is tested against its own emulation (test_bridge_satnogs.py)
URC_SPEAKS = [p for p in BRIDGE_PROTOCOLS if p in PROTOCOLS]


def connected(protocol: str, pos: bytes, options: ClientOptions | None = None, now_s: float = 0.0):
    """A client whose link is up and whose first poll was answered with ``pos``."""
    c = BridgeClient(make_dialect(protocol), options)
    c.link_up(now_s)
    ex, _ = c.next_exchange(now_s)
    assert ex.kind == "poll"
    c.answered(ex, pos, now_s, now_s + 0.01)
    return c


GS232B_POS = b"AZ=100  EL=020\r"


def test_reply_framing_one_byte_at_a_time():
    """Each framing completes exactly at its last byte, never before."""
    cases = [(Reply(terminator=b"\r"), GS232B_POS),
             (Reply(terminator=b"\n", lines=2, stop_line=b"RPRT"), b"10.00\n20.00\n"),
             (Reply(terminator=b"\n", lines=2, stop_line=b"RPRT"), b"RPRT -1\n"),
             (Reply(length=12), spid.encode_rot2_position(10.0, 20.0, 2, 2))]
    for reply, data in cases:
        for i in range(len(data)):
            assert reply.complete(data[:i]) is None, (data, i)
        assert reply.complete(data + b"junk") == len(data)


@pytest.mark.parametrize("protocol", URC_SPEAKS)
def test_every_dialect_round_trips_through_urcs_own_codec(protocol):
    """What the client sends, urc's device session understands (one codec, two ends)."""
    from urc.protocols.registry import make_session

    class Rot:
        def __init__(self):
            self.calls = []

        def status(self):
            from types import SimpleNamespace
            ax = SimpleNamespace(pos_deg=0.0, target_deg=None, mode="idle", rate_deg_per_s=0.0, duty=0.0,
                                 limit_min=False, limit_max=False)
            return SimpleNamespace(t_s=0.0, az_deg=0.0, el_deg=0.0, az=ax, el=ax, offsets={"az": 0.0, "el": 0.0},
                                   limits={"az": (0.0, 450.0), "el": (0.0, 90.0)}, moving=False, faults=(),
                                   target_az_deg=None, target_el_deg=None, flipped=False, wrap_turns=0,
                                   position_known=True)

        def goto(self, az, el):
            self.calls.append(("goto", round(az, 2), None if el is None else round(el, 2)))
            return []

        def goto_pose(self, az_m, el_m):
            # (a protocol speaking the controller's own azimuth names the pose; the
            # offsets here are 0, so it is the same angle)
            self.calls.append(("goto", round(az_m, 2), round(el_m, 2)))
            return []

        def stop(self, axis=None):
            self.calls.append(("stop", axis))

    rot = Rot()
    session = make_session(protocol, rot)
    d = make_dialect(protocol)
    d.resolution_deg = tuple(min(r, 0.5) for r in d.resolution_deg)
    fed(session, d.goto(123.0, 45.0).request)
    fed(session, d.stop().request)
    assert rot.calls[0][:2] == ("goto", 123.0), rot.calls
    assert rot.calls[0][2] == 45.0 or not d.has_el, rot.calls   # Rot1Prog: el keeps its own
    assert rot.calls[-1][0] == "stop", rot.calls


def test_targets_are_sent_once_per_controller_step():
    c = connected("gs232b", GS232B_POS)
    sent = []
    for i, az in enumerate((150.2, 150.4, 149.6, 150.0, 151.4)):
        c.post("az", az)
        c.post("el", 20.0)
        ex, _ = c.next_exchange(1.0 + i)
        if ex.kind == "set":
            sent.append(ex.request)
            ex, _ = c.next_exchange(1.0 + i)   # a poll always follows a set
            assert ex.kind == "poll"
        c.answered(ex, GS232B_POS, 1.0 + i, 1.01 + i) if ex.kind == "poll" else None
    assert sent == [b"W150 020\r", b"W151 020\r"], sent


def test_a_garbage_answer_blocks_targets_until_a_good_report():
    c = connected("gs232b", GS232B_POS)
    c.post("az", 200.0)
    c.post("el", 30.0)
    ex, _ = c.next_exchange(1.0)
    assert ex.kind == "set"
    ex, _ = c.next_exchange(1.0)
    c.answered(ex, b"AZ=1x0 ??\r", 1.0, 1.01)           # not understood
    c.post("az", 250.0)
    for t in (2.0, 3.0):
        ex, _ = c.next_exchange(t)
        assert ex.kind == "poll", ex                    # no set on a reply urc did not understand
        if t == 2.0:
            c.timed_out(ex, b"", t + 0.4)
    assert c.reading("az") == 100.0                      # the last good report, not garbage
    c.answered(ex, b"AZ=120  EL=025\r", 3.0, 3.01)
    ex, _ = c.next_exchange(4.0)
    assert ex.kind == "set" and ex.request == b"W250 030\r"


def test_repeated_failures_break_the_link_and_a_stop_goes_first_after_reconnect():
    c = connected("rotctld", b"10.00\n20.00\n", ClientOptions(max_failures=3))
    c.post("az", 50.0)
    c.post("el", 30.0)
    for t in range(3):
        ex, _ = c.next_exchange(float(t + 1))
        c.timed_out(ex, b"", t + 1.5)
    assert c.link_broken()
    c.link_down("3 missing answers", 5.0)
    with pytest.raises(SensorError, match="link lost"):
        c.reading("az", 5.0)
    c.link_up(6.0)
    ex, _ = c.next_exchange(6.0)
    assert ex.request == b"S\n"


def test_stop_before_set_for_controllers_that_ignore_targets_while_moving():
    c = connected("gs232a", b"+0100+0020\r\n", ClientOptions(stop_before_set=True))
    c.post("az", 200.0)
    c.post("el", 20.0)
    ex, _ = c.next_exchange(1.0)
    assert ex.request == b"W200 020\r"
    for t, pos in ((1.1, b"+0110+0020\r\n"), (1.2, b"+0120+0020\r\n")):
        ex, _ = c.next_exchange(t)
        c.answered(ex, pos, t, t + 0.01)
    c.post("az", 100.0)                                    # reversed while it moves
    ex1, _ = c.next_exchange(1.5)
    ex2, _ = c.next_exchange(1.5)
    ex3, _ = c.next_exchange(1.8)
    c.answered(ex2, b"+0121+0020\r\n", 1.5, 1.51)
    assert ex1.request == b"S\r" and ex2.kind == "poll" and ex3.request == b"W100 020\r", (ex1, ex2, ex3)


def test_stop_before_set_while_whole_degree_reports_repeat():
    """Polled every 40 ms, a GS-232 turning at 10 deg/s reports the same whole degree
    twice in a row: it is still moving towards its target (a set sent then was ignored)."""
    c = connected("gs232b", b"AZ=100  EL=020\r", ClientOptions(stop_before_set=True))
    c.post("az", 200.0)
    c.post("el", 20.0)
    ex, _ = c.next_exchange(1.0)
    assert ex.request == b"W200 020\r"
    for t, pos in ((1.04, b"AZ=110  EL=020\r"), (1.08, b"AZ=110  EL=020\r")):
        ex, _ = c.next_exchange(t)
        c.answered(ex, pos, t, t + 0.01)
    c.post("az", 100.0)
    ex, _ = c.next_exchange(1.3)
    assert ex.request == b"S\r", ex


def test_spid_learns_the_controllers_resolution():
    c = connected("rot2prog", spid.encode_rot2_position(10.0, 20.0, 4, 4))
    assert c.dialect.resolution_deg == (0.25, 0.25)
    c.post("az", 100.13)
    c.post("el", 30.0)
    ex, _ = c.next_exchange(1.0)
    cmd = spid.decode_command(ex.request, "rot2", (4, 4))
    assert (cmd.az_deg, cmd.el_deg) == (100.25, 30.0)      # nearest quarter degree


def test_reading_extrapolates_but_never_past_the_target():
    c = BridgeClient(make_dialect("easycomm3"))
    c.link_up(0.0)
    t = 0.1
    for az in (10.0, 11.0, 12.0, 13.0):     # 10 deg/s, a report every 0.1 s
        ex, _ = c.next_exchange(t)
        if ex.kind != "poll":
            ex, _ = c.next_exchange(t)
        c.answered(ex, b"AZ%.1f EL5.0\n" % az, t, t)
        if az == 10.0:
            c.post("az", 14.0)
            c.post("el", 5.0)
        t += 0.1
    assert c.reading("az", 0.45) == pytest.approx(13.5, abs=0.01)
    assert c.reading("az", 0.9) == 14.0                    # the controller stops at its target
    with pytest.raises(SensorError, match="no position report"):
        c.reading("az", 100.0)


def test_compass_azimuth_flicker_across_north_is_no_motion():
    """rotctld and Easycomm report 0..360: 359.9 then 0.1 must not extrapolate a
    -359.8 deg move (a 50 deg 'jump' latched a fault at start-up)."""
    c = BridgeClient(make_dialect("easycomm3"))
    c.link_up(0.0)
    t = 0.1
    for az in (359.9, 0.1, 359.9, 0.1):
        ex, _ = c.next_exchange(t)
        c.answered(ex, b"AZ%.1f EL5.0\n" % az, t, t)
        t += 0.1
    assert c.reading("az", t) == pytest.approx(0.1, abs=0.1)


def _report(c: BridgeClient, t: float, az: float, el: float) -> None:
    ex, _ = c.next_exchange(t)
    while ex is None or ex.kind != "poll":
        t += 0.05
        ex, _ = c.next_exchange(t)
    c.answered(ex, b"AZ%.1f EL%.1f\n" % (az, el), t, t)


def test_sky_frame_reports_are_unfolded_over_the_top():
    """urc's Easycomm reports a flipped antenna (mechanical az 308, el 110) as the sky
    direction it points to (128, 70): the bridge keeps the side of the zenith by
    continuity, also right at the top where the two poses lie 180 deg apart."""
    c = BridgeClient(make_dialect("easycomm3"), ClientOptions(over_top=True))
    c.link_up(0.0)
    t = 0.1
    for mech_el in (80.0, 88.0, 89.9, 90.1, 95.0, 110.0):   # rising over the top at az 308
        sky = (308.0, mech_el) if mech_el <= 90.0 else (128.0, 180.0 - mech_el)
        _report(c, t, *sky)
        assert (c.reading("az"), c.reading("el")) == pytest.approx((308.0, mech_el), abs=0.06), mech_el
        t += 0.2
    assert c.over_top()
    # a controller reporting its mechanical frame (Hamlib behind a GS-232) stays as it is
    m = BridgeClient(make_dialect("rotctld"), ClientOptions(over_top=True))
    m.link_up(0.0)
    ex, _ = m.next_exchange(0.0)
    m.answered(ex, b"308.00\n110.00\n", 0.0, 0.01)
    assert (m.reading("az"), m.reading("el")) == (308.0, 110.0)
    # a rotator that cannot flip: reports are never unfolded
    n = BridgeClient(make_dialect("easycomm3"))
    n.link_up(0.0)
    _report(n, 0.1, 128.0, 70.0)
    assert (n.reading("az"), n.reading("el")) == (128.0, 70.0)


def test_the_saved_side_of_the_zenith_turns_the_first_report_over():
    """After a restart a sky-frame report cannot tell the side: the state record keeps it
    (the el axis' calibration dict), and the reports already in are turned over."""
    from urc.clock import VirtualClock
    from urc.hardware.bridge import bridge_axes

    c = BridgeClient(make_dialect("easycomm3"), ClientOptions(over_top=True))
    az, el = bridge_axes(c, VirtualClock(0.0))
    c.link_up(0.0)
    _report(c, 0.1, 128.0, 70.0)
    assert el.sensor.calibration() == {}
    el.sensor.load_calibration({"over_top": True})
    assert (az.sensor.read_deg(), el.sensor.read_deg()) == pytest.approx((308.0, 110.0))
    assert el.sensor.calibration() == {"over_top": True}
    _report(c, 0.5, 127.0, 71.0)         # and continuity carries it on
    assert (c.reading("az"), c.reading("el")) == pytest.approx((307.0, 109.0))


def test_a_jog_runs_the_controllers_own_move_and_stops_it_on_an_answer_not_understood():
    c = connected("gs232b", b"AZ=100  EL=020\r")
    c.post("el", 20.0)
    c.post_move("az", 300.0, 0.5, 2.0)
    ex, _ = c.next_exchange(1.0)
    assert ex.kind == "move" and ex.request == b"X2\rR\r"
    ex, _ = c.next_exchange(1.1)
    assert ex.kind == "poll"
    c.answered(ex, b"AZ=101  EL=020\r", 1.1, 1.11)
    c.post_move("az", 300.0, 0.5, 2.0)             # posted again every tick: no new move
    ex, _ = c.next_exchange(1.2)
    assert ex.kind == "poll"
    c.answered(ex, b"\x00garbage\r", 1.2, 1.21)
    ex, _ = c.next_exchange(1.3)
    assert ex.request == b"S\r"                      # not left running unwatched


def test_a_jog_near_its_end_or_without_a_move_command_is_a_goto():
    c = connected("gs232b", b"AZ=297  EL=020\r")
    c.post("el", 20.0)
    c.post_move("az", 300.0, 0.5, 2.0)              # 3 deg to go: too near to start a move
    ex, _ = c.next_exchange(1.0)
    assert ex.request == b"W300 020\r"
    s = connected("rot2prog", spid.encode_rot2_position(100.0, 20.0, 2, 2))
    s.post("el", 20.0)
    s.post_move("az", 300.0, 0.5, 2.0)
    ex, _ = s.next_exchange(1.0)
    assert ex.kind == "set" and ex.pose == (300.0, 20.0)


def test_an_md01_jog_is_its_own_move_after_a_stop_and_is_stopped_before_the_goto_ends_it():
    """MD-01/02 (Hamlib 903): a stop, then the K 0x14 frame with the direction bits
    (no speed, no answer); near the jog's end a stop again, then the goto. Rot2Prog has
    no move: it jogs by goto (above)."""
    c = connected("md01", spid.encode_rot2_position(100.0, 20.0, 2, 2))
    c.post("el", 20.0)
    c.post_move("az", 300.0, 0.5, 2.0)
    ex, _ = c.next_exchange(1.0)
    assert ex.kind == "stop" and ex.request == spid.encode_query(spid.K_STOP)
    c.answered(ex, spid.encode_rot2_position(100.0, 20.0, 2, 2), 1.0, 1.01)
    ex, _ = c.next_exchange(1.4)
    assert ex.kind == "poll"
    c.answered(ex, spid.encode_rot2_position(100.0, 20.0, 2, 2), 1.4, 1.41)
    ex, _ = c.next_exchange(1.8)
    assert ex.kind == "move" and ex.reply is None
    assert ex.request == spid.encode_move(spid.DIR_RIGHT, (2, 2))
    c.sent(ex, 1.81)
    ex, _ = c.next_exchange(2.2)
    assert ex.kind == "poll"
    c.answered(ex, spid.encode_rot2_position(299.0, 20.0, 2, 2), 2.2, 2.21)   # near its end
    c.post_move("az", 300.0, 0.5, 2.0)
    ex, _ = c.next_exchange(2.6)
    assert ex.kind == "stop"
    c.answered(ex, spid.encode_rot2_position(299.0, 20.0, 2, 2), 2.6, 2.61)
    ex, _ = c.next_exchange(3.0)
    assert ex.kind == "poll"
    c.answered(ex, spid.encode_rot2_position(299.0, 20.0, 2, 2), 3.0, 3.01)
    ex, _ = c.next_exchange(3.4)
    assert ex.kind == "set" and ex.pose == (300.0, 20.0)
    assert c.counts["moves"] == 1
