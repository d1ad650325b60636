"""The link's codec: pickle, with a closed list of the types allowed back in.

Plain pickle rebuilds any importable object (and calls any importable function) named in
the bytes. The control process must never run what a confused or compromised I/O process
sends, so loading goes through :class:`_LinkUnpickler`, whose ``find_class`` looks the
(module, name) pair up in :data:`_REGISTRY` and nothing else: the registry is built here,
as this module is imported, from the modules :data:`_MODULES` names (their messages,
statuses, settings, capabilities, configuration models and exceptions) and a short list
of standard types. A name from the wire is never imported nor walked attribute by
attribute (it was: a 25-byte pickle naming ``urc.__main__`` ran the CLI in the control
process, and a dotted name reached pydantic's or subprocess's classes through a urc
module). Anything else fails to load (``pickle.UnpicklingError``). Pickle itself stays:
it is C, and a Status goes across a hundred times a second.

Two kinds of names are resolved on first use instead, each from a closed list in this
module: urc.link.client's exceptions (that module imports this one; they are taken
from it once it has been imported, never imported from here) and numpy's names in a
pickled array or scalar (numpy is imported only when one of those exact names arrives:
the I/O process loads numpy only if it uses it).
"""

from __future__ import annotations

import builtins
import collections
import dataclasses
import datetime
import enum
import io
import pathlib
import pickle
import sys
import threading
from types import ModuleType
from typing import Any

import pydantic

from .. import caps, errors
from ..config import hardware_sections, mqtt_section, panel_sections, schema, sections
from ..control import faults, geometry, law
from ..hardware import parts
from ..model import messages, program, settings, snapshot
from . import instance

#: the modules whose data types cross the link (what the codec admits from urc; a new
#: module of messages is added here)
_MODULES: tuple[ModuleType, ...] = (
    messages, snapshot, faults, program,                # requests, replies, statuses, pass programs
    settings, caps, geometry, law,                      # the "ready" message, Reconfigure
    schema, sections, hardware_sections, panel_sections, mqtt_section,  # "init": the Config
    errors, parts, instance,                            # urc's exceptions (exception_from_wire)
)

#: urc.link.client's exceptions: client imports this module, so they are taken from
#: it (sys.modules) on first use, never imported from here
_LATER: frozenset[tuple[str, str]] = frozenset({
    ("urc.link.client", "ControlUnavailable"), ("urc.link.client", "StopQueued")})

#: standard types a message may hold besides containers of plain values
_STDLIB_TYPES: tuple[type, ...] = (
    set, frozenset, complex, slice, collections.OrderedDict, collections.deque,
    datetime.datetime, datetime.date, datetime.time, datetime.timedelta, datetime.timezone,
    pathlib.Path, pathlib.PosixPath, pathlib.PurePath, pathlib.PurePosixPath,
)

#: numpy's names in a pickled scalar or small array (a sensor's calibration matrix);
#: numpy 2 and numpy 1 spellings
_NUMPY_NAMES: frozenset[tuple[str, str]] = frozenset({
    ("numpy", "dtype"), ("numpy", "ndarray"),
    *((f"numpy.{core}.multiarray", name) for core in ("_core", "core") for name in ("scalar", "_reconstruct")),
    *((f"numpy.{core}.numeric", "_frombuffer") for core in ("_core", "core")),
})


def is_data_type(obj: Any) -> bool:
    """A type whose instances are data: a dataclass, an enum, a named tuple, an exception,
    a pydantic model (a configuration section)."""
    if not isinstance(obj, type):
        return False
    return (dataclasses.is_dataclass(obj) or issubclass(obj, (enum.Enum, BaseException, pydantic.BaseModel))
            or (issubclass(obj, tuple) and hasattr(obj, "_fields")))


def data_types(module: ModuleType) -> dict[tuple[str, str], type]:
    """The data types ``module`` itself defines (not those it imports), by the
    (module, qualified name) pair pickle writes for them."""
    return {(obj.__module__, obj.__qualname__): obj for obj in vars(module).values()
            if is_data_type(obj) and obj.__module__ == module.__name__}


def _build_registry() -> dict[tuple[str, str], Any]:
    found: dict[tuple[str, str], Any] = {}
    for module in _MODULES:
        found.update(data_types(module))
    found.update({(t.__module__, t.__qualname__): t for t in _STDLIB_TYPES})
    # built-in exceptions a command may raise (OSError from a device, ValueError, ...),
    # under their aliases too (IOError), as exception_to_wire may name them
    found.update({("builtins", name): value for name, value in vars(builtins).items()
                  if isinstance(value, type) and issubclass(value, BaseException)})
    return found


#: (module, qualified name) -> the type the link rebuilds; read-only once built, but for
#: the names of :data:`_LATER` and :data:`_NUMPY_NAMES`, added on first use
_REGISTRY: dict[tuple[str, str], Any] = _build_registry()
_late_lock = threading.Lock()


def _numpy_names() -> dict[tuple[str, str], Any]:
    import numpy  # (only here: the I/O process imports numpy only if it uses it)

    core = getattr(numpy, "_core", None) or numpy.core  # numpy 2 | numpy 1
    return {("numpy", "dtype"): numpy.dtype, ("numpy", "ndarray"): numpy.ndarray,
            (core.multiarray.__name__, "scalar"): core.multiarray.scalar,
            (core.multiarray.__name__, "_reconstruct"): core.multiarray._reconstruct,
            (core.numeric.__name__, "_frombuffer"): core.numeric._frombuffer}


def _resolve_later(key: tuple[str, str]) -> Any:
    """A name of :data:`_LATER` or :data:`_NUMPY_NAMES` (``key`` is one of them)."""
    with _late_lock:
        if key in _REGISTRY:
            return _REGISTRY[key]
        if key in _NUMPY_NAMES:
            _REGISTRY.update(_numpy_names())
            return _REGISTRY.get(key)
        client = sys.modules.get("urc.link.client")
        cls = getattr(client, key[1], None) if client is not None else None
        if not (isinstance(cls, type) and issubclass(cls, BaseException)):
            return None  # (client not imported, or still importing: not kept, asked again later)
        _REGISTRY[key] = cls
        return cls


def allowed_class(module: str, name: str) -> Any:
    """The type ``module.name`` if the link admits it, else None: a lookup, nothing is
    imported for it (bar numpy for numpy's own names)."""
    key = (module, name)
    found = _REGISTRY.get(key)
    if found is None and (key in _LATER or key in _NUMPY_NAMES):
        found = _resolve_later(key)
    return found


class _LinkUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> Any:
        found = allowed_class(module, name)
        if found is None:
            raise pickle.UnpicklingError(f"the link refuses {module}.{name}: not one of its message types")
        return found


def dumps(msg: Any) -> bytes:
    return pickle.dumps(msg, protocol=pickle.HIGHEST_PROTOCOL)


def loads(data: bytes) -> Any:
    return _LinkUnpickler(io.BytesIO(data)).load()
