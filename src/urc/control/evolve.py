"""``evolve``: ``dataclasses.replace`` for the control law's frozen state records, and
``construct``: the same trick for the records the tick makes afresh every time.

The law and the fault monitor return a new state each tick (pure functions, easy to
test), about four per axis per tick at 50 Hz. ``dataclasses.replace`` walks every field
and runs ``__init__`` each time, and was the largest single cost of a simulated pass
(~16 % of its CPU). This copies the instance dict and applies the changes; it refuses a
name that is not a field, as ``replace`` does. Only for plain frozen dataclasses: no
``__post_init__``, no ``init=False`` field, no ``__slots__`` (tests/control/test_evolve.py).

A frozen dataclass' own ``__init__`` sets each field through ``object.__setattr__``:
~5x slower than filling the instance dict at once, which ``construct`` does for the
status snapshots and the monitor's inputs (every tick, per axis); it takes every field
and nothing else, so no default is left out.
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


def construct(cls: type[T], **fields: Any) -> T:
    """``cls(**fields)`` for a plain frozen dataclass, every field given (see above)."""
    if fields.keys() != cls.__dataclass_fields__.keys():  # type: ignore[attr-defined]
        wrong = fields.keys() ^ cls.__dataclass_fields__.keys()  # type: ignore[attr-defined]
        raise TypeError(f"{cls.__name__} fields missing or unknown: {', '.join(sorted(wrong))}")
    new = object.__new__(cls)
    new.__dict__.update(fields)
    return new
