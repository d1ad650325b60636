"""``evolve``: ``dataclasses.replace`` for the control law's frozen state records.

The law and the fault monitor return a new state each tick (pure functions, easy to
test), about four per axis per tick at 50 Hz. ``dataclasses.replace`` walks every field
and runs ``__init__`` each time, and was the largest single cost of a simulated pass
(~16 % of its CPU). This copies the instance dict and applies the changes; it refuses a
name that is not a field, as ``replace`` does. Only for plain frozen dataclasses: no
``__post_init__``, no ``init=False`` field, no ``__slots__`` (tests/control/test_evolve.py).
"""

from __future__ import annotations

from typing import Any, TypeVar

T = TypeVar("T")


def evolve(obj: T, **changes: Any) -> T:
    """A copy of frozen dataclass ``obj`` with ``changes`` applied."""
    fields = obj.__dict__
    if not changes.keys() <= fields.keys():
        unknown = ", ".join(sorted(changes.keys() - fields.keys()))
        raise TypeError(f"{type(obj).__name__} has no field {unknown}")
    new = object.__new__(type(obj))
    d = new.__dict__
    d.update(fields)
    d.update(changes)
    return new
