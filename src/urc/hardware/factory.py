"""Choose a hardware backend by name (gpiozero's pin-factory idea)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

from ..caps import RotatorCaps
from ..clock import Clock
from ..errors import ConfigError
from .interfaces import Hardware

#: builder(caps, clock, state_dir, options) -> Hardware
Builder = Callable[[RotatorCaps, Clock, Path, dict[str, Any]], Hardware]

_BACKENDS: dict[str, Builder] = {}


def register_backend(name: str, builder: Builder) -> None:
    _BACKENDS[name] = builder


def available_backends() -> list[str]:
    _load_builtin()
    return sorted(_BACKENDS)


def build_hardware(name: str, caps: RotatorCaps, clock: Clock, state_dir: Path,
                   options: dict[str, Any] | None = None) -> Hardware:
    _load_builtin()
    try:
        builder = _BACKENDS[name]
    except KeyError:
        raise ConfigError(
            f"unknown hardware backend {name!r}; expected one of {', '.join(sorted(_BACKENDS))}",
            key="hardware.backend", expected=" | ".join(sorted(_BACKENDS)), found=name) from None
    return builder(caps, clock, state_dir, dict(options or {}))


def _load_builtin() -> None:
    # Imported lazily so that importing urc.hardware does not pull in every backend.
    if "sim" not in _BACKENDS:
        from .sim import build_sim_hardware
        register_backend("sim", build_sim_hardware)
    if "bridge" not in _BACKENDS:
        from .bridge import build_bridge_hardware
        register_backend("bridge", build_bridge_hardware)
    if "gpio" not in _BACKENDS:
        from .gpio import build_gpio_hardware
        register_backend("gpio", build_gpio_hardware)
