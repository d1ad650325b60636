"""Tests for urc.config: defaults, the example file, every error path, TOML round trip."""

from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel

from urc.config import EXAMPLE_CONFIG, Config, KeepoutZone, ServeEntry, load_config, loads_config
from urc.errors import ConfigError
from urc.profiles import PROFILES, get_profile


def write(tmp_path: Path, text: str | bytes, name: str = "urc.toml") -> Path:
    p = tmp_path / name
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text, encoding="utf-8")
    return p


def load_error(tmp_path: Path, text: str | bytes) -> tuple[ConfigError, Path]:
    p = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_config(p)
    return info.value, p


def assert_names(err: ConfigError, path: Path | str, key: str | None, *words: str) -> str:
    """The message names the file, the key, what was expected and what was found."""
    msg = str(err)
    first = msg.splitlines()[0]
    assert str(path) in first
    assert err.path == str(path)
    if key is not None:
        assert f": {key}:" in first, first
        assert err.key == key
    assert "expected" in first and "found" in first, first
    assert err.expected
    for w in words:
        assert w in first, (w, first)
    return first


# --------------------------------------------------------------------------- defaults


def test_defaults_without_file():
    cfg = load_config(None)
    assert cfg == Config()
    assert cfg.rotator.profile == "tartu-urc"
    assert cfg.rotator.loop_hz == 50.0
    assert cfg.rotator.flip == "auto"
    assert cfg.hardware.backend == "sim"
    assert cfg.hardware.sim.seed == 1 and cfg.hardware.sim.wind is True
    assert cfg.hardware.sim.start_az_deg is None
    assert cfg.limits.az.min_deg is None and cfg.limits.el.max_deg is None
    assert cfg.offsets.az_deg == 0.0 and cfg.offsets.el_deg == 0.0
    assert cfg.park.az_deg is None and cfg.park.idle_park_s == 0
    assert cfg.keepout == ()
    assert cfg.control.az.kp_per_s == 6.0 and cfg.control.el.ki_per_s2 == 1.0
    assert cfg.faults.stall_timeout_s == 1.5 and cfg.faults.watchdog_s == 0.5
    assert cfg.api.host == "127.0.0.1" and cfg.api.port == 8080 and cfg.api.token == ""
    assert cfg.state.dir == "" and cfg.state.save_interval_s == 1.0
    assert cfg.control_requires_token is False


def test_empty_file_is_defaults(tmp_path):
    assert load_config(write(tmp_path, "")) == Config()


def test_frozen():
    cfg = Config()
    with pytest.raises(Exception):
        cfg.rotator.loop_hz = 10.0  # type: ignore[misc]


def test_helpers_use_profile_values():
    cfg = Config()
    caps = get_profile("tartu-urc")
    assert cfg.effective_limits(caps) == {"az": (0.0, 400.0), "el": (0.0, 180.0)}
    assert cfg.park(caps) == (0.0, 90.0)
    ctl = cfg.effective_control(caps)
    assert ctl["az"]["max_rate_deg_per_s"] == 6.0 and ctl["az"]["restart_deg"] == 0.2
    assert ctl["el"]["kp_per_s"] == 6.0


def test_helpers_apply_user_values():
    cfg = Config.from_dict({
        "rotator": {"profile": "bigras"},
        "limits": {"az": {"min_deg": 10, "max_deg": 350}, "el": {"max_deg": 80}},
        "park": {"az_deg": 180, "el_deg": 5},
        "control": {"az": {"max_rate_deg_per_s": 2.5, "tolerance_deg": 0.6, "creep_lead_deg": 0.4,
                           "backlash_deg": 0.3}},
    })
    caps = get_profile("bigras")
    assert cfg.effective_limits(caps) == {"az": (10.0, 350.0), "el": (0.0, 80.0)}
    assert cfg.park(caps) == (180.0, 5.0)
    ctl = cfg.effective_control(caps)
    assert ctl["az"]["max_rate_deg_per_s"] == 2.5 and ctl["az"]["tolerance_deg"] == 0.6
    assert ctl["az"]["creep_lead_deg"] == 0.4 and ctl["az"]["backlash_deg"] == 0.3
    assert ctl["el"]["max_rate_deg_per_s"] == 2.0
    assert ctl["el"]["creep_lead_deg"] == caps.el.creep_lead_deg and ctl["el"]["backlash_deg"] == 0.0


def test_ints_accepted_for_floats(tmp_path):
    cfg = load_config(write(tmp_path, "[rotator]\nloop_hz = 100\n[park]\nidle_park_s = 0\n"))
    assert cfg.rotator.loop_hz == 100.0 and isinstance(cfg.rotator.loop_hz, float)


@pytest.mark.parametrize("host,remote", [
    ("127.0.0.1", False), ("localhost", False), ("::1", False), ("127.0.1.1", False),
    ("0.0.0.0", True), ("192.168.1.5", True), ("::", True), ("station.example", True),
])
def test_control_requires_token(host, remote):
    cfg = Config.from_dict({"api": {"host": host}})  # empty token allowed
    assert cfg.control_requires_token is remote
    assert cfg.api.control_requires_token is remote


def test_state_dir_resolution(tmp_path):
    import platformdirs

    assert Config().state.resolve_dir() == Path(platformdirs.user_data_dir("urc"))
    cfg = Config.from_dict({"state": {"dir": str(tmp_path)}})
    assert cfg.state.resolve_dir() == tmp_path
    assert cfg.state.resolve_dir(tmp_path / "x") == tmp_path / "x"


def test_keepout_wraps_across_north():
    z = KeepoutZone(name="tree", az_min_deg=350, az_max_deg=10, el_min_deg=0, el_max_deg=20).keep_out(0)
    assert z.az_width_deg == 20
    assert z.contains(355, 5) and z.contains(5, 5) and z.contains(365, 5)
    assert not z.contains(20, 5) and not z.contains(355, 30)


# --------------------------------------------------------------------------- example


def test_example_parses_to_defaults(tmp_path):
    assert load_config(write(tmp_path, EXAMPLE_CONFIG)) == Config()


def test_example_mentions_every_key():
    """Every key of the schema appears in the example, set or commented out."""
    def keys(model, prefix=""):
        for name in type(model).model_fields:
            value = getattr(model, name)
            if isinstance(value, BaseModel):
                yield from keys(value, f"{prefix}{name}.")
            else:
                yield prefix, name
    text = EXAMPLE_CONFIG
    for prefix, name in keys(Config()):
        if name in ("keepout", "serve"):
            assert f"[[{name}]]" in text
            continue
        assert re.search(rf"^#? ?{name} = ", text, re.M), f"{prefix}{name} missing"
    for field in KeepoutZone.model_fields:
        assert re.search(rf"^# {field} = ", text, re.M), field
    for field in ServeEntry.model_fields:
        assert re.search(rf"^# {field} = ", text, re.M), field


def test_example_keepout_block_is_valid():
    """The commented [[keepout]] block, uncommented, is a valid zone."""
    block = EXAMPLE_CONFIG[EXAMPLE_CONFIG.index("# [[keepout]]"):]
    lines = []
    for line in block.splitlines():
        if not line.startswith("# "):
            break
        lines.append(line[2:])
    cfg = loads_config("\n".join(lines))
    assert cfg.keepout[0].name == "mast"


# --------------------------------------------------------------------------- round trip


def test_to_toml_round_trip_defaults():
    cfg = Config()
    assert loads_config(cfg.to_toml()) == cfg


def test_to_toml_round_trip_everything_set():
    cfg = Config.from_dict({
        "rotator": {"profile": "g5500", "loop_hz": 20, "flip": True},
        "hardware": {"backend": "sim", "sim": {"seed": -7, "wind": False,
                                               "start_az_deg": 12.5, "start_el_deg": 1e-5}},
        "limits": {"az": {"min_deg": 5, "max_deg": 445.25}, "el": {"min_deg": 0.5,
                                                                  "max_deg": 179}},
        "offsets": {"az_deg": -3.3, "el_deg": 0.1},
        "park": {"az_deg": 180, "el_deg": 90, "idle_park_s": 600},
        "keepout": [
            {"name": 'roof "north"\n\\', "az_min_deg": 350, "az_max_deg": 10,
             "el_min_deg": -5, "el_max_deg": 15},
            {"name": "mäst ☃", "az_min_deg": 80, "az_max_deg": 100, "el_min_deg": 0,
             "el_max_deg": 20},
        ],
        "control": {"az": {"tolerance_deg": 0.5, "restart_deg": 1.5, "max_rate_deg_per_s": 3,
                           "accel_deg_per_s2": 20, "kp_per_s": 1.25, "ki_per_s2": 0,
                           "overshoot_deg": 0.2}},
        "faults": {"stall_timeout_s": 2, "runaway_deg": 4, "sensor_jump_deg": 6,
                   "overcurrent_a": 3.5, "watchdog_s": 0.25},
        "api": {"host": "0.0.0.0", "port": 4533, "token": "s3cr3t"},
        "state": {"dir": "/var/lib/urc", "save_interval_s": 0.5},
    })
    text = cfg.to_toml()
    tomllib.loads(text)  # valid TOML
    assert loads_config(text) == cfg
    assert cfg.control_requires_token


def test_to_toml_writes_a_lone_surrogate_as_a_replacement_character():
    """A JSON string can carry one (\\ud800); tomlkit would write it raw, and the text
    could then not be encoded to a file or a terminal."""
    cfg = Config.from_dict({"station": {"name": "mast \ud800"}})
    text = cfg.to_toml()
    text.encode("utf-8")
    assert loads_config(text).station.name == "mast \ufffd"


# --------------------------------------------------------------------------- error paths


def test_wrong_type(tmp_path):
    err, p = load_error(tmp_path, '[limits.az]\nmax_deg = "abc"\n')
    first = assert_names(err, p, "limits.az.max_deg", "a number (degrees)", "'abc' (str)")
    assert first == f"{p}: limits.az.max_deg: expected a number (degrees), found 'abc' (str)"
    assert err.found == "abc"


@pytest.mark.parametrize("text,key,words", [
    ("[rotator]\nflip = 1\n", "rotator.flip", ['true, false or "auto"', "1 (int)"]),
    ("[api]\nport = 80.5\n", "api.port", ["an integer", "80.5 (float)"]),
    ("[api]\nport = \"8080\"\n", "api.port", ["an integer", "'8080' (str)"]),
    ("[rotator]\nloop_hz = true\n", "rotator.loop_hz", ["a number (Hz)", "True (bool)"]),
    ("[api]\ntoken = 1234\n", "api.token", ["a string", "1234 (int)"]),
    ("rotator = 3\n", "rotator", ["a table ([rotator])", "3 (int)"]),
    ("[keepout]\nname = 'x'\n", "keepout", ["an array of tables ([[keepout]])"]),
    ("[[keepout]]\nname = 'x'\naz_min_deg = 1\naz_max_deg = 2\nel_min_deg = 0\n",
     "keepout[0].el_max_deg", ["(required)", "nothing"]),
    ("[park]\nel_deg = 1979-05-27\n", "park.el_deg", ["a number (degrees)", "(date)"]),
])
def test_wrong_types(tmp_path, text, key, words):
    err, p = load_error(tmp_path, text)
    assert_names(err, p, key, *words)


@pytest.mark.parametrize("text,key,words", [
    ("[rotator]\nloop_hz = 0\n", "rotator.loop_hz", ["in 1..1000", "0 (int)"]),
    ("[rotator]\nloop_hz = 1000.5\n", "rotator.loop_hz", ["in 1..1000", "1000.5"]),
    ("[offsets]\naz_deg = 181\n", "offsets.az_deg", ["in -180..180", "181"]),
    ("[offsets]\nel_deg = -90.5\n", "offsets.el_deg", ["in -90..90", "-90.5"]),
    ("[offsets]\nel_deg = nan\n", "offsets.el_deg", ["finite", "nan"]),
    ("[limits.az]\nmax_deg = inf\n", "limits.az.max_deg", ["finite", "inf"]),
    ("[faults]\nwatchdog_s = 0\n", "faults.watchdog_s", ["> 0", "seconds"]),
    ("[faults]\novercurrent_a = -1\n", "faults.overcurrent_a", [">= 0", "amperes"]),
    ("[park]\nidle_park_s = -5\n", "park.idle_park_s", [">= 0"]),
    ("[api]\nport = 70000\n", "api.port", ["in 0..65535", "70000"]),
    ("[api]\nhost = ''\n", "api.host", ["non-empty"]),
    ("[control.el]\novershoot_deg = -0.1\n", "control.el.overshoot_deg", [">= 0"]),
    ("[control.az]\nkp_per_s = -2\n", "control.az.kp_per_s", ["per second", ">= 0"]),
])
def test_out_of_range(tmp_path, text, key, words):
    err, p = load_error(tmp_path, text)
    assert_names(err, p, key, *words)


@pytest.mark.parametrize("text,key,suggestion", [
    ("[limits.az]\nmax_dg = 10\n", "limits.az.max_dg", "max_deg"),
    ("[rotatr]\nprofile = 'bigras'\n", "rotatr", "rotator"),
    ("[faults]\nstall_timeout = 2\n", "faults.stall_timeout", "stall_timeout_s"),
    ("[[keepout]]\nnmae = 'x'\naz_min_deg = 1\naz_max_deg = 2\nel_min_deg = 0\n"
     "el_max_deg = 1\n", "keepout[0].nmae", "name"),
    ("[hardware.sim]\nsede = 3\n", "hardware.sim.sede", "seed"),
])
def test_unknown_key_with_suggestion(tmp_path, text, key, suggestion):
    err, p = load_error(tmp_path, text)
    assert_names(err, p, key, "unknown key", f"did you mean {suggestion!r}?")


def test_unknown_key_without_close_match(tmp_path):
    err, p = load_error(tmp_path, "[api]\nzzzzqqq = 1\n")
    first = assert_names(err, p, "api.zzzzqqq", "unknown key", "host, port, read_token, token")
    assert "did you mean" not in first


def test_bad_profile(tmp_path):
    err, p = load_error(tmp_path, "[rotator]\nprofile = 'tartu'\n")
    first = assert_names(err, p, "rotator.profile", "'tartu' (str)", "did you mean 'tartu-urc'?")
    for name in PROFILES:
        assert name in first


def test_bad_backend(tmp_path):
    err, p = load_error(tmp_path, "[hardware]\nbackend = 'simm'\n")
    assert_names(err, p, "hardware.backend", "sim", "'simm' (str)", "did you mean 'sim'?")


@pytest.mark.parametrize("text,line,col", [
    ('[rotator]\nprofile = "tartu-urc\nloop_hz = 5\n', 2, None),
    ("[api]\nport = 80\nport = 81\n", 3, None),
    ("[api]\n\nhost = \n", 3, 8),
    ("[[keepout]\n", 1, None),
])
def test_toml_syntax_error(tmp_path, text, line, col):
    err, p = load_error(tmp_path, text)
    first = str(err).splitlines()[0]
    assert first.startswith(f"{p}:{line}:")
    assert f"line {line}, column" in first
    assert err.line == line  # type: ignore[attr-defined]
    if col is not None:
        assert err.column == col  # type: ignore[attr-defined]
    assert "expected valid TOML" in first and "found" in first
    assert err.path == str(p)


def test_not_utf8(tmp_path):
    err, p = load_error(tmp_path, b"[api]\nhost = '\xff'\n")
    assert str(err).startswith(f"{p}:2:")
    assert "expected UTF-8" in str(err) and "found" in str(err)


def test_missing_file(tmp_path):
    p = tmp_path / "nope.toml"
    with pytest.raises(ConfigError) as info:
        load_config(p)
    msg = str(info.value)
    assert str(p) in msg and "not found" in msg
    assert info.value.path == str(p)


def test_directory_instead_of_file(tmp_path):
    with pytest.raises(ConfigError) as info:
        load_config(tmp_path)
    assert str(tmp_path) in str(info.value) and "directory" in str(info.value)


@pytest.mark.parametrize("text,key,words", [
    ("[limits.az]\nmin_deg = -10\n", "limits.az.min_deg", ["in 0..400", "tartu-urc", "-10"]),
    ("[limits.az]\nmax_deg = 401\n", "limits.az.max_deg", ["in 0..400", "401"]),
    ("[rotator]\nprofile = 'bigras'\n[limits.el]\nmax_deg = 120\n", "limits.el.max_deg",
     ["in 0..90", "bigras", "120"]),
    ("[rotator]\nprofile = 'sarcnet-mini'\n[limits.az]\nmin_deg = -91\n",
     "limits.az.min_deg", ["in -90..450", "-91"]),
])
def test_limits_outside_profile(tmp_path, text, key, words):
    err, p = load_error(tmp_path, text)
    assert_names(err, p, key, *words)


def test_limits_inside_profile_ok():
    cfg = Config.from_dict({"rotator": {"profile": "sarcnet-mini"},
                            "limits": {"az": {"min_deg": -90, "max_deg": 450}}})
    assert cfg.effective_limits(cfg.caps)["az"] == (-90.0, 450.0)


@pytest.mark.parametrize("text,key", [
    ("[limits.el]\nmin_deg = 50\nmax_deg = 40\n", "limits.el.max_deg"),
    ("[limits.az]\nmin_deg = 100\nmax_deg = 100\n", "limits.az.max_deg"),
    ("[limits.az]\nmin_deg = 400\n", "limits.az.min_deg"),  # against the profile's max
])
def test_limits_min_not_below_max(tmp_path, text, key):
    err, p = load_error(tmp_path, text)
    assert_names(err, p, key, "min_deg < limits.")


@pytest.mark.parametrize("text,key,words", [
    ("[park]\naz_deg = 200\n[limits.az]\nmax_deg = 180\n", "park.az_deg",
     ["inside the az limits 0..180", "200.0 (float)"]),
    ("[park]\nel_deg = -1\n", "park.el_deg", ["inside the el limits 0..180", "-1"]),
    # the profile's park (el 90) is outside the user's el limits: say so
    ("[limits.el]\nmax_deg = 80\n", "park.el_deg", ["inside the el limits 0..80",
                                                    "set park.el_deg"]),
])
def test_park_outside_limits(tmp_path, text, key, words):
    err, p = load_error(tmp_path, text)
    assert_names(err, p, key, *words)


def test_flip_on_non_flip_profile(tmp_path):
    err, p = load_error(tmp_path, "[rotator]\nprofile = 'bigras'\nflip = true\n")
    assert_names(err, p, "rotator.flip", "false", "bigras", "True (bool)")
    # fine on a profile whose elevation reaches 180
    assert Config.from_dict({"rotator": {"profile": "g5500", "flip": True}}).rotator.flip


@pytest.mark.parametrize("zone,key,words", [
    ({"el_min_deg": 30, "el_max_deg": 20}, "keepout[0].el_max_deg", ["el_min_deg"]),
    ({"az_min_deg": 90, "az_max_deg": 90}, "keepout[0].az_max_deg", ["az_min_deg"]),
    ({"az_min_deg": -5}, "keepout[0].az_min_deg", ["in 0..400", "-5"]),
    ({"az_max_deg": 720}, "keepout[0].az_max_deg", ["in 0..400", "720"]),
    ({"el_max_deg": 181}, "keepout[0].el_max_deg", ["in -90..180", "181"]),
    ({"el_min_deg": -91}, "keepout[0].el_min_deg", ["in -90..180"]),
])
def test_bad_keepout(zone, key, words):
    data = {"name": "mast", "az_min_deg": 80, "az_max_deg": 100, "el_min_deg": 0,
            "el_max_deg": 20} | zone
    with pytest.raises(ConfigError) as info:
        Config.from_dict({"keepout": [data]}, source="/etc/urc.toml")
    assert_names(info.value, "/etc/urc.toml", key, *words)


def test_keepout_in_wrap_range_ok():
    cfg = Config.from_dict({"keepout": [
        {"az_min_deg": 350, "az_max_deg": 10, "el_min_deg": 0, "el_max_deg": 20},
        {"az_min_deg": 350, "az_max_deg": 370, "el_min_deg": -10, "el_max_deg": 5},
    ]})
    assert len(cfg.keepout) == 2


def test_park_inside_keepout():
    with pytest.raises(ConfigError) as info:
        Config.from_dict({"park": {"az_deg": 90, "el_deg": 10},
                          "keepout": [{"name": "mast", "az_min_deg": 80, "az_max_deg": 100,
                                       "el_min_deg": 0, "el_max_deg": 20}]}, "f.toml")
    assert_names(info.value, "f.toml", "park.az_deg", "'mast'")


def test_control_overrides_beyond_caps():
    with pytest.raises(ConfigError) as info:
        Config.from_dict({"control": {"el": {"max_rate_deg_per_s": 7}}}, "f.toml")
    assert_names(info.value, "f.toml", "control.el.max_rate_deg_per_s", "<= 6", "7")
    with pytest.raises(ConfigError) as info:
        Config.from_dict({"control": {"az": {"accel_deg_per_s2": 13}}}, "f.toml")
    assert_names(info.value, "f.toml", "control.az.accel_deg_per_s2", "<= 12", "13")
    with pytest.raises(ConfigError) as info:
        Config.from_dict({"control": {"az": {"restart_deg": 0.05}}}, "f.toml")
    assert_names(info.value, "f.toml", "control.az.restart_deg", "tolerance")


def test_sim_start_outside_profile():
    with pytest.raises(ConfigError) as info:
        Config.from_dict({"hardware": {"sim": {"start_el_deg": 200}}}, "f.toml")
    assert_names(info.value, "f.toml", "hardware.sim.start_el_deg", "0..180", "200")


def test_all_errors_collected(tmp_path):
    err, p = load_error(tmp_path, "[rotator]\nloop_hz = 0\n[api]\nport = 'x'\nprot = 1\n")
    keys = [e.key for e in err.errors]  # type: ignore[attr-defined]
    assert keys == ["rotator.loop_hz", "api.port", "api.prot"]
    assert err.key == "rotator.loop_hz"
    assert len(str(err).splitlines()) > 3  # the others are listed too


def test_from_dict_not_a_table():
    with pytest.raises(ConfigError) as info:
        Config.from_dict([1, 2], source="web")
    assert "web" in str(info.value) and "a table" in str(info.value)


def test_from_dict_default_source():
    with pytest.raises(ConfigError) as info:
        Config.from_dict({"api": {"port": -1}})
    assert str(info.value).startswith("<dict>: api.port:")


# --------------------------------------------------------------------------- fuzzing

_FRAGMENTS = [
    "[rotator]", "[limits.az]", "[limits.el]", "[park]", "[[keepout]]", "[control.az]",
    "[api]", "[hardware.sim]", "[faults]", "[state]", "[offsets]", "[", "]", "[[", "]]",
    "profile", "loop_hz", "flip", "min_deg", "max_deg", "az_deg", "el_deg", "port", "host",
    "az_min_deg", "az_max_deg", "el_min_deg", "el_max_deg", "name", "seed", "dir",
    "kp_per_s", "max_rate_deg_per_s", "tolerance_deg", "restart_deg", "rotator.flip",
    " = ", "=", "\n", " ", "#", '"', "'", '"""', "{", "}", ",", ".", "\\", "\t", "\r\n",
    "0", "1", "-1", "90", "180", "400", "1e400", "nan", "inf", "-inf", "0x1F", "1_000",
    "3.5", "true", "false", '"tartu-urc"', '"bigras"', "'sim'", "1979-05-27T07:32:00Z",
    "12:00:00", "[1, 2]", "{a = 1}", "99999999999999999999999", "\x00", "é", "\ud7ff",
]

toml_ish = st.one_of(
    st.lists(st.sampled_from(_FRAGMENTS), max_size=40).map("".join),
    st.text(max_size=200),
)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(toml_ish)
def test_fuzz_text_loads_or_config_error(text):
    try:
        cfg = loads_config(text, source="fuzz.toml")
    except ConfigError as exc:
        assert str(exc).startswith("fuzz.toml")
    else:
        assert loads_config(cfg.to_toml()) == cfg


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=200))
def test_fuzz_bytes_loads_or_config_error(tmp_path_factory, data):
    p = tmp_path_factory.mktemp("fuzz") / "urc.toml"
    p.write_bytes(data)
    try:
        load_config(p)
    except ConfigError as exc:
        assert str(p) in str(exc)


_values = st.one_of(
    st.none(), st.booleans(), st.integers(-10**30, 10**30),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=10),
    st.sampled_from(list(PROFILES) + ["sim", "127.0.0.1", "0.0.0.0"]),
)
_keys = st.sampled_from([
    "rotator", "hardware", "sim", "limits", "az", "el", "offsets", "park", "keepout",
    "control", "faults", "api", "state", "profile", "loop_hz", "flip", "backend", "seed",
    "wind", "start_az_deg", "min_deg", "max_deg", "az_deg", "el_deg", "idle_park_s",
    "name", "az_min_deg", "az_max_deg", "el_min_deg", "el_max_deg", "tolerance_deg",
    "restart_deg", "max_rate_deg_per_s", "accel_deg_per_s2", "kp_per_s", "ki_per_s2",
    "overshoot_deg", "stall_timeout_s", "host", "port", "token", "dir", "save_interval_s",
    "bogus",
])
_docs = st.recursive(
    _values,
    lambda children: st.one_of(st.lists(children, max_size=3),
                               st.dictionaries(_keys, children, max_size=5)),
    max_leaves=25,
)


@settings(max_examples=400, deadline=None)
@given(st.dictionaries(_keys, _docs, max_size=6))
def test_fuzz_dicts_config_or_config_error(data):
    try:
        cfg = Config.from_dict(data, source="web")
    except ConfigError as exc:
        assert str(exc).startswith("web")
        assert exc.errors  # type: ignore[attr-defined]
        for e in exc.errors:  # type: ignore[attr-defined]
            assert "expected" in str(e) and "found" in str(e)
    else:
        text = cfg.to_toml()
        assert loads_config(text) == cfg
        for lo, hi in cfg.effective_limits(cfg.caps).values():
            assert lo < hi and math.isfinite(lo) and math.isfinite(hi)


def _valid_docs():
    def for_profile(name):
        caps = PROFILES[name]
        fl = lambda lo, hi: st.floats(lo, hi, allow_nan=False, allow_infinity=False)  # noqa: E731
        axis_lim = lambda a: st.fixed_dictionaries({}, optional={  # noqa: E731
            "min_deg": fl(a.min_deg, a.min_deg + a.span_deg / 4),
            "max_deg": fl(a.max_deg - a.span_deg / 4, a.max_deg)})
        ctl = lambda a: st.fixed_dictionaries({}, optional={  # noqa: E731
            "max_rate_deg_per_s": fl(0.01, a.max_rate_deg_per_s),
            "accel_deg_per_s2": fl(0.01, a.accel_deg_per_s2),
            "kp_per_s": fl(0, 100), "ki_per_s2": fl(0, 100), "overshoot_deg": fl(0, 5)})
        return st.fixed_dictionaries({
            "rotator": st.fixed_dictionaries({"profile": st.just(name)}, optional={
                "loop_hz": fl(1, 1000), "flip": st.just(caps.can_flip) | st.just(False)}),
        }, optional={
            "hardware": st.fixed_dictionaries({}, optional={"sim": st.fixed_dictionaries(
                {}, optional={"seed": st.integers(-2**63, 2**63 - 1), "wind": st.booleans(),
                              "start_az_deg": fl(caps.az.min_deg, caps.az.max_deg)})}),
            "limits": st.fixed_dictionaries({}, optional={"az": axis_lim(caps.az),
                                                           "el": axis_lim(caps.el)}),
            "offsets": st.fixed_dictionaries({}, optional={"az_deg": fl(-180, 180),
                                                           "el_deg": fl(-90, 90)}),
            "park": st.fixed_dictionaries({}, optional={"idle_park_s": fl(0, 1e6)}),
            "keepout": st.lists(st.fixed_dictionaries({
                "name": st.text(max_size=8), "az_min_deg": fl(0, 359), "az_max_deg": fl(0, 359),
                "el_min_deg": fl(-90, 0), "el_max_deg": fl(1, 180)}), max_size=2),
            "control": st.fixed_dictionaries({}, optional={"az": ctl(caps.az),
                                                           "el": ctl(caps.el)}),
            "api": st.fixed_dictionaries({}, optional={
                "host": st.text(min_size=1, max_size=8), "port": st.integers(0, 65535),
                "token": st.text(max_size=8)}),
            "state": st.fixed_dictionaries({}, optional={"dir": st.text(max_size=8),
                                                         "save_interval_s": fl(1e-3, 10)}),
        })
    return st.sampled_from(sorted(PROFILES)).flatmap(for_profile)


@settings(max_examples=200, deadline=None)
@given(_valid_docs())
def test_fuzz_round_trip(data):
    try:
        cfg = Config.from_dict(data)
    except ConfigError:
        return  # e.g. a keep-out zone over the park position
    text = cfg.to_toml()
    assert loads_config(text, source="rt.toml") == cfg


# --------------------------------------------------------------------------- bridge


def test_bridge_section_is_validated():
    ok = loads_config('[hardware]\nbackend = "bridge"\n[hardware.bridge]\nprotocol = "rot2prog"\n'
                      'serial = "/dev/ttyUSB0"\nbaud = 600\n')
    assert ok.hardware.bridge.protocol == "rot2prog" and ok.hardware.bridge.baud == 600
    bad = {
        '[hardware]\nbackend = "bridge"\n': "hardware.bridge",
        '[hardware.bridge]\nprotocol = "gs232c"\nserial = "/x"\n': "did you mean 'gs232b'",
        '[hardware.bridge]\nprotocol = "gs232b"\n': "exactly one of serial, tcp",
        '[hardware.bridge]\nprotocol = "gs232b"\nserial = "/x"\ntcp = "h:1"\n': "exactly one of serial, tcp",
        '[hardware.bridge]\nprotocol = "rotctld"\ntcp = "nohost"\n': "host:port",
        '[hardware.bridge]\nprotocol = "rotctld"\ntcp = "h:4533"\nbaud = 9600\n': "no baud with tcp",
        '[hardware.bridge]\nprotocol = "gs232b"\nserial = "/x"\nbaud = 10\n': "hardware.bridge.baud",
        '[hardware.bridge]\nprotocol = "gs232b"\nserial = "/x"\nmax_failures = 0\n': "max_failures",
        '[hardware]\nbackend = "bridge"\n[hardware.bridge]\nprotocol = "rot1prog"\nserial = "/x"\n':
            "limits.el.max_deg",
    }
    for text, expected in bad.items():
        with pytest.raises(ConfigError, match=re.escape(expected)):
            loads_config(text)
    loads_config('[hardware]\nbackend = "bridge"\n[hardware.bridge]\nprotocol = "rot1prog"\nserial = "/x"\n'
                 '[limits.el]\nmax_deg = 1.0\n[park]\nel_deg = 0.0\n')


def test_the_read_only_token_is_not_the_control_token():
    """Issue 36.8: api.read_token (a wall display) reads and never controls: the same
    value as api.token would make it control."""
    from urc.config import Config
    from urc.errors import ConfigError

    with pytest.raises(ConfigError, match="api.read_token"):
        Config.from_dict({"api": {"host": "0.0.0.0", "token": "abc", "read_token": "abc"}})
    assert Config.from_dict({"api": {"host": "0.0.0.0", "token": "abc", "read_token": "xyz"}}).api.reads_require_token
