"""The extended frame (urc.protocols.poses): poses with their wrap turns and flip, and
single-axis gotos in that frame, on the tartu-urc profile (0..400 az, 0..180 el)."""

from __future__ import annotations

from dataclasses import replace as dc_replace

import pytest

from urc.protocols.poses import ExtendedTarget, extended_pose_deg, frame_offsets_deg

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
    t.goto(380.0, 120.0)
    tartu.settle()
    t.goto(None, 60.0)
    tartu.settle()
    assert (tartu.truth("az"), tartu.truth("el")) == pytest.approx((380.0, 60.0), abs=TOL_DEG)
    t.goto(370.0, None)
    tartu.settle()
    assert (tartu.truth("az"), tartu.truth("el")) == pytest.approx((370.0, 60.0), abs=TOL_DEG)


def test_same_breath_then_stop_then_someone_else(tartu):
    t = ExtendedTarget(tartu.rot)
    t.goto(100.0, None)                     # no target yet: elevation stays (park, 90)
    t.goto(None, 20.0)                      # no tick in between: azimuth 100 holds
    tartu.settle()
    assert (tartu.truth("az"), tartu.truth("el")) == pytest.approx((100.0, 20.0), abs=TOL_DEG)
    t.goto(200.0, 60.0)
    tartu.run(3.0)
    t.stop()                                # like the service: no target from here on
    t.goto(None, 50.0)                      # azimuth stays where it stopped
    tartu.settle()
    az_stop = tartu.truth("az")
    assert 110.0 < az_stop < 190.0 and tartu.truth("el") == pytest.approx(50.0, abs=TOL_DEG)
    tartu.rot.goto(30.0, 40.0)              # another client: its target counts
    tartu.run(0.1)
    t.goto(None, 10.0)
    tartu.settle()
    assert (tartu.truth("az"), tartu.truth("el")) == pytest.approx((30.0, 10.0), abs=TOL_DEG)
