"""Every public method of the rotator runs under its lock, by construction.

The control loop ticks on its own thread while commands arrive on others; a command
that ran beside a tick could see or leave half of one. :func:`locked_api` wraps every
public method a class defines in ``with self.lock``, when the class is made, so a new
command is locked without anyone remembering to; a method that must not take the lock
on entry says so where it is defined, with the reason (:func:`lock_free`).
"""

from __future__ import annotations

import functools
import inspect
from typing import Any, Callable, TypeVar

F = TypeVar("F", bound=Callable[..., Any])
C = TypeVar("C", bound=type)

#: set on a method marked :func:`lock_free` (its value: the reason)
LOCK_FREE_ATTR = "__urc_lock_free__"
#: set on the wrapper :func:`locked_api` puts round a method (its value: the method)
LOCKED_ATTR = "__urc_locked__"


def lock_free(reason: str) -> Callable[[F], F]:
    """Mark a public method that does not take the lock on entry; ``reason`` says why
    that is safe (it reads an immutable snapshot, or takes the lock itself for part)."""
    if not reason.strip():
        raise ValueError("a lock-free method needs its reason")

    def mark(method: F) -> F:
        setattr(method, LOCK_FREE_ATTR, reason)
        return method
    return mark


def _holding_lock(method: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(method)
    def locked(self: Any, *args: Any, **kwargs: Any) -> Any:
        with self.lock:
            return method(self, *args, **kwargs)
    setattr(locked, LOCKED_ATTR, method)
    return locked


def locked_api(cls: C) -> C:
    """Class decorator: every public method of ``cls`` (not marked :func:`lock_free`)
    holds ``self.lock`` for its whole run. Properties are plain reads and stay as they
    are; a public static or class method is refused (it has no lock to take)."""
    for name, member in list(vars(cls).items()):
        if name.startswith("_"):
            continue
        if isinstance(member, (staticmethod, classmethod)):
            raise TypeError(f"{cls.__name__}.{name}: a public static or class method cannot hold "
                            "the instance's lock; make it a method or move it out of the class")
        if not inspect.isfunction(member) or hasattr(member, LOCK_FREE_ATTR):
            continue
        setattr(cls, name, _holding_lock(member))
    return cls
