"""rotctld (Hamlib NET rotctl) session: framing, every command, captures, clients, fuzzing.

Byte captures are from protocols.md section 1 (Hamlib 4.5.4 / 4.6.5 ``rotctld -m 1``).
Where a capture shows the dummy's position or info string, the rotator here is put at
the same position (the nearest tenth the Tartu encoders can show) and the reply must be
byte-identical apart from those values.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from conftest import Bench
from session_replay import raises_nothing
from urc.errors import ConfigError
from urc.protocols import MAX_PENDING_BYTES, Session, make_session, session_class
from urc.protocols.rotctld import RotctldSession
from urc.wire.rotctld.commands import BY_NAME, COMMANDS
from urc.protocols.rotctld.lexer import CLOSE, CMD, UNKNOWN, Lexer
from urc.testing.sessions import fed, ticked


# ------------------------------------------------------------------------- helpers
def at(b, az_deg: float, el_deg: float) -> None:
    """Re-reference the rotator to (az, el) and let the snapshot settle."""
    b.rot.set_position(az_deg, el_deg)
    b.run(1.0)
    s = b.rot.status()
    assert not s.moving and s.az_deg == pytest.approx(az_deg % 360, abs=1e-6)


def go(b, az_deg: float, el_deg: float) -> None:
    """Really drive there (set_position would only change what the controller believes)."""
    b.rot.goto(az_deg, el_deg)
    b.settle()


def bytewise(sess, data: bytes) -> list[bytes]:
    out: list[bytes] = []
    for i in range(len(data)):
        out += fed(sess, data[i:i + 1])
    return out


def idle(b) -> bool:
    """Nothing was commanded: no target, no motion, after the queue has been applied."""
    b.run(0.2)
    s = b.rot.status()
    return s.target_az_deg is None and s.az.target_deg is None and s.el.target_deg is None \
        and not s.moving


class Recorder:
    """The real rotator, plus a log of the motion commands called on it (every call goes
    through): shows that the session itself, not only the service behind it, refused."""

    MOTION = ("goto", "goto_az", "goto_el", "park", "move", "track", "set_position")

    def __init__(self, rot):
        self._rot = rot
        self.calls: list[tuple[str, tuple]] = []

    def __getattr__(self, name):
        attr = getattr(self._rot, name)
        if name not in self.MOTION:
            return attr

        def call(*args, **kwargs):
            self.calls.append((name, args))
            return attr(*args, **kwargs)
        return call


_BENCH_DIRS: list[Path] = []


@pytest.fixture(scope="module", autouse=True)
def _bench_dir(tmp_path_factory):
    """Where fresh_bench's state directories go: under pytest's own temporary root, which
    pytest prunes, not one /tmp directory per bench left behind by every run."""
    _BENCH_DIRS.append(tmp_path_factory.mktemp("rotctld"))
    yield
    _BENCH_DIRS.pop()


def fresh_bench(profile: str = "tartu-urc", **config) -> Bench:
    return Bench(profile, Path(tempfile.mkdtemp(dir=_BENCH_DIRS[-1])) / "state", **config)


@pytest.fixture
def tartu(bench):
    b = bench("tartu-urc")
    at(b, 10.5, 20.5)
    return b


# ------------------------------------------------------------------- registration
def test_registered_and_is_a_session(tartu):
    assert session_class("rotctld") is RotctldSession
    s = make_session("rotctld", tartu.rot, hamlib_version="4.6")
    assert isinstance(s, Session) and not s.closed and ticked(s, 0.0) == []


def test_bad_version_option(tartu):
    with pytest.raises(ConfigError, match="hamlib_version"):
        RotctldSession(tartu.rot, hamlib_version="4.4")
    assert RotctldSession(tartu.rot, hamlib_version=4.6).hamlib_version == "4.6"  # TOML number
    s = RotctldSession(tartu.rot)
    assert fed(s, bytearray(b"p")) == [b"10.50\n20.50\n"] and fed(s, memoryview(b"_\n")) == [
        b"urc tartu-urc\n"]


# ------------------------------------------------------------ section 1.3 captures
# (sent, replies, rotator position or None). Dummy's 16.22 / 0.19 / 10.81 -> 16.20 / 0.20 /
# 10.80, "Dummy rotator" -> "urc tartu-urc", dummy's SPEED 3 -> ours set to 3 first.
CAPTURES = [
    (b"p\n", [b"10.50\n20.50\n"], (10.5, 20.5)),
    (b"+p\n", [b"get_pos:\nAzimuth: 10.00\nElevation: 16.20\nRPRT 0\n"], (10.0, 16.2)),
    (b";p\n", [b"get_pos:;Azimuth: 10.00;Elevation: 20.00;RPRT 0\n"], (10.0, 20.0)),
    (b"|p\n", [b"get_pos:|Azimuth: 10.00|Elevation: 20.00|RPRT 0\n"], (10.0, 20.0)),
    (b",p\n", [b"get_pos:,Azimuth: 10.00,Elevation: 20.00,RPRT 0\n"], (10.0, 20.0)),
    (b"?p\n", [b"get_pos:?Azimuth: 0.00?Elevation: 0.20?RPRT 0\n"], (0.0, 0.2)),
    (b"\\get_pos\n", [b"10.80\n10.80\n"], (10.8, 10.8)),
    (b"P 123.4 45.6\n", [b"RPRT 0\n"], None),
    (b"P 1 2 p\n", [b"RPRT 0\n", b"10.50\n20.50\n"], (10.5, 20.5)),
    (b"+P 1 2\n", [b"set_pos: 1 2\nRPRT 0\n"], None),
    (b";P 1 2\n", [b"set_pos: 1 2;RPRT 0\n"], None),
    (b"+\\set_pos 10 20\n", [b"set_pos: 10 20\nRPRT 0\n"], None),
    (b"+P 1000 0\n", [b"set_pos: 1000 0\nRPRT -1\n"], None),
    (b";P 1000 0\n", [b"set_pos: 1000 0;RPRT -1\n"], None),
    (b"+M LEFT 50\n", [b"move: LEFT 50\nRPRT 0\n"], (10.5, 20.5)),
    (b"+K\n", [b"park:\nRPRT 0\n"], None),
    (b";S\n", [b"stop:;RPRT 0\n"], None),
    (b"_\n", [b"urc tartu-urc\n"], None),
    (b"+_\n", [b"get_info:\nInfo: urc tartu-urc\nRPRT 0\n"], None),
    (b"|_\n", [b"get_info:|Info: urc tartu-urc|RPRT 0\n"], None),
    (b"+s\n", [b"get_status:\nStatus flags: \nRPRT 0\n"], None),
    (b"V SPEED 3\nv SPEED\n", [b"RPRT 0\n", b"3\n"], None),
    (b"V SPEED 3\n+v SPEED\n", [b"RPRT 0\n", b"get_level: SPEED\n3\nRPRT 0\n"], None),
    (b"+V SPEED 2\n", [b"set_level: SPEED 2\nRPRT 0\n"], None),
    (b"V ?\n", [b"SPEED \nRPRT 0\n"], None),
    (b"R\n1\n", [b"RPRT 0\n"], None),
    (b"P 180,50 45,25\n", [b"RPRT 0\n"], None),
    (b"P abc def\n", [b"RPRT -1\n"], None),
    (b"Z\n", [], None),
    (b"\\dump_state\n", [b"1\n1\nmin_az=0.000000\nmax_az=400.000000\nmin_el=0.000000\n"
                         b"max_el=180.000000\nsouth_zero=0\nrot_type=AzEl\ndone\n"], None),
    (b"+\\dump_state\n", [b"dump_state:\nrotctld Protocol Ver: 1\nRotor Model: 1\n"
                          b"Minimum Azimuth: 0.000000\nMaximum Azimuth: 400.000000\n"
                          b"Minimum Elevation: 0.000000\nMaximum Elevation: 180.000000\n"
                          b"South Zero: 0\nrot_type=AzEl\ndone\nRPRT 0\n"], None),
    (b";\\dump_state\n", [b"dump_state:;rotctld Protocol Ver: 1;Rotor Model: 1;"
                          b"Minimum Azimuth: 0.000000;Maximum Azimuth: 400.000000;"
                          b"Minimum Elevation: 0.000000;Maximum Elevation: 180.000000;"
                          b"South Zero: 0;rot_type=AzEl;done;RPRT 0\n"], None),
]


@pytest.mark.parametrize("feed", ["whole", "bytewise"])
@pytest.mark.parametrize("sent,replies,pos", CAPTURES, ids=[repr(c[0]) for c in CAPTURES])
def test_capture(bench, sent, replies, pos, feed):
    b = bench("tartu-urc")
    at(b, *(pos or (10.5, 20.5)))
    s = RotctldSession(b.rot)
    got = fed(s, sent) if feed == "whole" else bytewise(s, sent)
    assert got == replies


@pytest.mark.parametrize("sent,reply", [
    (b"P 1000 0\n", b"RPRT -21\n"),
    (b"+P 1000 0\n", b"set_pos: 1000 0\nRPRT -21\n"),
    (b";P 1000 0\n", b"set_pos: 1000 0;RPRT -21\n"),
])
def test_out_of_range_is_elimit_in_46(tartu, sent, reply):
    s = RotctldSession(tartu.rot, hamlib_version="4.6")
    assert fed(s, sent) == [reply]
    assert idle(tartu)


def test_get_conf_capture_46():
    # protocols.md: `;\get_conf min_az` -> `get_conf: min_az;min_az=-90.000000\nRPRT 0\n`
    b = fresh_bench("sarcnet-mini")  # its azimuth runs from -90
    s = RotctldSession(b.rot, hamlib_version="4.6")
    assert fed(s, b";\\get_conf min_az\n") == [b"get_conf: min_az;min_az=-90.000000\nRPRT 0\n"]
    assert fed(s, b"\\get_conf max_az\n") == [b"max_az=450.000000\n"]


# ---------------------------------------------------------------- \dump_state
@pytest.mark.parametrize("profile,config,limits", [
    ("tartu-urc", {}, "min_az=0.000000\nmax_az=400.000000\nmin_el=0.000000\nmax_el=180.000000"),
    ("berkeley", {}, "min_az=0.000000\nmax_az=360.000000\nmin_el=-45.000000\nmax_el=225.000000"),
    ("sarcnet-mini", {}, "min_az=-90.000000\nmax_az=450.000000\nmin_el=0.000000\nmax_el=180.000000"),
    ("g5500", {"limits": {"el": {"max_deg": 90.0}}},
     "min_az=0.000000\nmax_az=450.000000\nmin_el=0.000000\nmax_el=90.000000"),
    # the frame of status(): mechanical limits plus the mount offsets
    ("g5500", {"offsets": {"az_deg": 10.0, "el_deg": -1.5}},
     "min_az=10.000000\nmax_az=460.000000\nmin_el=-1.500000\nmax_el=178.500000"),
])
def test_dump_state_v1_layout(bench, profile, config, limits):
    b = bench(profile, **config)
    got = fed(RotctldSession(b.rot), b"\\dump_state\n")
    assert got == [f"1\n1\n{limits}\nsouth_zero=0\nrot_type=AzEl\ndone\n".encode()]


def netrotctl_open(reply: bytes) -> dict:
    """What Hamlib 4.5+'s netrotctl rot_open does with a dump_state reply (section 1.5)."""
    lines = reply.decode().split("\n")
    assert int(lines[0]) == 1, "protocol version 1"
    int(lines[1])  # model, ignored
    found = {}
    for line in lines[2:]:
        if line.startswith("done"):
            return found
        key, eq, value = line.partition("=")
        assert eq, f"line without '=': {line!r}"
        found[key] = value
    raise AssertionError("no 'done' line")


def test_dump_state_parses_like_netrotctl(tartu):
    keys = netrotctl_open(fed(RotctldSession(tartu.rot), b"\\dump_state\n")[0])
    assert float(keys["min_az"]) == 0.0 and float(keys["max_az"]) == 400.0
    assert float(keys["max_el"]) == 180.0 and keys["south_zero"] == "0" and keys["rot_type"] == "AzEl"


# --------------------------------------------------------------------- framing
def test_single_char_command_answered_at_once(tartu):
    s = RotctldSession(tartu.rot)
    assert fed(s, b"p") == [b"10.50\n20.50\n"]
    assert fed(s, b"\n") == []  # the line end is skipped


def test_long_name_waits_for_its_terminator(tartu):
    s = RotctldSession(tartu.rot)
    assert fed(s, b"\\get_pos") == []
    assert fed(s, b"\r") == [b"10.50\n20.50\n"]
    assert fed(s, b"\\dump_state") == []
    assert fed(s, b" ")[0].startswith(b"1\n1\nmin_az=")


@pytest.mark.parametrize("sent", [
    b"P 1 2\n", b"P 1\n2\n", b"P\n1\n2\n", b"P 1 2\r\n", b"P 1 2\r", b"P\t1\t2 ", b"\\set_pos 1 2\n",
    b"\\set_pos\n1\r\n2\r\n", b"\n\r\nP 1 2\n",
])
def test_arguments_cross_line_ends(tartu, sent):
    s = RotctldSession(tartu.rot)
    assert fed(s, sent) == [b"RPRT 0\n"]
    tartu.run(0.1)
    assert tartu.rot.status().target_az_deg == pytest.approx(1.0)


def test_incomplete_argument_waits(tartu):
    s = RotctldSession(tartu.rot)
    assert fed(s, b"P 1 2") == []  # "2" may go on: scanf("%s") waits for whitespace
    assert idle(tartu)
    assert fed(s, b"5\n") == [b"RPRT 0\n"]
    tartu.run(0.1)
    assert tartu.rot.status().target_el_deg == pytest.approx(25.0)


def test_several_commands_per_chunk_and_trailing_bytes(tartu):
    s = RotctldSession(tartu.rot)
    got = fed(s, b"p\np\n_\nS\\get_pos\n+p\nP 1")
    assert got == [b"10.50\n20.50\n"] * 2 + [b"urc tartu-urc\n", b"RPRT 0\n", b"10.50\n20.50\n",
                                             b"get_pos:\nAzimuth: 10.50\nElevation: 20.50\nRPRT 0\n"]
    assert fed(s, b" 2\n") == [b"RPRT 0\n"]


def test_every_split_gives_the_same_replies(tartu):
    stream = b"p\n+\\get_pos\n;P 1 2\nV SPEED 40 v SPEED # comment K\n\\dump_state\n_\r\n|s\n"
    whole = fed(RotctldSession(tartu.rot), stream)
    assert len(whole) == 8
    for cut in range(1, len(stream)):
        s = RotctldSession(tartu.rot)
        assert fed(s, stream[:cut]) + fed(s, stream[cut:]) == whole, cut
    assert bytewise(RotctldSession(tartu.rot), stream) == whole


def test_comments_run_to_the_line_end(tartu):
    s = RotctldSession(tartu.rot)
    assert fed(s, b"# K park me\np\n") == [b"10.50\n20.50\n"]
    assert fed(s, b"#K") == [] and fed(s, b" P 1 2 K") == [] and fed(s, b"\rp") == [b"10.50\n20.50\n"]
    assert fed(s, b"+# K\np") == [b"10.50\n20.50\n"]
    assert idle(tartu)


def test_quit_closes_without_reply_and_ignores_the_rest(tartu):
    for q in (b"q", b"Q", b"q\n", b"+q"):
        s = RotctldSession(tartu.rot)
        assert fed(s, b"p\n" + q + b"K\n") == [b"10.50\n20.50\n"]
        assert s.closed
        assert fed(s, b"K\n") == []
    assert idle(tartu)


def test_unknown_commands_are_silent_and_logged(tartu, caplog):
    s = RotctldSession(tartu.rot)
    caplog.set_level("INFO", logger="urc.protocols.rotctld")
    assert fed(s, b"Z\n\\foo\nO\n") == []
    assert "'Z'" in caplog.text and "'\\\\foo'" in caplog.text


def test_unknown_long_name_arguments_become_commands(tartu):
    s = RotctldSession(tartu.rot)
    got = fed(s, b"\\nosuch p _\n")
    assert got == [b"10.50\n20.50\n", b"urc tartu-urc\n"]


def test_prefix_rules(tartu):
    s = RotctldSession(tartu.rot)
    # '+' then another punctuation: that one is the separator
    assert fed(s, b"+;p\n") == [b"get_pos:;Azimuth: 10.50;Elevation: 20.50;RPRT 0\n"]
    assert fed(s, b"++p\n") == [b"get_pos:+Azimuth: 10.50+Elevation: 20.50+RPRT 0\n"]
    # `_` is a command, not a separator; `\` starts a long name after a prefix
    assert fed(s, b";_\n") == [b"get_info:;Info: urc tartu-urc;RPRT 0\n"]
    assert fed(s, b"-\\get_pos\n") == [b"get_pos:-Azimuth: 10.50-Elevation: 20.50-RPRT 0\n"]
    # a prefix followed by a line end or an unknown character is dropped
    assert fed(s, b"+\np\n") == [b"10.50\n20.50\n"]
    assert fed(s, b";;p\n") == [b"10.50\n20.50\n"]
    # the extended header echoes the arguments as typed (decimal comma included)
    assert fed(s, b"+P 10,5 20,5\n") == [b"set_pos: 10,5 20,5\nRPRT 0\n"]


# ------------------------------------------------------------------ P / set_pos
@pytest.mark.parametrize("args,az,el", [
    ("+10 1e1", 10.0, 10.0), ("180,50 45,25", 180.5, 45.25), ("10. .5", 10.0, 0.5),
    ("123.400000 45.600000", 123.4, 45.6), ("-90.00 10.00", 270.0, 10.0),
    ("-180 5", 180.0, 5.0), ("359.99 0", 359.99, 0.0),
])
def test_set_pos_values(tartu, args, az, el):
    s = RotctldSession(tartu.rot)
    assert fed(s, f"P {args}\n".encode()) == [b"RPRT 0\n"]
    tartu.run(0.1)
    st_ = tartu.rot.status()
    assert (st_.target_az_deg, st_.target_el_deg) == pytest.approx((az, el))


@pytest.mark.parametrize("args", [
    "nan 0", "0 nan", "abc 1", "inf 0", "-inf 0", "1e999 0", "10abc 5", "0x10 5", "1,2,3 4",
    "1.5.3 4", "10 20abc", "?", "?5", "1_0 5", "١٢ 5", "+-1 5", ". 5", "e5 5",
])
def test_set_pos_garbage_is_einval_and_never_moves(tartu, args):
    for version in ("4.5", "4.6"):
        rec = Recorder(tartu.rot)
        s = RotctldSession(rec, hamlib_version=version)
        assert fed(s, f"P {args}\n".encode()) == [b"RPRT -1\n"]
        assert rec.calls == []
    assert idle(tartu)


@pytest.mark.parametrize("version,code", [("4.5", -1), ("4.6", -21)])
@pytest.mark.parametrize("args", ["1000 0", "401 10", "-181 10", "10 -1", "10 180.5", "360.5 200"])
def test_set_pos_out_of_range(tartu, version, code, args):
    rec = Recorder(tartu.rot)
    s = RotctldSession(rec, hamlib_version=version)
    assert fed(s, f"P {args}\n".encode()) == [f"RPRT {code}\n".encode()]
    assert rec.calls == [] and idle(tartu)


def test_set_pos_inside_the_wrap_range_is_a_wrap_pose(bench):
    b = bench("g5500")
    s = RotctldSession(b.rot)
    assert fed(s, b"P 400 20\n") == [b"RPRT 0\n"]
    b.settle()
    assert b.truth("az") == pytest.approx(400.0, abs=1.5)  # the overlap, not 40
    az, el = (float(x) for x in fed(s, b"p\n")[0].split())
    assert az == pytest.approx(40.0, abs=1.0) and el == pytest.approx(20.0, abs=1.0)
    assert "OVERLAP_RIGHT" in fed(s, b"s\n")[0].decode().split()


def test_set_pos_negative_azimuth_within_the_range_is_passed_unchanged():
    b = fresh_bench("sarcnet-mini")  # azimuth -90..450
    s = RotctldSession(b.rot)
    assert fed(s, b"P -45 10\n") == [b"RPRT 0\n"]
    b.settle()
    assert b.truth("az") == pytest.approx(-45.0, abs=1.5)  # CCW of north, not 315
    assert "OVERLAP_LEFT" in fed(s, b"s\n")[0].decode().split()


def test_set_pos_with_offsets_accepts_any_compass_azimuth(bench):
    b = bench("g5500", offsets={"az_deg": 10.0})  # advertises 10..460
    s = RotctldSession(b.rot)
    assert fed(s, b"P 5 10\n") == [b"RPRT 0\n"]  # sky az 5 = mechanical 355
    b.settle()
    assert b.rot.status().az_deg == pytest.approx(5.0, abs=1.0)


def test_rejections_map_to_rprt_codes(bench):
    mast = {"name": "mast", "az_min_deg": 80.0, "az_max_deg": 100.0, "el_min_deg": 0.0, "el_max_deg": 20.0}
    b = bench("berkeley", keepout=[mast])
    for version, code in (("4.5", b"RPRT -1\n"), ("4.6", b"RPRT -21\n")):
        assert fed(RotctldSession(b.rot, hamlib_version=version), b"P 90 10\n") == [code]
    for _ in range(b.rot.timing.latch_stalls):
        b.rot.note_lateness(2.0)  # stalls that keep happening: a latched fault (watchdog)
    b.run(0.1)
    s = RotctldSession(b.rot)
    assert fed(s, b"P 10 10\nK\nM 2 50\n") == [b"RPRT -9\n"] * 3
    assert "BUSY" in fed(s, b"s\n")[0].decode()
    assert fed(s, b"R 1\n") == [b"RPRT 0\n"]  # stop + clear faults
    b.run(0.1)
    assert not b.rot.status().faults
    assert fed(s, b"P 10 10\n") == [b"RPRT 0\n"]


# ---------------------------------------------------------------------- M / move
def az_el_rates(b, seconds: float = 2.0) -> tuple[float, float]:
    """Mean speed of each axis over ``seconds``, after one second to get going."""
    b.run(1.0)
    s0 = b.rot.status()
    b.run(seconds)
    s1 = b.rot.status()
    return (s1.az.pos_deg - s0.az.pos_deg) / seconds, (s1.el.pos_deg - s0.el.pos_deg) / seconds


@pytest.mark.parametrize("direction,sign_az,sign_el", [
    ("2", 0, 1), ("UP", 0, 1), ("4", 0, -1), ("DOWN", 0, -1), ("8", -1, 0), ("LEFT", -1, 0),
    ("CCW", -1, 0), ("16", 1, 0), ("RIGHT", 1, 0), ("CW", 1, 0),
])
def test_move_directions(bench, direction, sign_az, sign_el):
    b = bench("tartu-urc")
    go(b, 200.0, 45.0)
    s = RotctldSession(b.rot)
    assert fed(s, f"M {direction} 50\n".encode()) == [b"RPRT 0\n"]
    az_rate, el_rate = az_el_rates(b)
    for sign, rate in ((sign_az, az_rate), (sign_el, el_rate)):
        if sign:
            assert rate * sign == pytest.approx(3.0, rel=0.15)  # 50 % of 6 deg/s
        else:
            assert abs(rate) < 0.05
    flags = fed(s, b"s\n")[0].decode().split()
    assert "MOVING" in flags
    name = {(0, 1): "MOVING_UP", (0, -1): "MOVING_DOWN", (-1, 0): "MOVING_LEFT", (1, 0): "MOVING_RIGHT"}
    assert name[(sign_az, sign_el)] in flags
    assert fed(s, b"S\n") == [b"RPRT 0\n"]
    b.settle()
    assert fed(s, b"s\n") == [b"\n"]


@pytest.mark.parametrize("direction,sign_az,sign_el", [
    ("32", -1, 1), ("UP_LEFT", -1, 1), ("UP_CCW", -1, 1), ("64", 1, 1), ("UP_CW", 1, 1),
    ("128", -1, -1), ("DOWN_CCW", -1, -1), ("256", 1, -1), ("DOWN_RIGHT", 1, -1),
])
def test_move_diagonals_46_only(bench, direction, sign_az, sign_el):
    b = bench("tartu-urc")
    go(b, 200.0, 45.0)
    assert fed(RotctldSession(b.rot), f"M {direction} 20\n".encode()) == [b"RPRT -1\n"]
    assert az_el_rates(b) == (0.0, 0.0)
    assert fed(RotctldSession(b.rot, hamlib_version="4.6"), f"M {direction} 20\n".encode()) == [b"RPRT 0\n"]
    az_rate, el_rate = az_el_rates(b)
    assert az_rate * sign_az == pytest.approx(1.2, rel=0.2) and el_rate * sign_el == pytest.approx(1.2, rel=0.2)


def test_move_speed_level_and_no_change(bench):
    b = bench("tartu-urc")
    go(b, 200.0, 45.0)
    s = RotctldSession(b.rot)
    assert fed(s, b"V SPEED 25\nM RIGHT -1\n") == [b"RPRT 0\n", b"RPRT 0\n"]
    assert az_el_rates(b)[0] == pytest.approx(1.5, rel=0.15)  # 25 % of 6 deg/s
    assert fed(s, b"V SPEED 100\nM RIGHT -1\n") == [b"RPRT 0\n", b"RPRT 0\n"]
    assert az_el_rates(b)[0] == pytest.approx(6.0, rel=0.1)


@pytest.mark.parametrize("args", ["2 0", "2 101", "2 -2", "2 50.5", "3 50", "0 50", "up 50", "FOO 50",
                                  "UPLEFT 10", "2 abc", "? 5", "2 nan"])
def test_move_garbage_is_einval_and_never_moves(tartu, args):
    rec = Recorder(tartu.rot)
    for version in ("4.5", "4.6"):
        assert fed(RotctldSession(rec, hamlib_version=version), f"M {args}\n".encode()) == [b"RPRT -1\n"]
    assert rec.calls == [] and idle(tartu)


# --------------------------------------------------------------- K, S, R, s, _
def test_park_stop_reset(bench):
    b = bench("tartu-urc")
    go(b, 100.0, 30.0)
    s = RotctldSession(b.rot)
    assert fed(s, b"K\n") == [b"RPRT 0\n"]
    b.settle()
    assert b.rot.status().parked
    # tartu parks at az 0 el 90 (az 0 is its limit: the service's guard stops ~1.5 short)
    assert (b.truth("az"), b.truth("el")) == pytest.approx((0.0, 90.0), abs=2.0)
    assert fed(s, b"P 180 10\n") == [b"RPRT 0\n"]
    b.run(6.0)
    assert fed(s, b"S\n") == [b"RPRT 0\n"]
    b.settle()
    assert 20.0 < b.truth("az") < 150.0  # stopped on the way
    assert fed(s, b"P 180 10\n") == [b"RPRT 0\n"]
    b.run(1.0)
    assert fed(s, b"R 1\n") == [b"RPRT 0\n"]  # reset stops too
    b.settle()
    assert b.truth("az") < 170.0
    assert fed(s, b"R x\n") == [b"RPRT -1\n"]


def test_status_while_moving_up(bench):
    # capture: `MOVING MOVING_EL MOVING_UP \n`
    b = bench("tartu-urc")
    go(b, 10.0, 10.0)
    s = RotctldSession(b.rot)
    fed(s, b"P 10 60\n")
    b.run(2.0)
    assert fed(s, b"s\n") == [b"MOVING MOVING_EL MOVING_UP \n"]
    assert fed(s, b";s\n") == [b"get_status:;Status flags: MOVING MOVING_EL MOVING_UP ;RPRT 0\n"]


def test_limit_switch_flag():
    b = fresh_bench("bigras")
    b.world.inject("az", "limit_switch", which="max")
    b.run(0.5)
    assert "LIMIT_RIGHT" in fed(RotctldSession(b.rot), b"s\n")[0].decode().split()


def test_position_reported_while_moving_is_current(bench):
    b = bench("tartu-urc")
    go(b, 0.0, 0.0)
    s = RotctldSession(b.rot)
    fed(s, b"P 90 0\n")
    seen = []
    for _ in range(5):
        b.run(2.0)
        seen.append(float(fed(s, b"p\n")[0].split()[0]))
        assert seen[-1] == pytest.approx(b.rot.status().az_deg, abs=0.006)
    assert seen == sorted(seen) and seen[0] > 0.0 and seen[-1] < 90.0


# ---------------------------------------------------------------- levels, conf, misc
def test_levels(tartu):
    s = RotctldSession(tartu.rot)
    assert fed(s, b"v SPEED\n") == [b"100\n"]
    assert fed(s, b"v ?\n") == [b"SPEED \n"]
    assert fed(s, b"+v ?\n") == [b"get_level: ?\nSPEED \nRPRT 0\n"]
    assert fed(s, b"+V ?\n") == [b"set_level: ?\nSPEED \nRPRT 0\n"]
    assert fed(s, b"V SPEED 0\nV SPEED 101\nV SPEED x\nV SPEED ?\n") == [b"RPRT -1\n"] * 4
    assert fed(s, b"V FOO 1\n") == [b"RPRT -11\n"]
    assert fed(s, b"v FOO\n") == [b"RPRT -1\n"]
    assert fed(s, b"V SPEED 7\n;v SPEED\n") == [b"RPRT 0\n", b"get_level: SPEED;7\nRPRT 0\n"]
    assert s.speed == 7


def test_funcs_and_parms(tartu):
    s = RotctldSession(tartu.rot)
    assert fed(s, b"U ?\nu ?\nX ?\nx ?\n") == [b"\nRPRT 0\n", b"\n", b"\nRPRT 0\n", b"\n"]
    assert fed(s, b"U FOO 1\nu FOO\nX FOO 1\nx FOO\n") == \
        [b"RPRT -11\n", b"RPRT -1\n", b"RPRT -1\n", b"RPRT -1\n"]


def test_conf(tartu):
    s = RotctldSession(tartu.rot)
    assert fed(s, b"\\get_conf min_az\n\\get_conf max_az\n\\get_conf min_el\n"
                     b"\\get_conf max_el\n\\get_conf south_zero\n") == [
        b"min_az=0.000000\n", b"max_az=400.000000\n", b"min_el=0.000000\n", b"max_el=180.000000\n",
        b"south_zero=0\n"]
    assert fed(s, b"\\get_conf foo\n") == [b"RPRT -1\n"]
    # limits and the azimuth frame are the rotator's: changing them is not available
    assert fed(s, b"C min_az -90\nC max_el 90\nC south_zero 1\n") == [b"RPRT -11\n"] * 3
    # ... and saying what they already are is fine
    assert fed(s, b"C min_az 0\n\\set_conf max_az 400.0\nC south_zero 0\n") == [b"RPRT 0\n"] * 3
    assert fed(s, b"C foo 1\nC min_az abc\n") == [b"RPRT -1\n"] * 2
    assert fed(s, b"+C min_az -90\n") == [b"set_conf: min_az -90\nRPRT -11\n"]
    assert fed(s, b"\\dump_state\n")[0].startswith(b"1\n1\nmin_az=0.000000\n")
    assert idle(tartu)


def test_conf_list(tartu):
    assert fed(RotctldSession(tartu.rot), b"C ?\n") == [b"RPRT -1\n"]  # 4.5
    s = RotctldSession(tartu.rot, hamlib_version="4.6")
    listing = fed(s, b"C ?\n")[0].decode()
    assert listing.startswith('min_az: "Minimum rotator azimuth in degrees"\n\tDefault: -180, Value: 0.000000\n')
    assert "south_zero" in listing and listing.endswith("\tCheckbox: 0,1\nRPRT 0\n")
    assert fed(s, b"3\n") == [listing.encode()]
    assert fed(s, b"\\get_conf ?\n") == [listing[:-len("RPRT 0\n")].encode()]


def test_dump_caps(tartu):
    s = RotctldSession(tartu.rot)
    caps = fed(s, b"1\n")[0].decode()
    assert caps.startswith("Caps dump for model:\t1\nModel name:\t\turc tartu-urc\n")
    assert "Max Azimuth:\t\t400.00\n" in caps and "Can set Position:\tY\n" in caps
    assert caps.endswith("\nOverall backend warnings: 0\nRPRT 0\n")
    assert fed(s, b"+1\n")[0].decode() == "dump_caps:\n" + caps


def test_helpers_not_offered_but_read_their_arguments(tartu):
    s = RotctldSession(tartu.rot)
    # each helper's arguments are consumed: the digits are not run as dump_caps etc.
    got = fed(s, b"L 1 2 3\nl JO\nD 1 2 3 4\nd 1\nE 1 2 3\ne 1\nB 1 2 3 4\nA 1\na 1\n"
                    b"\\pause 1\nw K K K\np\n")
    assert got == [b"RPRT -11\n"] * 11 + [b"10.50\n20.50\n"]
    assert idle(tartu)


# ------------------------------------------------------------- bounded buffers
def test_overlong_argument_is_dropped_answered_and_resynchronised(tartu, caplog):
    s = RotctldSession(tartu.rot)
    junk = b"9" * (MAX_PENDING_BYTES + 10)
    got = []
    for i in range(0, len(junk), 1000):
        got += fed(s, (b"P 1 " if i == 0 else b"") + junk[i:i + 1000])
    assert got == [b"RPRT -1\n"]  # gpredict waits for an answer to every P
    # the rest of the cut word is not read as commands (9s, and a K glued to it)
    assert fed(s, b"999K1K p\n") == [b"10.50\n20.50\n"]
    assert idle(tartu) and "unfinished command" in caplog.text


def test_overlong_long_name_and_comment(tartu):
    s = RotctldSession(tartu.rot)
    assert fed(s, b"\\" + b"x" * (MAX_PENDING_BYTES + 5)) == []
    assert fed(s, b"xxK p\n") == [b"10.50\n20.50\n"]
    fed(s, b"#" + b" K" * 5000)  # a comment is skipped, however long, never buffered
    assert fed(s, b" K P 1 2\np\n") == [b"10.50\n20.50\n"]
    assert idle(tartu)


def test_lexer_items():
    lx = Lexer()
    items = lx.feed(b"+P 1 2 ;\\get_conf min_az Z q p")
    assert items[0] == (CMD, BY_NAME["set_pos"], ("1", "2"), "\n")
    assert items[1] == (CMD, BY_NAME["get_conf"], ("min_az",), ";")
    assert items[2][:1] == (UNKNOWN,) and items[2][2] == ("Z", 1)
    assert items[3][0] == CLOSE and len(items) == 4
    assert all(c.name in BY_NAME for c in COMMANDS)


# ---------------------------------------------------------------- client exchanges
def test_hamlib_netrotctl_exchange_45(bench):
    """Section 1.6: `rotctl -m 2 ... P 100 20 p S K R 1 M 2 50 M 64 10 _` (4.5.4 bytes)."""
    b = bench("tartu-urc")
    at(b, 10.5, 20.5)
    s = RotctldSession(b.rot)
    keys = netrotctl_open(fed(s, b"\\dump_state\n")[0])
    assert float(keys["max_az"]) >= 100.0
    assert fed(s, b"P 100.000000 20.000000\n") == [b"RPRT 0\n"]
    b.run(2.0)
    az, el = fed(s, b"p\n")[0].split(b"\n")[:2]  # atof of two lines
    assert 10.5 < float(az) < 100.0
    for cmd in (b"S\n", b"K\n", b"R 1\n", b"M 2 50\n"):
        reply = fed(s, cmd)
        assert reply == [b"RPRT 0\n"], cmd  # the client reads the first line only
    assert fed(s, b"M 64 10\n") == [b"RPRT -1\n"]  # a 4.5 server has no diagonals
    assert fed(s, b"_\n") == [b"urc tartu-urc\n"]
    assert fed(s, b"q\n") == [] and s.closed


def test_hamlib_netrotctl_exchange_46(bench):
    b = bench("tartu-urc")
    at(b, 100.0, 20.0)
    s = RotctldSession(b.rot, hamlib_version="4.6")
    fed(s, b"\\dump_state\n")
    assert fed(s, b"M 64 10\n") == [b"RPRT 0\n"]  # up and right
    az_rate, el_rate = az_el_rates(b, 2.0)
    assert az_rate > 0.3 and el_rate > 0.3
    assert fed(s, b"S\nq\n") == [b"RPRT 0\n"] and s.closed


class Gpredict:
    """gpredict's rotator thread (gtk-rot-ctrl.c, v2.2.1 .. master), for one session.

    Sets with ``P %.2f %.2f\\n`` in the process locale, reads with ``p\\n``; one recv()
    for each, judged as gpredict does.
    """

    def __init__(self, session, decimal_comma: bool):
        self.s = session
        self.comma = decimal_comma
        self.errors = 0

    def set(self, az: float, el: float) -> None:
        text = "P %.2f %.2f\n" % (az, el)
        if self.comma:
            text = text.replace(".", ",")
        replies = fed(self.s, text.encode())
        assert len(replies) == 1, "gpredict reads one recv(); a missing reply hangs it"
        if float(replies[0][4:].split()[0]) != 0:  # strtod(buf + 4)
            self.errors += 1

    def get(self) -> tuple[float, float]:
        replies = fed(self.s, b"p\n")
        assert len(replies) == 1, "both lines must come in one segment"
        buf = replies[0]
        assert not buf.startswith(b"RPRT")
        parts = buf.decode().split("\n", 2)
        return float(parts[0]), float(parts[1])

    def close(self) -> None:
        assert fed(self.s, b"q\n") == [] and self.s.closed


def test_gpredict_bytes(tartu):
    """Section 1.7's exact requests: `P %.2f %.2f\n` (C and comma locale, -180..180 mode),
    `p\n`, `q\n`; every reply one segment."""
    s = RotctldSession(tartu.rot)
    for sent, target in ((b"P 180.00 45.00\n", (180.0, 45.0)), (b"P -90.00 10.00\n", (270.0, 10.0)),
                         (b"P 180,00 45,00\n", (180.0, 45.0)), (b"P 123,45 6,70\n", (123.45, 6.7))):
        assert fed(s, sent) == [b"RPRT 0\n"]
        tartu.run(0.05)
        st_ = tartu.rot.status()
        assert (st_.target_az_deg, st_.target_el_deg) == pytest.approx(target)
        assert fed(s, b"p\n") == [b"%.2f\n%.2f\n" % (st_.az_deg, st_.el_deg)]
    assert fed(s, b"q\n") == [] and s.closed


@pytest.mark.parametrize("comma", [False, True], ids=["C-locale", "de_DE-locale"])
def test_gpredict_tracks_a_pass(bench, comma):
    b = bench("tartu-urc")  # starts at its park, az 0 el 90
    g = Gpredict(RotctldSession(b.rot), decimal_comma=comma)
    # gpredict in -180..180 mode sends west as negative; 5-degree threshold, ~0.8 s loop
    track = [(-60.0 + 2.0 * i, 5.0 + 1.5 * i) for i in range(40)]
    last = None
    for az, el in track:
        pos = g.get()
        if last is None or abs(((az - pos[0]) + 180) % 360 - 180) > 5 or abs(el - pos[1]) > 5:
            g.set(az, el)
            last = (az, el)
        b.run(0.8)
    b.settle()
    az, el = g.get()
    assert g.errors == 0
    assert az == pytest.approx(last[0] % 360, abs=0.3) and el == pytest.approx(last[1], abs=0.3)
    assert az == pytest.approx(b.truth("az") % 360, abs=0.3) and el == pytest.approx(b.truth("el"), abs=0.3)
    g.close()


def test_gpredict_error_reply_is_a_single_rprt(tartu):
    g = Gpredict(RotctldSession(tartu.rot), decimal_comma=True)
    g.set(10.0, 95.5)  # beyond 90 on a flip rotator is allowed: 95,50 -> 95.5
    g.set(10.0, -5.0)
    assert g.errors == 1


def test_radiosonde_auto_rx_connection_per_command(bench):
    """Section 1.8: a new connection per operation, `P %.1f %.1f\\n` or `p\\n`, never `q`."""
    b = bench("berkeley")
    for az, el in ((123.4, 12.3), (250.0, 45.6)):
        reply = fed(RotctldSession(b.rot), b"P %.1f %.1f\n" % (az, el))
        assert b"RPRT 0" in reply[0]
        b.settle()
        lines = fed(RotctldSession(b.rot), b"p\n")[0].decode().split("\n")
        assert not lines[0].startswith("RPRT")
        assert (float(lines[0]), float(lines[1])) == pytest.approx((az, el), abs=0.2)
        assert float(lines[0]) == pytest.approx(b.truth("az") % 360, abs=0.2)


# ------------------------------------------------------------------ fuzzing
_BENCH: dict[str, Bench] = {}


def shared_bench() -> Bench:
    """One rotator for every fuzz example: the property keeps it still, so it stays clean."""
    if "b" not in _BENCH:
        _BENCH["b"] = fresh_bench("tartu-urc")
        at(_BENCH["b"], 10.5, 20.5)
    return _BENCH["b"]


_MOVERS = (b"K", b"P", b"M", b"park", b"move", b"set_pos")


def check_no_motion_and_bounded(chunks: list[bytes]) -> None:
    b = shared_bench()
    rec = Recorder(b.rot)
    s = RotctldSession(rec, hamlib_version="4.6")
    replies = []
    for chunk in chunks:
        replies += fed(s, chunk)
    total = sum(len(c) for c in chunks)
    assert len(replies) <= total and all(0 < len(r) <= 4096 for r in replies)
    assert all(r.endswith(b"\n") for r in replies)
    assert rec.calls == [] and idle(b), f"moved on {b''.join(chunks)!r}"


@settings(max_examples=150, deadline=None)
@given(st.lists(st.binary(max_size=64).map(lambda c: c.translate(None, b"KPM")), max_size=8))
@raises_nothing
def test_fuzz_random_bytes_never_move(chunks):
    assume(not any(m in b"".join(chunks) for m in _MOVERS))
    check_no_motion_and_bounded(chunks)


_BAD_NUMBERS = ["nan", "NaN", "inf", "-inf", "1e999", "abc", "10abc", "0x10", "1,2,3", "?", "--1", ".",
                "1..2", "DOWN_", "LEFTx", "UPLEFT", "2.5.", "1e", "+", "-", "infinity", "e5", "9,9,9"]
# No token here may parse as a finite number: "P P P 3 3" is a valid set_pos (the last P
# takes both 3s), which is why dump_conf's "3" is not in the list.
_COMMANDS = ["P", "\\set_pos", "M", "\\move", "p", "S", "s", "_", "v", "V", "C", "\\get_conf",
             "\\dump_state", "R", "#", "+", ";", "?", "|", "\\nosuch", "SPEED", "min_az", "w"]
_SEPARATORS = [" ", "\n", "\r\n", "\t", "\r", ""]


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(_COMMANDS + _BAD_NUMBERS), st.sampled_from(_SEPARATORS)),
                max_size=30),
       st.integers(min_value=1, max_value=7))
@raises_nothing
def test_fuzz_token_streams_without_valid_motion_never_move(tokens, chunk):
    stream = "".join(t + sep for t, sep in tokens).encode()
    check_no_motion_and_bounded([stream[i:i + chunk] for i in range(0, len(stream), chunk)])


_ANY_ARG = st.one_of(st.sampled_from(_BAD_NUMBERS + ["2", "UP", "CW", "SPEED", "50", "-1", "1"]),
                     st.floats(min_value=-500, max_value=500).map(lambda x: f"{x:.2f}"))


@st.composite
def command_streams(draw):
    """Whole commands (each with all its arguments), valid or not."""
    out = []
    for _ in range(draw(st.integers(0, 8))):
        name = draw(st.sampled_from(["P", "\\set_pos", "M", "p", "S", "K", "R", "V", "v", "_", "s",
                                     "\\dump_state", "\\get_conf", "C", "1"]))
        prefix = draw(st.sampled_from(["", "", "+", ";", "|"]))
        n = {"P": 2, "\\set_pos": 2, "M": 2, "R": 1, "V": 2, "v": 1, "\\get_conf": 1, "C": 2}.get(name, 0)
        args = [draw(_ANY_ARG) for _ in range(n)]
        if args and args[0].startswith("?"):
            args = args[:1]
        out.append(prefix + " ".join([name] + args) + draw(st.sampled_from(["\n", "\r\n", " "])))
    return out


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(command_streams())
@raises_nothing
def test_fuzz_every_command_gets_one_reply_whatever_the_split(commands):
    stream = "".join(commands).encode()
    b1, b2 = fresh_bench(), fresh_bench()
    whole = fed(RotctldSession(b1.rot), stream)
    assert len(whole) == len(commands)
    assert bytewise(RotctldSession(b2.rot), stream) == whole
    for cmd, reply in zip(commands, whole):
        if cmd.startswith(("P", "\\set_pos", "M", "K")):
            assert reply.startswith(b"RPRT ") and reply.endswith(b"\n") and reply.count(b"\n") == 1
