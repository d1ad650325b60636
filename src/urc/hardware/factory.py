"""Choose a hardware backend by name (gpiozero's pin-factory idea), and check the
configuration's [hardware] against the backends (registered with urc.config at import)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from ..caps import RotatorCaps
from ..config.issues import suggest
from ..config.owners import register_check
from ..errors import ConfigError
from .interfaces import Hardware

if TYPE_CHECKING:  # urc.clock imports asyncio: checking a configuration (which asks for the backends) must not
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


def hardware_issues(cfg: Any, caps: RotatorCaps) -> list[Issue]:
    """urc.config's check of [hardware]: a backend registered here, each backend's own
    section, and the simulator's pointing error."""
    issues: list[Issue] = []
    backends = available_backends()
    if cfg.hardware.backend not in backends:
        issues.append(("hardware.backend", "one of " + ", ".join(backends),
                       cfg.hardware.backend, suggest(cfg.hardware.backend, backends)))
    return issues + backend_issues(cfg, caps) + _pointing_error_issues(cfg.hardware.sim.pointing_error)


def _pointing_error_issues(terms: dict[str, float] | None) -> list[Issue]:
    """[hardware.sim] pointing_error: urc.pointing.model's terms (checked whichever backend
    is chosen, as every section given is; imported only when there are terms)."""
    if terms is None:
        return []
    from ..pointing.model import PointingModel

    try:
        PointingModel.from_dict(terms)
    except (TypeError, ValueError) as exc:
        return [("hardware.sim.pointing_error", f"pointing model terms ({exc})", terms, "")]
    return []


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


def load_backend(name: str) -> None:
    """Import what building backend ``name`` needs, now (:func:`urc.assembly.prepare_takeover`:
    a takeover then opens the hardware and imports nothing)."""
    _load_builtin()
    builder = _BACKENDS.get(name)
    if isinstance(builder, _Builtin):
        builder.load()


class _Builtin:
    """A built-in backend's builder whose module is imported at the first build (lazy:
    checking a configuration, in both processes of every ``urc run``, must not import
    every backend; the control process builds one, the I/O process may take one over)."""

    def __init__(self, load: Callable[[], Builder]):
        self.load = load

    def __call__(self, caps: RotatorCaps, clock: Clock, state_dir: Path, options: dict[str, Any]) -> Hardware:
        return self.load()(caps, clock, state_dir, options)


def _sim() -> Builder:
    from .sim import build_sim_hardware
    return build_sim_hardware


def _bridge() -> Builder:
    from .bridge import build_bridge_hardware
    return build_bridge_hardware


def _gpio() -> Builder:
    from .gpio import build_gpio_hardware
    return build_gpio_hardware


# (each backend's package is imported only when its section is there to check, or it is
# the backend chosen: what the checks themselves look at first)
def _bridge_issues(cfg: Any, caps: RotatorCaps) -> list[Issue]:
    if cfg.hardware.bridge is None and cfg.hardware.backend != "bridge":
        return []
    from .bridge.checks import bridge_issues
    return bridge_issues(cfg, caps)


def _gpio_issues(cfg: Any, caps: RotatorCaps) -> list[Issue]:
    if cfg.hardware.gpio is None and cfg.hardware.backend != "gpio":
        return []
    from .gpio.checks import gpio_issues
    return gpio_issues(cfg, caps)


def _load_builtin() -> None:
    # Registered here, not at import, so that importing urc.hardware registers nothing a
    # caller has not registered first (and imports no backend: see _Builtin).
    if "sim" not in _BACKENDS:
        register_backend("sim", _Builtin(_sim))
    if "bridge" not in _BACKENDS:
        register_backend("bridge", _Builtin(_bridge), _bridge_issues)
    if "gpio" not in _BACKENDS:
        register_backend("gpio", _Builtin(_gpio), _gpio_issues)


# [hardware] is checked whenever a configuration is validated (urc.registrations imports this)
register_check("hardware", hardware_issues)
