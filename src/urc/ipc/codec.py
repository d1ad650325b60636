"""The link's codec: pickle, with only the link's own types allowed back in.

Plain pickle would rebuild any importable object (and call any importable function)
named in the bytes. The control process must never run what a confused or compromised
I/O process sends, so loading goes through :class:`_LinkUnpickler`, whose
``find_class`` admits only: urc's messages, statuses, settings and capability types
(dataclasses, enums and named tuples under ``urc.``), urc's own exceptions and configuration models, and a short
list of standard data types. Anything else fails to load (``pickle.UnpicklingError``),
the "restricting globals" recipe of the pickle documentation. Pickle itself stays: it
is C, and a Status goes across a hundred times a second.
"""

from __future__ import annotations

import builtins
import dataclasses
import enum
import functools
import importlib
import io
import pickle
from typing import Any

import pydantic

#: standard types a message may hold besides containers of plain values
_STDLIB: frozenset[tuple[str, str]] = frozenset({
    ("builtins", "set"), ("builtins", "frozenset"), ("builtins", "complex"), ("builtins", "slice"),
    ("collections", "OrderedDict"), ("collections", "deque"),
    ("datetime", "datetime"), ("datetime", "date"), ("datetime", "time"), ("datetime", "timedelta"),
    ("datetime", "timezone"), ("pathlib", "PosixPath"), ("pathlib", "PurePosixPath"),
    ("pathlib", "Path"), ("pathlib", "_local"),
    # numpy scalars and small arrays (a sensor's calibration matrix)
    ("numpy", "dtype"), ("numpy", "ndarray"), ("numpy.core.multiarray", "scalar"),
    ("numpy._core.multiarray", "scalar"), ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "_reconstruct"), ("numpy._core.numeric", "_frombuffer"),
    # built-in exceptions a command may raise (OSError from a device, ValueError, ...)
    *(("builtins", name) for name, value in vars(builtins).items()
      if isinstance(value, type) and issubclass(value, BaseException)),
})


def _urc_data_type(obj: Any) -> bool:
    """A type whose instances are data: a dataclass, an enum, a named tuple, an exception."""
    if not isinstance(obj, type):
        return False
    return (dataclasses.is_dataclass(obj) or issubclass(obj, (enum.Enum, BaseException, pydantic.BaseModel))
            or (issubclass(obj, tuple) and hasattr(obj, "_fields")))


@functools.lru_cache(maxsize=512)
def allowed_class(module: str, name: str) -> Any:
    """The class ``module.name`` if the link admits it, else None (remembered: a Status
    names a dozen classes and crosses the link a hundred times a second)."""
    if (module, name) in _STDLIB or (module.startswith("numpy") and name == "dtype"):
        return getattr(importlib.import_module(module), name, None)
    if module == "urc" or module.startswith("urc."):
        try:
            obj: Any = importlib.import_module(module)
        except ImportError:
            return None
        for part in name.split("."):
            obj = getattr(obj, part, None)
        if _urc_data_type(obj):
            return obj
    return None


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
