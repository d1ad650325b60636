"""SARCNET ``c``: the 12-direction hand-held calibration over the console (seed 001).

The operator's "point this face along the field / down" is emulated by turning the
simulated sensor board (``world.board.point``: the SensorBoard interface of the
simulator, which the emulated LSM303D's registers read too). The board carries hard and
soft iron and accelerometer errors the shipped constants do not know about.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy.testing
import pytest

from urc.assembly import build_rotator
from urc.cli import with_emulation
from urc.clock import VirtualClock
from urc.config import Config, load_config
from urc.protocols.sarcnet import CALIBRATION_HOLD, SarcnetSession
from urc.rotator.loop import run_virtual
from urc.testing.sessions import fed, hung_up, ticked

SARCNET_EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "sarcnet-mini.toml"

FACES = ("+x", "-x", "+y", "-y", "+z", "-z")
#: iron the shipped constants know nothing of: soft iron with cross terms (also in the
#: horizontal plane, so the heading suffers; stretched along the boresight, the chip's
#: Y as seed 001 mounts it), hard iron along z, accelerometer errors
IRON = dict(soft_iron=(0.90, 0.08, -0.05, 0.08, 1.15, 0.03, -0.05, 0.03, 1.02), hard_iron_z=0.12,
            accel_bias_g=(-0.02, 0.03, 0.05), accel_scale=(0.97, 1.04, 1.02))


def disturb(world) -> None:
    """The magnetic conditions near the sensor change (the document's reason to redo it)."""
    world.board.change_conditions(**IRON)


def operator(world, session, tick, directions=None, wiggles=(0.0, 8.0, -8.0), steps=7):
    """Hold the board in each direction (gravity first, then the field, as prompted),
    moving it a little around each point, and return everything the console printed."""
    out = []
    for along, face in directions or [(a, f) for a in ("gravity", "field") for f in FACES]:
        for twist in wiggles:
            world.board.point(face, along, twist)
            for _ in range(steps):
                out += tick()
    return out


def az_errors(b, azimuths=(0.0, 60.0, 150.0, 240.0, 300.0)) -> list[float]:
    """Reported minus true azimuth, the antenna driven to each azimuth in turn."""
    errs = []
    # the simulated site's declination is 12.5 deg; a different setting shifts by design
    shift = b.rot.hw.axis("az").sensor.calibration()["declination_deg"] - 12.5
    for az in azimuths:
        b.rot.goto(az, 10.0)
        b.settle()
        st = b.rot.status()
        errs.append(abs((st.az_deg - st.sim_truth["az"]["deg"] - shift + 180.0) % 360.0 - 180.0))
    return errs


@pytest.fixture
def rig(bench):
    b = bench("sarcnet-mini")
    disturb(b.world)
    s = SarcnetSession(b.rot)

    def tick():
        b.run(0.1)
        return ticked(s, b.clock.now_s())
    return b, s, tick


def test_document_calibration_session(rig):
    """The document's calibration steps as typed in the IDE Serial Monitor with
    "Carriage return" line endings: e11.7 then s, c, the 12 directions, s, r."""
    b, s, tick = rig
    before = az_errors(b)
    assert max(before) > 3.0, "the new iron spoils the heading"
    assert fed(s, b"e11.7\r") == [b"Magnetic declination: 11.7\r\n"]
    assert fed(s, b"s\r")[0].startswith(b"Saved")
    out = fed(s, b"c\r")
    assert out[0] == b"Calibration in progress: Press 'a' to abort\r\n"
    assert out[-1] == b"Next: +X face down (0 of 12 done)\r\n"
    b.run(0.1)
    assert b.rot.status().local_control == (CALIBRATION_HOLD,)
    assert fed(s, b"30 45\r") == [b"Error: calibrating: s to save, a to abort\r\n"]
    out = operator(b.world, s, tick)
    done = [line for line in out if line.startswith(b"Point ")]
    assert done[0] == b"Point 1 of 12 done: +X face down\r\n"
    assert done[-1] == b"Point 12 of 12 done: -Z face along the magnetic field\r\n" and len(done) == 12
    assert out[-1] == b"All 12 directions done: keep moving gently to refine, s to save, a to abort\r\n"
    shown = [line for line in out if line.startswith((b"M offset", b"G offset"))]
    pairs = list(zip(shown[::2], shown[1::2]))
    assert pairs and all(a != b for a, b in zip(pairs, pairs[1:])), "shown only when it changes"
    assert all(line.endswith(b"\r\n") for line in out)

    saved = fed(s, b"s\r")
    assert saved[-1] == b"Calibration saved: put the sensor back on the boom, then r to reset\r\n"
    b.run(0.1)
    assert b.rot.status().local_control == ()
    cal = b.rot.hw.axis("az").sensor.calibration()
    assert (cal["hard_iron_x"], cal["hard_iron_y"], cal["hard_iron_z"]) == pytest.approx((0.04, -0.03, 0.12), abs=0.01)
    assert cal["accel_offset"] == pytest.approx(list(IRON["accel_bias_g"]), abs=0.005)
    assert cal["accel_scale"] == pytest.approx(list(IRON["accel_scale"]), abs=0.005)
    assert b.rot.hw.axis("el").sensor.calibration()["accel_offset"] == cal["accel_offset"]
    # the fitted soft iron undoes the board's: their product is a multiple of identity
    m = cal["mag_matrix"]
    prod = [[sum(m[3 * i + k] * IRON["soft_iron"][3 * k + j] for k in range(3)) for j in range(3)] for i in range(3)]
    for i in range(3):
        for j in range(3):
            assert prod[i][j] / prod[0][0] == pytest.approx(1.0 if i == j else 0.0, abs=0.01)

    b.world.board.release()                      # back on the boom
    b.run(1.0)
    reset = fed(s, b"r\r")
    assert reset[-1] == b"Reset complete\r\n" and b"az hard_iron_z: " + f"{cal['hard_iron_z']:g}".encode() + b"\r\n" in reset
    b.settle()
    after = az_errors(b)
    assert max(after) < 1.0, (before, after)
    # kept across a restart of urc (the state record carries the constants)
    b2 = b.restart()
    assert b2.rot.hw.axis("az").sensor.calibration()["mag_matrix"] == pytest.approx(m)


def _unchanged(b):
    return (b.rot.hw.axis("az").sensor.calibration(), b.rot.hw.axis("el").sensor.calibration())


@pytest.mark.parametrize("how", ["a", "esc", "ctrl-c", "disconnect", "too few"])
def test_aborted_or_bad_calibration_changes_nothing(rig, how):
    b, s, tick = rig
    start = _unchanged(b)
    fed(s, b"c\r")
    few = [("gravity", "+x"), ("gravity", "+z"), ("field", "+x")]
    out = operator(b.world, s, tick, directions=few if how == "too few" else None)
    if how != "too few":
        assert out[-1].startswith(b"All 12 directions done")
    if how == "a":
        assert fed(s, b"a\r") == [b"Calibration aborted: nothing changed\r\n"]
    elif how == "esc":
        assert fed(s, b"s\x1b") == [b"Calibration aborted: nothing changed\r\n"]
    elif how == "ctrl-c":
        assert fed(s, b"\x03") == [b"Calibration aborted: nothing changed\r\n"]
    elif how == "disconnect":
        hung_up(s)
    else:
        (reply,) = fed(s, b"s\r")
        assert reply.startswith(b"Error: calibration not saved: 3 of 12 directions done (missing: -X along gravity, ")
        assert reply.endswith(b"; nothing changed\r\n")
        assert s.mode == "calibrating" and b.rot.local_controls() == (CALIBRATION_HOLD,)
        assert fed(s, b"a\r") == [b"Calibration aborted: nothing changed\r\n"]
    assert _unchanged(b) == start
    assert b.rot.local_controls() == ()
    assert fed(s, b"s\r")[0].startswith(b"Saved")      # an ordinary s again
    assert _unchanged(b) == start


def test_sensor_board_points_faces(bench):
    """The simulator interface the tests hold the board with: the named face reads the
    whole field (or gravity) and the others none."""
    b = bench("sarcnet-mini")
    board = b.world.board
    for face, axis, sign in (("+x", 0, 1), ("-y", 1, -1), ("+z", 2, 1)):
        board.point(face, "gravity", 30.0)
        g = b.rot.hw.axis("el").sensor.accel.read_vector()
        assert g[axis] * sign == pytest.approx(1.0, abs=0.01)
        board.point(face, "field")
        m = b.rot.hw.axis("az").sensor.mag.read_vector()
        total = math.hypot(1.0, math.tan(math.radians(65.0)))
        assert (m[axis] - (0.04, -0.03, 0.0)[axis]) * sign == pytest.approx(total, abs=0.02)
    board.release()
    assert b.rot.hw.axis("el").sensor.accel.read_vector()[2] == pytest.approx(1.0, abs=0.01)


def test_calibration_on_the_emulated_lsm303d(tmp_path):
    """The gpio backend's LSM303D driver, its registers fed by the same board: the
    calibration finds the board's hard iron in the chip's units (gauss)."""
    data = with_emulation(load_config(SARCNET_EXAMPLE)).to_dict()
    data["hardware"]["sim"] = {"wind": False}
    clock = VirtualClock(1000.0)
    rot = build_rotator(Config.from_dict(data), clock, tmp_path, durable_state=False, fast_virtual=True)
    world = rot.hw.world
    disturb(world)
    s = SarcnetSession(rot)
    fed(s, b"c\r")

    def tick():
        run_virtual(rot, clock, 0.1)
        return ticked(s, clock.now_s())
    assert operator(world, s, tick)[-1].startswith(b"All 12 directions done")
    assert fed(s, b"s\r")[-1].startswith(b"Calibration saved")
    cal = rot.hw.axis("az").sensor.calibration()
    h_gauss = 0.2
    assert (cal["hard_iron_x"], cal["hard_iron_y"], cal["hard_iron_z"]) == \
        pytest.approx((0.04 * h_gauss, -0.03 * h_gauss, 0.12 * h_gauss), abs=0.003)
    assert cal["accel_offset"] == pytest.approx(list(IRON["accel_bias_g"]), abs=0.005)


def test_calibration_on_an_azimuth_only_sarcnet_in_the_plain_simulator(bench):
    """[rotator] elevation = false: no tilt sensor, so the compass's own accelerometer
    (on the same simulated board) gives the accelerometer half. Before, ``c`` answered
    "Error: no raw magnetometer/accelerometer on this rotator"."""
    from urc.protocols import make_session

    b = bench("sarcnet-mini", rotator={"elevation": False})
    disturb(b.world)
    s = make_session("sarcnet", b.rot)      # the single-axis port, as urc run serves it

    def tick():
        b.run(0.1)
        return ticked(s, b.clock.now_s())
    before = az_errors(b)
    assert max(before) > 3.0, "the new iron spoils the heading"
    assert fed(s, b"c\r")[-1] == b"Next: +X face down (0 of 12 done)\r\n"
    assert operator(b.world, s, tick)[-1].startswith(b"All 12 directions done")
    assert fed(s, b"s\r")[-1].startswith(b"Calibration saved")
    cal = b.rot.hw.axis("az").sensor.calibration()
    assert cal["hard_iron_z"] == pytest.approx(0.12, abs=0.01)
    assert cal["accel_offset"] == pytest.approx(list(IRON["accel_bias_g"]), abs=0.005)
    b.world.board.release()                      # back on the boom, then r (as the document)
    b.run(1.0)
    assert fed(s, b"r\r")[-1] == b"Reset complete\r\n"
    b.settle()
    after = az_errors(b)
    assert max(after) < 1.0, (before, after)
    b2 = b.restart()
    assert b2.rot.hw.axis("az").sensor.calibration()["mag_matrix"] == pytest.approx(cal["mag_matrix"])


#: the compass constants the two soft-iron procedures set
SOFT_KEYS = ("hard_iron_x", "hard_iron_y", "hard_iron_z", "mag_matrix", "soft_iron")
IDENTITY3 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]


def _soft(b) -> dict:
    c = b.rot.hw.axis("az").sensor.calibration()
    return {k: c[k] for k in SOFT_KEYS}


def assert_same_soft_iron(actual: dict, expected: dict) -> None:
    """The calibrations agree key by key, to pytest.approx's default tolerance (pytest 9's
    approx refuses a dict of lists, and a whole-dict compare would hide which key differs)."""
    assert actual.keys() == expected.keys()
    for key, want in expected.items():
        if want is None:
            assert actual[key] is None, key
        else:
            numpy.testing.assert_allclose(actual[key], want, rtol=1e-6, atol=1e-12, err_msg=key)


def _turn_round(b):
    """The web page's turn-round calibration (the procedure its route starts)."""
    from urc.procedures.calibration import MagnetometerCalibration

    proc = MagnetometerCalibration(b.rot)
    b.run(1200.0, on_tick=proc.poll, until=lambda st: proc.finished)
    assert proc.state == "done", proc.as_dict()
    b.run(0.2)
    return proc.result


def _hand_held(b, s, tick):
    assert fed(s, b"c\r")[-1].startswith(b"Next: ")
    assert operator(b.world, s, tick)[-1].startswith(b"All 12 directions done")
    assert fed(s, b"s\r")[-1].startswith(b"Calibration saved")
    b.world.board.release()
    b.run(1.0)
    assert fed(s, b"r\r")[-1] == b"Reset complete\r\n"
    b.settle()


def test_turn_round_and_c_each_replace_the_others_soft_iron_and_the_last_one_is_kept(rig):
    b, s, tick = rig
    first = _turn_round(b)
    assert first["soft_iron"] is not None, "the board's soft iron makes an ellipse"
    assert _soft(b)["soft_iron"] == pytest.approx(first["soft_iron"])

    _hand_held(b, s, tick)                           # c after the turn-round
    after_c = _soft(b)
    assert after_c["soft_iron"] == [1.0, 0.0, 0.0, 1.0], "c replaced the horizontal soft iron"
    assert after_c["mag_matrix"] != pytest.approx(IDENTITY3)
    assert max(az_errors(b)) < 1.0
    b = b.restart()                                  # what is kept is what was applied
    assert_same_soft_iron(_soft(b), after_c)

    last = _turn_round(b)                            # the turn-round after c
    now = _soft(b)
    assert now["mag_matrix"] == IDENTITY3, "the turn-round replaced c's 3-D soft iron"
    assert now["soft_iron"] == pytest.approx(last["soft_iron"] or [1.0, 0.0, 0.0, 1.0])
    assert (now["hard_iron_x"], now["hard_iron_y"]) == pytest.approx((last["hard_iron_x"], last["hard_iron_y"]))
    assert max(az_errors(b)) < 1.0
    b = b.restart()
    assert_same_soft_iron(_soft(b), now)


def test_c_during_a_turn_round_stops_it_and_only_c_is_applied(rig):
    """The board taken off the boom while the antenna turns round: the turn-round ends
    without applying anything (its samples would mix boom and hand), c's result is the
    one in use and on disk."""
    from urc.procedures.calibration import MagnetometerCalibration

    b, s, tick = rig
    before = _soft(b)
    proc = MagnetometerCalibration(b.rot)
    # at the last direction, the antenna standing still for its sample
    b.run(600.0, on_tick=proc.poll, until=lambda st: len(proc.samples) == 11 and proc._phase == "dwell")
    assert not proc.finished
    fed(s, b"c\r")       # its last sample comes next: applying it is refused by c's hold
    b.run(30.0, on_tick=proc.poll, until=lambda st: proc.finished)
    assert proc.state == "failed" and "local control active" in proc.error, proc.as_dict()
    assert _soft(b) == before, "nothing of the turn-round applied"
    assert fed(s, b"a\r") == [b"Calibration aborted: nothing changed\r\n"]
    assert _soft(b) == before
    _hand_held(b, s, tick)
    after_c = _soft(b)
    assert after_c["mag_matrix"] != pytest.approx(IDENTITY3) and after_c["soft_iron"] == [1.0, 0.0, 0.0, 1.0]
    assert_same_soft_iron(_soft(b.restart()), after_c)
