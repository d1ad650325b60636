"""The rotator service: the single owner of both axes and their state.

Its names load on first use (PEP 562): ``urc run`` imports ``urc.service.instance``
before it starts its control process, and the Rotator's modules (~0.5 s to import on a
small machine) belong to that process, not on the way to starting it."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .rotator import Rotator
    from .settings import RotatorSettings
    from .snapshot import AxisStatus, Status

__all__ = ["Rotator", "RotatorSettings", "Status", "AxisStatus"]

_HOMES = {"Rotator": "rotator", "RotatorSettings": "settings", "Status": "snapshot", "AxisStatus": "snapshot"}


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from importlib import import_module

    return getattr(import_module(f".{_HOMES[name]}", __name__), name)
