"""Position, wrap and calibration survive a controller restart; damage is detected."""

import json

import pytest

from conftest import ALL_PROFILES
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
