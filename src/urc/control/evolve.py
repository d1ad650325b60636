"""``evolve``: ``dataclasses.replace`` for the control law's frozen state records, and
``construct``: the same trick for the records the tick makes afresh every time.

The law and the fault monitor return a new state each tick (pure functions, easy to
test), about four per axis per tick at 50 Hz. ``dataclasses.replace`` walks every field
and runs ``__init__`` each time, and was the largest single cost of a simulated pass
(~16 % of its CPU). This copies the instance dict (``dict.copy``: one block, not field
by field) with the changes applied and gives it to the new instance; it refuses a name
that is not a field, as ``replace`` does. Only for plain frozen dataclasses: no
``__post_init__``, no ``init=False`` field, no ``__slots__`` (tests/control/test_evolve.py).

A frozen dataclass' own ``__init__`` sets each field through ``object.__setattr__``,
about twice the work of ``construct``, which the status snapshots and the monitor's
inputs are made with (every tick, per axis): the keyword arguments' own fresh dict
becomes the instance dict. It takes every field and nothing else, so no default is
left out.
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

T = TypeVar("T")

_set_attr = object.__setattr__  # (a frozen dataclass refuses its own __setattr__)
#: each class' field names in their order (construct checks every call against them)
_FIELD_NAMES: dict[type, tuple[str, ...]] = {}


def evolve(obj: T, **changes: Any) -> T:
    """A copy of frozen dataclass ``obj`` with ``changes`` applied."""
    fields = obj.__dict__
    if not changes.keys() <= fields.keys():
        unknown = ", ".join(sorted(changes.keys() - fields.keys()))
        raise TypeError(f"{type(obj).__name__} has no field {unknown}")
    values = fields.copy()
    values.update(changes)
    new = object.__new__(type(obj))
    _set_attr(new, "__dict__", values)
    return new


def construct(cls: type[T], **fields: Any) -> T:
    """``cls(**fields)`` for a plain frozen dataclass, every field given (see above)."""
    names = _FIELD_NAMES.get(cls)
    if names is None:
        names = _FIELD_NAMES[cls] = tuple(f.name for f in dataclasses.fields(cls))  # type: ignore[arg-type]
    # (in the class' order, as every call site gives them, one tuple compare; any other
    # order is as good, checked as a set: a call in a rare branch must not crash a tick)
    if tuple(fields) != names and fields.keys() != set(names):
        wrong = fields.keys() ^ set(names)
        raise TypeError(f"{cls.__name__} fields missing or unknown: {', '.join(sorted(wrong))}")
    new = object.__new__(cls)
    _set_attr(new, "__dict__", fields)  # (a fresh dict of this call's own)
    return new
