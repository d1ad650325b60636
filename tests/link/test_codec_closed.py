"""The link's codec admits a closed list of types (issue 34, item 1): what crosses the link
in urc's own use loads; a name outside the list is refused before anything is imported
for it, in a unit and in a running control process."""

from __future__ import annotations

import dataclasses
import enum
import os
import pickle
import subprocess
import sys
import typing
from pathlib import Path

import pydantic
import pytest

from urc import errors
from urc.config import EXAMPLE_CONFIG, Config, load_config, loads_config
from urc.link import codec
from urc.model import messages
from urc.model.messages import Goto, GotoPose, Reconfigure, Reply
from urc.model import snapshot
from urc.model.program import PassProgram
from urc.link.client import ControlUnavailable, StopQueued, exception_from_wire, exception_to_wire
from urc_process import wait_until

EXAMPLES = sorted((Path(__file__).resolve().parents[2] / "examples").glob("*.toml"))


def stack_global(module: str, name: str) -> bytes:
    """The shortest pickle naming ``module.name`` (protocol 4's STACK_GLOBAL): the
    attack needs no call, naming the module is enough for the old loader to import it."""
    def text(s: str) -> bytes:
        return pickle.SHORT_BINUNICODE + bytes([len(s)]) + s.encode()
    return pickle.PROTO + b"\x04" + text(module) + text(name) + pickle.STACK_GLOBAL + pickle.MEMOIZE + pickle.STOP


def old_global(module: str, name: str) -> bytes:
    """The same with protocol 0's GLOBAL opcode (a text line)."""
    return pickle.GLOBAL + f"{module}\n{name}\n".encode() + pickle.STOP


#: each was loaded by the old codec's import-then-getattr walk: the CLI run in the
#: loading process (SystemExit), pydantic's BaseModel and subprocess's error reached
#: through a urc module's namespace, the web stack imported to look a name up
PROBES = {
    "urc.__main__ (25 bytes)": stack_global("urc.__main__", "main"),
    "urc.__main__ (GLOBAL)": old_global("urc.__main__", "main"),
    "pydantic.BaseModel via urc.config.base": stack_global("urc.config.base", "BaseModel"),
    "subprocess.CalledProcessError via a dotted name": stack_global("urc.link.control_process",
                                                                    "subprocess.CalledProcessError"),
    "a nested attribute walk": stack_global("urc.errors", "UrcError.__class__"),
    "urc.api (the web stack)": stack_global("urc.api", "create_api"),
}


# ------------------------------------------------------------------ what crosses
#: a sample value per field type of a message (a new field type is added here: the
#: test names it)
SAMPLES: dict[str, object] = {
    "float": 12.5, "str": "az", "int": 3, "bool": True, "float | None": 4.25, "str | None": "el",
    "int | None": 7, "dict": {"M": -15897.0, "C": 3758.0}, "tuple": ((10.0, 1234.0), (200.0, 2900.0)),
    "tuple[str, ...]": ("M", "C"), "Goto | GotoPose": GotoPose(10.0, 20.0, "home"), "Request": Goto(1.0, 2.0),
    # (FlyProgram's program: a pass program, urc.model.program)
    "Any": PassProgram(4, "ISS", (100.0, 101.0, 102.0), (10.0, 11.0, 12.0), (5.0, 6.0, 7.0), (False, True, False),
                       90.0, "hold"),
}


def message_types() -> list[type]:
    return [obj for obj in vars(messages).values()
            if isinstance(obj, type) and dataclasses.is_dataclass(obj) and obj.__module__ == messages.__name__]


def sample(cls: type, extra: dict[str, object]) -> object:
    values = {}
    for f in dataclasses.fields(cls):
        if f.name in extra:
            values[f.name] = extra[f.name]
        else:
            assert f.type in SAMPLES, f"no sample value for {cls.__name__}.{f.name}: {f.type} (add one to SAMPLES)"
            values[f.name] = SAMPLES[f.type]
    return cls(**values)


@pytest.fixture
def real(bench):
    """A simulator rotator's status (a fault latched), settings, caps and geometry: what
    the "ready" message and every tick send."""
    b = bench("tartu-urc")
    b.run(0.5)
    b.rot.power_fail("a test's supply cut")
    b.run(0.1)
    return b.rot


def test_every_message_type_crosses_unchanged(real):
    status, settings = real.status(), real.settings
    assert status.faults and status.az is not None
    extra = {"settings": settings, "value": {"az": 1.5}, "status": status}
    types = message_types()
    assert len(types) > 40  # (the introspection sees the module)
    for cls in types:
        msg = ("request", sample(cls, extra))
        assert codec.loads(codec.dumps(msg)) == msg, cls.__name__
    env = ("request", messages.Envelope(9, 12.5, Reconfigure(settings)))
    assert codec.loads(codec.dumps(env)) == env


def test_the_ready_message_status_and_settings_cross_unchanged(real):
    ready = ("ready", {"pid": 1, "priority": "normal", "settings": real.settings, "caps": real.caps,
                       "geometry": real.geometry, "status": real.status(),
                       "hardware": messages.HardwareSummary("sim", True, "/tmp/state")})
    assert codec.loads(codec.dumps(ready)) == ready
    reply = ("reply", Reply(3, "value", None, real.status()))
    assert codec.loads(codec.dumps(reply)) == reply


FULL = {"rotator": {"profile": "tartu-urc"},
        "hardware": {"backend": "bridge", "bridge": {"protocol": "gs232b", "tcp": "localhost:4533"}},
        "keepout": [{"name": "mast", "az_min_deg": 10.0, "az_max_deg": 20.0, "el_min_deg": 0.0, "el_max_deg": 10.0}],
        "tracking": {"schedule": [{"sat": "ISS"}]}, "mqtt": {"url": "mqtt://localhost:1883"},
        "panel": {"enabled": True, "emulate": True, "lcd": {}, "ir": {"device": "/dev/input/event0"}, "presets": {}}}


@pytest.mark.parametrize("cfg", [
    *(pytest.param(lambda p=p: load_config(p), id=p.name) for p in EXAMPLES),
    pytest.param(lambda: loads_config(EXAMPLE_CONFIG), id="config_example.toml"),
    pytest.param(lambda: load_config(None), id="defaults"),
    pytest.param(lambda: Config.from_dict(FULL), id="mqtt-panel-keepout-bridge"),
    pytest.param(lambda: Config.from_dict({**FULL, "panel": {"enabled": True, "emulate": True, "oled": {}}}),
                 id="oled"),
])
def test_each_configuration_crosses_in_the_init_message(cfg, tmp_path):
    init = ("init", cfg(), str(tmp_path), [5, 6], 20)  # as ControlProcess.spawn sends it
    assert codec.loads(codec.dumps(init)) == init


def test_every_configuration_model_is_registered():
    """Every pydantic model a Config can hold (its sections, theirs, the backends',
    mqtt's and the panel's), found from the field annotations: a new section type not
    registered fails here rather than at a user's start."""
    seen: set[type] = set()

    def walk(tp: object) -> None:
        if isinstance(tp, type) and issubclass(tp, pydantic.BaseModel):
            if tp in seen:
                return
            seen.add(tp)
            for f in tp.model_fields.values():
                walk(f.annotation)
        for arg in typing.get_args(tp):
            walk(arg)
    walk(Config)
    assert len(seen) > 20
    missing = [t for t in seen if codec.allowed_class(t.__module__, t.__qualname__) is not t]
    assert not missing, missing


def types_reachable(root: type, seen: set[type]) -> None:
    """``root`` and the dataclasses and enums its fields' types name, recursively."""
    if root in seen:
        return
    seen.add(root)
    if not dataclasses.is_dataclass(root):
        return
    for hint in typing.get_type_hints(root).values():
        stack = [hint]
        while stack:
            tp = stack.pop()
            stack.extend(typing.get_args(tp))
            if isinstance(tp, type) and (dataclasses.is_dataclass(tp) or issubclass(tp, enum.Enum)):
                types_reachable(tp, seen)


@pytest.mark.parametrize("module", [messages, snapshot], ids=lambda m: m.__name__)
def test_the_registry_covers_every_message_and_status_type(module):
    """Every dataclass and enum defined in the messages and snapshot modules, and every
    one their fields name (Fault, the settings' tuning and fault limits, the caps...), is
    admitted: a new message or status field of a new type fails here, not on the link."""
    seen: set[type] = set()
    for obj in vars(module).values():
        if isinstance(obj, type) and obj.__module__ == module.__name__ and (
                dataclasses.is_dataclass(obj) or issubclass(obj, enum.Enum)):
            types_reachable(obj, seen)
    from urc.model.settings import RotatorSettings  # (Reconfigure's settings: Any)
    types_reachable(RotatorSettings, seen)
    assert snapshot.Status in seen or module is messages
    missing = [t for t in seen if codec.allowed_class(t.__module__, t.__qualname__) is not t]
    assert not missing, missing


def urc_exceptions() -> list[type]:
    """urc's exceptions that may cross: its own, a part's, a second urc's lock."""
    from urc.hardware import parts
    from urc.link import instance

    return [obj for module in (errors, parts, instance) for obj in vars(module).values()
            if isinstance(obj, type) and issubclass(obj, BaseException) and obj.__module__ == module.__name__]


@pytest.mark.parametrize("cls", [*urc_exceptions(), ControlUnavailable, StopQueued, ValueError, FileNotFoundError],
                         ids=lambda c: c.__qualname__)
def test_each_exception_type_crosses(cls):
    """As a reply's error (exception_to_wire names its class; the other side looks the
    name up) and pickled inside a message, each keeps its class."""
    exc = cls("it failed")
    back = exception_from_wire(exception_to_wire(exc))
    assert type(back) is cls and str(back) == "it failed"
    loaded = codec.loads(codec.dumps(("x", exc)))[1]
    assert type(loaded) is cls and str(loaded) == "it failed"


def test_urc_s_exceptions_are_all_registered():
    found = urc_exceptions()
    assert len(found) >= 10
    missing = [t for t in found if codec.allowed_class(t.__module__, t.__qualname__) is not t]
    assert not missing, missing


# ------------------------------------------------------------------ what is refused
@pytest.mark.parametrize("probe", PROBES.values(), ids=PROBES.keys())
def test_a_probe_is_refused(probe):
    with pytest.raises(pickle.UnpicklingError, match="the link refuses"):
        codec.loads(probe)


def test_the_probes_import_nothing(tmp_path):
    """In a fresh interpreter (as the control process): each probe is refused with
    UnpicklingError and sys.modules is the same after as before. The old codec imported
    urc.__main__ (and ran the CLI: SystemExit), fastapi with urc.api."""
    code = ("import pickle, sys\n"
            "import urc.link.control_process\n"
            "from urc.link import codec\n"
            f"probes = {list(PROBES.values())!r}\n"
            "wrong = []\n"
            "for probe in probes:\n"
            "    before = set(sys.modules)\n"
            "    try:\n"
            "        codec.loads(probe)\n"
            "        outcome = 'loaded'\n"
            "    except pickle.UnpicklingError:\n"
            "        outcome = 'refused'\n"
            "    except BaseException as exc:  # (SystemExit: the CLI ran)\n"
            "        outcome = repr(exc)\n"
            "    new = sorted(set(sys.modules) - before)\n"
            "    if outcome != 'refused' or new:\n"
            "        wrong.append((probe, outcome, new))\n"
            "assert not wrong, wrong\n"
            "print('ok')\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                         env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert out.returncode == 0 and out.stdout.strip() == "ok", (out.stdout[-2000:], out.stderr[-2000:])


def test_a_lookup_imports_nothing(tmp_path):
    """allowed_class (exception_from_wire's too) only looks up: the link client's
    exceptions are found once it is imported, never imported for the asking."""
    code = ("import sys\n"
            "from urc.link import codec\n"
            "assert 'urc.link.client' not in sys.modules\n"
            "assert codec.allowed_class('urc.link.client', 'ControlUnavailable') is None\n"
            "assert 'urc.link.client' not in sys.modules\n"
            "from urc.link.client import ControlUnavailable\n"
            "assert codec.allowed_class('urc.link.client', 'ControlUnavailable') is ControlUnavailable\n"
            "for module, name in [('urc.api', 'create_api'), ('urc.__main__', 'main'), ('urc.tracking', 'Catalog'),\n"
            "                     ('urc.errors', 'UrcError.__class__'), ('urc.config.base', 'BaseModel')]:\n"
            "    assert codec.allowed_class(module, name) is None, (module, name)\n"
            "loaded = [m for m in ('urc.api', 'urc.__main__', 'urc.tracking', 'fastapi', 'numpy') if m in sys.modules]\n"
            "assert not loaded, loaded\n"
            "print('ok')\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                         env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert out.returncode == 0 and out.stdout.strip() == "ok", (out.stdout[-2000:], out.stderr[-2000:])


def test_numpy_values_cross():
    """numpy scalars and arrays (a sensor's calibration) load: numpy's own names only."""
    np = pytest.importorskip("numpy")
    value = {"matrix": np.eye(3), "offset": np.float64(1.5), "count": np.int64(3)}
    back = codec.loads(codec.dumps(("reply", value)))[1]
    assert (back["matrix"] == np.eye(3)).all() and back["offset"] == 1.5 and type(back["count"]) is np.int64
    with pytest.raises(pickle.UnpicklingError):
        codec.loads(stack_global("numpy", "load"))


# ------------------------------------------------------------------ a running control process
def test_a_control_process_sent_the_probes_keeps_ticking(start_control):
    """The probes arrive on the control process's socket while the axes move: each is an
    unreadable message, logged and ignored; statuses keep coming and a later Goto runs.
    Before, ``urc.__main__`` ran the CLI in the control process: SystemExit ended it
    mid-move (the I/O process lost it)."""
    proc, rot = start_control("tartu-urc")
    link = rot._link
    assert rot.goto(60.0, 60.0) == [(60.0, 60.0)]
    wait_until(lambda: rot.status().moving, what="moving")
    for probe in PROBES.values():
        with link._send_lock:
            link.conn.send_bytes(probe)
    t_s = rot.status().t_s
    wait_until(lambda: link.lost or rot.status().t_s > t_s + 0.5, what="statuses after the probes")
    assert not link.lost and proc.proc.poll() is None, link.lost
    assert rot.goto(30.0, 40.0) == [(30.0, 40.0)]
    wait_until(lambda: rot.status().target_az_deg == 30.0, what="the later Goto's target")
    result = proc.stop()
    assert result["exit_code"] == 0 and result["saved"] and not result["error"], result
