"""The extended frame (urc.protocols.poses): poses with their wrap turns and flip, and
single-axis gotos in that frame, on the tartu-urc profile (0..400 az, 0..180 el)."""

from __future__ import annotations

from dataclasses import replace as dc_replace

import pytest

from urc.protocols.poses import ExtendedTarget, extended_pose_deg, frame_offsets_deg
from urc.model.effects import drive
from urc.testing.sessions import fed

TOL_DEG = 0.25


@pytest.fixture
def tartu(bench):
    return bench("tartu-urc")


def test_extended_pose_with_mount_offsets(tartu):
    """An azimuth mount offset of 200 deg: the controller frame is mechanical + 200."""
    st_ = tartu.rot.status()
    az_m, el_m = st_.az.pos_deg, st_.el.pos_deg
    for az_off, el_off, az_m2, el_m2 in ((200.0, 0.0, 150.0, 30.0), (-30.0, 5.0, 10.0, 120.0)):
        ext = az_m2 + az_off
        el_ext = el_m2 + el_off
        flipped = el_ext > 90
        sky_az = (ext + (180 if flipped else 0)) % 360
        sky_el = 180 - el_ext if flipped else el_ext
        fake = dc_replace(st_, az=dc_replace(st_.az, pos_deg=az_m2), el=dc_replace(st_.el, pos_deg=el_m2),
                          az_deg=sky_az, el_deg=sky_el, flipped=flipped, wrap_turns=int(ext // 360))
        if hasattr(fake, "offsets"):
            fake = dc_replace(fake, offsets={})          # the estimate, as without offsets
        assert frame_offsets_deg(fake) == pytest.approx((az_off, el_off))
        assert extended_pose_deg(fake) == pytest.approx((ext, el_ext))
        if hasattr(fake, "offsets"):
            exact = dc_replace(fake, offsets={"az": az_off, "el": el_off})
            assert extended_pose_deg(exact) == pytest.approx((ext, el_ext))
    assert extended_pose_deg(st_) == pytest.approx((az_m, el_m))


def test_single_axis_keeps_the_other_in_the_extended_frame(tartu):
    """380/120 is the overlap, over the top: the service's sky target (200, 60) could
    not say so, and handing it back would unwind and unflip."""
    t = ExtendedTarget(tartu.rot)
    drive(t.goto(380.0, 120.0), t.rotator)
    tartu.settle()
    drive(t.goto(None, 60.0), t.rotator)
    tartu.settle()
    assert (tartu.truth("az"), tartu.truth("el")) == pytest.approx((380.0, 60.0), abs=TOL_DEG)
    drive(t.goto(370.0, None), t.rotator)
    tartu.settle()
    assert (tartu.truth("az"), tartu.truth("el")) == pytest.approx((370.0, 60.0), abs=TOL_DEG)


def test_same_breath_then_stop_then_someone_else(tartu):
    t = ExtendedTarget(tartu.rot)
    drive(t.goto(100.0, None), t.rotator)                     # no target yet: elevation stays (park, 90)
    drive(t.goto(None, 20.0), t.rotator)                      # no tick in between: azimuth 100 holds
    tartu.settle()
    assert (tartu.truth("az"), tartu.truth("el")) == pytest.approx((100.0, 20.0), abs=TOL_DEG)
    drive(t.goto(200.0, 60.0), t.rotator)
    tartu.run(3.0)
    drive(t.stop(), t.rotator)                                # like the service: no target from here on
    drive(t.goto(None, 50.0), t.rotator)                      # azimuth stays where it stopped
    tartu.settle()
    az_stop = tartu.truth("az")
    assert 110.0 < az_stop < 190.0 and tartu.truth("el") == pytest.approx(50.0, abs=TOL_DEG)
    tartu.rot.goto(30.0, 40.0)              # another client: its target counts
    tartu.run(0.1)
    drive(t.goto(None, 10.0), t.rotator)
    tartu.settle()
    assert (tartu.truth("az"), tartu.truth("el")) == pytest.approx((30.0, 10.0), abs=TOL_DEG)


@pytest.mark.parametrize("profile,mech_az", [("bigras", 350.0), ("g5500", 350.0), ("sarcnet-mini", -10.0)])
def test_negative_azimuth_is_one_rule_on_every_protocol(bench, profile, mech_az):
    """Issue 13.7: PstRotator <AZIMUTH>-10 was refused as a limit while rotctld P -10 5
    meant 350. One rule (README): inside the rotator's range -10 names that wrap pose
    (sarcnet-mini: -90..450); beyond it, it is the compass bearing 350."""
    from urc.protocols import make_session
    commands = {"pstrotator": b"<PST><AZIMUTH>-10</AZIMUTH><ELEVATION>5</ELEVATION></PST>",
                "rotctld": b"P -10 5\n"}  # (GS-232 and SPID cannot even write a negative)
    for protocol, line in commands.items():
        b = bench(profile)
        s = make_session(protocol, b.rot)
        replies = fed(s, line)
        assert not any(b"RPRT -" in r or b"?>" in r for r in replies), (protocol, replies)
        st_ = b.settle()
        assert st_.az.pos_deg == pytest.approx(mech_az, abs=1.5), (protocol, st_.az.pos_deg)
        assert st_.az_deg == pytest.approx(350.0, abs=1.5)
    b = bench(profile)
    with pytest.raises(Exception):
        b.rot.goto(-200.0, 5.0)  # beyond -180: refused, nothing moves


def test_gpredict_with_flip_reads_back_what_it_set(bench):
    """Issue 13.6: Gpredict with flip sends the flipped pose (P 10.00 120.00 for the sky
    direction az 190, el 60) and re-sends P whenever p differs from it by more than its
    threshold; p reported the sky direction, 180 deg away, so P went out every cycle.
    The Gpredict loop (protocols.md 1.7): p, compare, P only past the 5 deg threshold."""
    from urc.protocols.rotctld.session import RotctldSession
    b = bench("tartu-urc", rotator={"flip": True})
    s = RotctldSession(b.rot)

    def get() -> tuple[float, float]:
        (reply,) = fed(s, b"p\n")
        az, el = reply.decode().split("\n")[:2]
        return float(az), float(el)
    sent = 0
    for i in range(90):  # a pass near culmination, flipped: az 190 -> 250, el 60 -> 70
        sky_az, sky_el = 190.0 + 0.6 * i, 60.0 + 0.1 * i
        az, el = (sky_az + 180.0) % 360.0, 180.0 - sky_el  # what gpredict sends with flip
        pos = get()
        if abs((az - pos[0] + 180.0) % 360.0 - 180.0) > 5.0 or abs(el - pos[1]) > 5.0:
            assert fed(s, b"P %.2f %.2f\n" % (az, el)) == [b"RPRT 0\n"]
            sent += 1
        b.run(0.8)
    st_ = b.rot.status()
    assert st_.flipped
    # after the first move, a command each time the target moved ~5 deg: ~10, not 90
    assert sent <= 15, sent
    assert get() == pytest.approx(((st_.az_deg + 180.0) % 360.0, 180.0 - st_.el_deg), abs=0.01)
    # unflipped, p is the sky direction as before
    fed(s, b"P 100.00 30.00\n")
    b.settle()
    assert get() == pytest.approx((100.0, 30.0), abs=0.3)
