"""Choose a hardware backend by name (gpiozero's pin-factory idea)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from ..caps import RotatorCaps
from ..errors import ConfigError
from .interfaces import Hardware

if TYPE_CHECKING:  # urc.clock imports asyncio: urc.config (which asks for the backends) must not
    from ..clock import Clock

#: builder(caps, clock, state_dir, options) -> Hardware
Builder = Callable[[RotatorCaps, "Clock", Path, dict[str, Any]], Hardware]
#: an issue as urc.config.issues words it: (key, expected, found, hint)
Issue = tuple[str, str, Any, str]
#: check(cfg, caps) -> what is wrong in the backend's own section of a Config (validated
#: otherwise; caps are the profile's as [rotator] changes them)
Check = Callable[[Any, RotatorCaps], list[Issue]]

_BACKENDS: dict[str, Builder] = {}
_CHECKS: dict[str, Check] = {}


def register_backend(name: str, builder: Builder, check: Check | None = None) -> None:
    """``builder`` makes the backend's Hardware; ``check``, if given, runs whenever a
    configuration is validated (whichever backend it selects: a section given is checked)."""
    _BACKENDS[name] = builder
    if check is not None:
        _CHECKS[name] = check
    else:
        _CHECKS.pop(name, None)


def available_backends() -> list[str]:
    _load_builtin()
    return sorted(_BACKENDS)


def backend_issues(cfg: Any, caps: RotatorCaps) -> list[Issue]:
    """Every registered backend's check of its own section (urc.config's cross-check)."""
    _load_builtin()
    return [issue for check in list(_CHECKS.values()) for issue in check(cfg, caps)]


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
        from .bridge.checks import bridge_issues
        register_backend("bridge", build_bridge_hardware, bridge_issues)
    if "gpio" not in _BACKENDS:
        from .gpio import build_gpio_hardware
        from .gpio.checks import gpio_issues
        register_backend("gpio", build_gpio_hardware, gpio_issues)
