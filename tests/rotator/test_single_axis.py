"""A single-axis rotator ([rotator] elevation = false) as a first-class configuration:
the TRC turntable (seed 000), BIG-RAS with "Elevation: OFF" (seed 002), an HF beam."""

from __future__ import annotations

import pytest

from urc.config import Config
from urc.errors import CommandRejected, ConfigError

AZ_ONLY = {"rotator": {"elevation": False}}


def test_status_says_elevation_is_absent(bench):
    b = bench("tartu-urc", **AZ_ONLY)
    s = b.rot.status()
    assert s.axes == ("az",) and not s.has_el
    assert s.el is None and s.el_deg is None and s.target_el_deg is None  # not a fake 0
    assert "el" not in s.limits and s.as_dict()["axes"] == ["az"]
    assert b.rot.hw.el is None and set(b.rot.axes) == {"az"}


def test_a_two_axis_goto_moves_the_azimuth_and_leaves_the_elevation_aside(bench):
    b = bench("tartu-urc", **AZ_ONLY)
    el0 = b.truth("el")
    b.rot.goto(123.0, 45.0)
    s = b.settle()
    assert s.az_deg == pytest.approx(123.0, abs=0.2) and s.el_deg is None
    assert b.truth("az") == pytest.approx(123.0, abs=0.3)
    assert b.truth("el") == el0  # nothing drove the elevation joint


@pytest.mark.parametrize("command", [
    lambda r: r.goto_el(30.0), lambda r: r.move("el", 1), lambda r: r.set_position(el_deg=10.0),
    lambda r: r.set_overshoot("el", 1.0)])
def test_elevation_commands_are_refused_and_move_nothing(bench, command):
    b = bench("tartu-urc", **AZ_ONLY)
    b.rot.goto(60.0, 0.0)
    b.run(1.0)
    with pytest.raises(CommandRejected) as exc:
        command(b.rot)
    assert exc.value.reason == "no_axis"
    s = b.settle()
    assert s.az_deg == pytest.approx(60.0, abs=0.2)  # the azimuth goto went on unharmed


def test_stop_el_is_harmless_and_stop_stops_the_azimuth(bench):
    b = bench("tartu-urc", **AZ_ONLY)
    b.rot.goto(200.0, 0.0)
    b.run(2.0)
    b.rot.stop("el")  # no such axis: nothing to stop, the azimuth keeps going
    s = b.settle()
    assert s.az_deg == pytest.approx(200.0, abs=0.2)
    b.rot.goto(20.0, 0.0)
    b.run(2.0)
    b.rot.stop()
    s = b.settle()
    assert 40.0 < s.az_deg < 190.0


def test_nan_elevation_in_a_goto_is_still_bad_input(bench):
    b = bench("tartu-urc", **AZ_ONLY)
    with pytest.raises(CommandRejected) as exc:
        b.rot.goto(10.0, float("nan"))
    assert exc.value.reason == "invalid"


def test_limits_and_keep_out_zones_still_guard_the_azimuth(bench):
    # the beam of a single-axis rotator stands at the horizon: a zone reaching down to
    # el 0 (a mast) blocks its azimuth sector, one above the horizon does not
    b = bench("tartu-urc", **AZ_ONLY, limits={"az": {"max_deg": 300.0}},
              keepout=[{"name": "mast", "az_min_deg": 100, "az_max_deg": 140, "el_min_deg": 0, "el_max_deg": 20},
                       {"name": "sky", "az_min_deg": 40, "az_max_deg": 60, "el_min_deg": 10, "el_max_deg": 30}])
    with pytest.raises(CommandRejected) as exc:
        b.rot.goto(120.0, 0.0)
    assert exc.value.reason == "keepout"
    with pytest.raises(CommandRejected) as exc:
        b.rot.goto(330.0, 0.0)
    assert exc.value.reason == "limit"
    # from 0 to 170 the only way is through the mast (no elevation to fly over it, and
    # the 300 deg limit forbids the long way round): refused, nothing moves
    with pytest.raises(CommandRejected) as exc:
        b.rot.goto(170.0, 0.0)
    assert exc.value.reason == "keepout"
    b.rot.goto(50.0, 0.0)  # the "sky" zone is above the beam: its sector is free
    b.settle()
    b.rot.move("az", 1)  # a jog stops before the mast
    poses = []
    b.run(30.0, on_tick=lambda s: poses.append(s.sim_truth["az"]["deg"]))
    assert 90.0 < poses[-1] < 100.0 and max(poses) < 100.0


def test_park_and_track_use_the_azimuth_alone(bench):
    b = bench("tartu-urc", **AZ_ONLY, park={"az_deg": 10.0})
    b.rot.track(50.0, 70.0, az_rate_deg_per_s=1.0, el_rate_deg_per_s=0.5)
    s = b.run(20.0)
    assert s.target_el_deg is None
    assert s.az_deg == pytest.approx(70.0, abs=0.5)
    b.rot.park()
    s = b.run(60.0, until=lambda s: s.parked)
    assert s.parked and s.az_deg == pytest.approx(10.0, abs=0.2)


def test_a_restart_with_elevation_back_on_does_not_claim_to_know_it(bench, tmp_path):
    b = bench("tartu-urc", exact=True, **AZ_ONLY)
    b.rot.goto(80.0, 0.0)
    b.settle()
    b.rot.shutdown()
    b.rot.hw.close()
    again = bench("tartu-urc", exact=True)  # same state directory, elevation on again
    s = again.rot.status()
    assert s.az.uncertainty_deg == 0.0 and s.az.pos_deg == pytest.approx(80.0, abs=0.2)
    assert s.el.uncertainty_deg > 0 and not s.position_known  # the record says nothing of it


def test_config_az_only_needs_no_elevation_parts_and_refuses_elevation_settings():
    az = {"motor": "vnh5019", "pins": {"ina": 5, "inb": 6, "pwm": 12, "enc_a": 17, "enc_b": 27, "brake": 16}}
    cfg = Config.from_dict({"rotator": {"elevation": False},
                            "hardware": {"backend": "gpio", "gpio": {"emulate": True, "az": az}}})
    assert cfg.caps.axes == ("az",)
    with pytest.raises(ConfigError) as exc:  # the same without elevation = false: el pins missing
        Config.from_dict({"hardware": {"backend": "gpio", "gpio": {"emulate": True, "az": az}}})
    assert exc.value.key == "hardware.gpio.el"
    for extra, key in (({"limits": {"el": {"max_deg": 80.0}}}, "limits.el.max_deg"),
                       ({"park": {"el_deg": 10.0}}, "park.el_deg"),
                       ({"hardware": {"backend": "gpio", "gpio": {"az": az, "el": az}}}, "hardware.gpio.el"),
                       ({"rotator": {"elevation": False, "flip": True}}, "rotator.flip")):
        data = {"rotator": {"elevation": False}, **extra}
        with pytest.raises(ConfigError) as exc:
            Config.from_dict(data)
        assert key in str(exc.value) and "rotator.elevation" in str(exc.value) or key == "rotator.flip"
    with pytest.raises(ConfigError) as exc:
        Config.from_dict({"rotator": {"elevation": "off"}})
    assert exc.value.key == "rotator.elevation"
