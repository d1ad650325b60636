"""Position, wrap and calibration survive a controller restart; damage is detected."""

import json

import pytest

from conftest import ALL_PROFILES, bounded
from urc.errors import CommandRejected


def counts(b, axis):
    return b.rot.caps.axis(axis).sensor.resolution_deg


@pytest.mark.parametrize("profile", ALL_PROFILES)
def test_orderly_restart_keeps_position_and_wrap(bench, profile):
    b = bench(profile, exact=True)
    lo, hi = b.rot.status().limits["az"]
    az_target = 380.0 if hi >= 390 else 200.0  # on the overlap where there is one
    b.rot.goto(az_target, 30.0)
    b.settle()
    b = b.restart(clean=True)
    s = b.rot.status()
    assert s.position_known
    for axis in ("az", "el"):
        truth = s.sim_truth[axis]["deg"]
        # within 2 sensor counts of the simulator's truth (plus sensor noise)
        slack = 2 * counts(b, axis) + 4 * b.rot.caps.axis(axis).sensor.noise_deg + 0.25
        assert getattr(s, axis).pos_deg == pytest.approx(truth, abs=slack), axis
    assert s.az.pos_deg == pytest.approx(az_target, abs=2.0)
    b.rot.goto(10.0, 10.0)  # automatic motion allowed


@pytest.mark.parametrize("profile", ["tartu-urc", "bigras"])  # incremental sensors
def test_kill_mid_move_reports_uncertainty_or_exact_position(bench, profile):
    b = bench(profile, exact=True)
    b.rot.goto(150.0, 40.0)
    b.run(6.0)
    assert b.rot.status().moving
    b = b.restart(clean=False)  # as if kill -9: no orderly save, the motor loses power
    s = b.rot.status()
    for axis in ("az", "el"):
        ax = getattr(s, axis)
        truth = s.sim_truth[axis]["deg"]
        if ax.uncertainty_deg == 0:
            assert ax.pos_deg == pytest.approx(truth, abs=2 * counts(b, axis))
        else:
            # the truth lies inside the bound urc reports
            assert abs(ax.pos_deg - truth) <= ax.uncertainty_deg
    if not s.position_known:
        with pytest.raises(CommandRejected, match="uncertain"):
            b.rot.goto(10.0, 10.0)
        with pytest.raises(CommandRejected, match="uncertain"):
            b.rot.park()
        b.rot.move("az", +1, 0.5)  # a person jogging by hand is allowed
        b.rot.stop()
        b.settle()
        truth = b.rot.status().sim_truth
        b.rot.set_position(az_deg=truth["az"]["deg"], el_deg=truth["el"]["deg"])
        b.run(0.1)
        assert b.rot.status().position_known
        b.rot.goto(10.0, 10.0)


@pytest.mark.parametrize("damage", ["truncate", "flip", "garbage"])
def test_damaged_state_file_is_detected_not_trusted(bench, damage):
    b = bench("tartu-urc", exact=True)
    b.rot.goto(100.0, 30.0)
    b.settle()
    b.rot.shutdown()
    b.rot.hw.close()
    path = b.state_dir / "state.json"
    raw = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(raw[: len(raw) // 2])
    elif damage == "flip":
        rec = json.loads(raw)
        rec["payload"]["axes"]["az"]["mech_deg"] += 10
        path.write_text(json.dumps(rec))
    else:
        path.write_bytes(b"\x00" * 40)
    b = b.restart(clean=False)
    s = b.rot.status()
    assert not s.position_known
    assert any("state file damaged" in e for e in s.events)
    assert list(b.state_dir.glob("state.json.corrupt-*")), "the damaged file is kept for inspection"
    with pytest.raises(CommandRejected, match="uncertain"):
        b.rot.goto(10.0, 10.0)


def test_absolute_sensor_restart_needs_no_state(bench):
    b = bench("g5500", exact=True)
    b.rot.goto(200.0, 60.0)
    b.settle()
    (b.state_dir / "state.json").unlink()
    b = b.restart(clean=False)
    s = b.rot.status()
    assert s.position_known
    assert s.az.pos_deg == pytest.approx(s.sim_truth["az"]["deg"], abs=1.0)


def test_calibration_and_learnt_coast_persist(bench):
    b = bench("g4jnt", exact=True)
    for az in (100.0, 200.0, 120.0):
        b.rot.goto(az, 20.0)
        b.settle()
        b.run(1.0)
    learnt = b.rot.axes["az"].law.coast_deg
    b = b.restart(clean=True)
    assert b.rot.axes["az"].law.coast_deg == pytest.approx(learnt)


# ------------------------------------------------- issue 9.1: homing's search frame
@pytest.mark.parametrize("clean", [False, True], ids=["kill", "sigterm"])
def test_interrupted_homing_restarts_uncertain_in_the_true_frame(bench, clean):
    from urc.procedures import calibration as cal
    b = bench("bigras", exact=True, hardware={"sim": {"wind": False, "start_az_deg": 120.0}})
    b.rot.set_position(az_deg=b.truth("az"))
    b.run(0.2)
    proc = cal.LimitSwitchHoming(b.rot, "az")
    b.run(4.0, on_tick=proc.poll)
    assert proc.state == "running" and proc._phase == "search"
    # the search frame (top of the range) is in use right now
    assert b.rot.status().az.pos_deg - b.truth("az") > 100.0
    b = b.restart(clean=clean)
    s = b.rot.status()
    assert not s.position_known
    assert bounded(s, "az"), (s.az, s.sim_truth["az"]["deg"])
    assert abs(s.az.pos_deg - b.truth("az")) < 30.0, "the record keeps the true frame"
    with pytest.raises(CommandRejected, match="uncertain"):
        b.rot.goto(10.0, 10.0)


# ----------------------------------- issue 9.3: missing / foreign / just-damaged file
def test_missing_state_file_in_a_used_dir_means_uncertain(bench):
    """sarcnet-mini at 420 deg (its overlap) must not restart as 60 deg known."""
    b = bench("sarcnet-mini", exact=True)
    b.rot.goto(420.0 - 360.0 + 360.0, 10.0)  # an explicit overlap pose: az 420
    b.settle()
    assert b.rot.status().az.pos_deg == pytest.approx(420.0, abs=2.0)
    b.rot.shutdown()
    (b.state_dir / "state.json").unlink()
    b = b.restart(clean=False)
    s = b.rot.status()
    assert not s.position_known and s.az.uncertainty_deg >= 360.0
    with pytest.raises(CommandRejected, match="uncertain"):
        b.rot.goto(150.0, 10.0)


def test_missing_state_file_on_an_incremental_axis_means_uncertain(bench):
    b = bench("tartu-urc", exact=True)
    b.rot.goto(200.0, 30.0)
    b.settle()
    b.rot.shutdown()
    (b.state_dir / "state.json").unlink()
    b = b.restart(clean=False)
    assert not b.rot.status().position_known


def test_fresh_state_dir_assumes_park_and_marks_itself_used(bench):
    b = bench("tartu-urc", exact=True)
    s = b.rot.status()
    assert s.position_known
    assert any("first start" in e for e in s.events)
    assert (b.state_dir / "urc-initialised").exists()


def test_foreign_state_file_means_uncertain(bench, tmp_path):
    b = bench("tartu-urc", exact=True)
    b.rot.goto(200.0, 30.0)
    b.settle()
    b.rot.shutdown()
    path = b.state_dir / "state.json"
    rec = json.loads(path.read_text())
    from urc.persistence import StateStore
    payload = rec["payload"]
    payload["profile"] = "bigras"
    StateStore(path).save(payload)
    b = b.restart(clean=False)
    assert not b.rot.status().position_known


def test_damaged_file_is_replaced_by_an_uncertain_record_before_the_first_tick(bench):
    """A kill right after start-up (before any tick) must not restart 'assuming park'."""
    b = bench("tartu-urc", exact=True)
    b.rot.goto(200.0, 30.0)
    b.settle()
    b.rot.shutdown()
    path = b.state_dir / "state.json"
    path.write_bytes(path.read_bytes()[:20])
    b = b.restart(clean=False)
    assert not b.rot.status().position_known
    b = b.restart(clean=False)  # killed before its first tick
    s = b.rot.status()
    assert not s.position_known
    assert not any("damaged" in e for e in s.events), "the record on disk is the new one"


# ------------------------------------- issue 9.9: a kill early in a move, long interval
@pytest.mark.parametrize("profile", ["tartu-urc", "bigras"])
@pytest.mark.parametrize("early_s", [0.1, 0.6, 2.5])
def test_kill_early_in_a_move_is_never_the_old_position_known(bench, profile, early_s):
    b = bench(profile, exact=True, state={"save_interval_s": 5.0})
    b.rot.goto(150.0, 40.0)
    b.run(early_s)
    b = b.restart(clean=False)
    s = b.rot.status()
    for axis in ("az", "el"):
        assert bounded(s, axis, slack_deg=0.6), (axis, getattr(s, axis), s.sim_truth[axis]["deg"])


def test_save_interval_is_bounded():
    from urc.config import Config
    from urc.errors import ConfigError
    with pytest.raises(ConfigError):
        Config.from_dict({"state": {"save_interval_s": 60.0}})


def _rewrite_with_checksum(path, edit):
    """Change a record and give it a valid checksum (what a bug or a hand edit could
    leave), so only the content can tell it is damaged."""
    import zlib
    rec = json.loads(path.read_text())
    edit(rec["payload"])
    rec["crc32"] = zlib.crc32(json.dumps(rec["payload"], sort_keys=True, separators=(",", ":")).encode())
    path.write_text(json.dumps(rec))


@pytest.mark.parametrize("field, value, said", [
    ("mech_deg", "12.5", "mech_deg: expected a number"),       # issue 36.20: taken as known, 11.7 deg off
    ("mech_deg", True, "mech_deg: expected a number"),
    ("mech_deg", 1000.0, "outside the az axis' reach"),         # tartu-urc: 0..400
    ("mech_deg", 1e5, "mech_deg: expected a number within"),
    ("uncertainty_deg", "0", "uncertainty_deg"),
    ("uncertainty_deg", -1.0, "uncertainty_deg"),
    ("moving", "no", "moving"),
    ("window_deg", ["99", "101"], "window_deg"),
    ("window_deg", [101.0, 99.0], "window_deg"),
    ("calibration", {"reference_deg": "3"}, "calibration"),
    ("coast_deg", "0.5", "coast_deg"),
    ("rate_deg_per_s", None, "rate_deg_per_s"),
    (None, None, "mech_deg: missing"),
])
def test_a_field_of_the_wrong_type_or_range_is_damage(bench, field, value, said):
    """Issue 36.20: a record's fields were not checked: mech_deg "12.5" under a valid
    checksum was taken as a known position. Any field not as urc writes it makes the
    record damaged: the position restarts uncertain."""
    b = bench("tartu-urc", exact=True)
    b.rot.goto(100.0, 30.0)
    b.settle()
    b.rot.shutdown()
    b.rot.hw.close()
    path = b.state_dir / "state.json"

    def edit(payload):
        ax = payload["axes"]["az"]
        if field is None:
            del ax["mech_deg"]
        else:
            ax[field] = value
    _rewrite_with_checksum(path, edit)
    b = b.restart(clean=False)
    s = b.rot.status()
    assert not s.position_known and s.az.uncertainty_deg > 0
    assert any("state file damaged" in e and said in e for e in s.events), s.events
    assert list(b.state_dir.glob("state.json.corrupt-*")), "the damaged file is kept for inspection"
    with pytest.raises(CommandRejected, match="uncertain"):
        b.rot.goto(10.0, 10.0)


@pytest.mark.parametrize("field", ["uncertainty_deg", "mech_deg", "window_deg"])
def test_non_finite_field_is_damage_never_trusted_nor_written_back(bench, field):
    """Issue 21: uncertainty_deg = NaN was trusted (moves allowed, NaN written into
    every new record, status not JSON); mech_deg = NaN crashed the start."""
    b = bench("tartu-urc", exact=True)
    b.rot.goto(100.0, 30.0)
    b.settle()
    b.rot.shutdown()
    b.rot.hw.close()
    path = b.state_dir / "state.json"

    def poison(payload):
        ax = payload["axes"]["az"]
        ax[field] = [float("nan"), 1.0] if field == "window_deg" else float("nan")
    _rewrite_with_checksum(path, poison)
    b = b.restart(clean=False)
    s = b.rot.status()
    assert not s.position_known
    assert any("state file damaged" in e and "not a finite number" in e for e in s.events)
    with pytest.raises(CommandRejected, match="uncertain"):
        b.rot.goto(10.0, 10.0)
    json.dumps(s.as_dict() if hasattr(s, "as_dict") else s.az.uncertainty_deg, allow_nan=False)
    assert "NaN" not in path.read_text(), "the new record is finite"
