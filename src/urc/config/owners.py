"""What the packages above urc.config register with it: the checks of the keys whose
meaning they own, and the lookup of a served protocol's session class.

urc.config imports nothing above it (issue 34): the hardware backends, the front panel,
MQTT and the protocols each know what their keys mean, so each registers its check
here when its module is imported (:func:`register_check`), as a hardware backend
registers its builder with :func:`urc.hardware.factory.register_backend`. The section
models themselves are plain data and stay in this package (:mod:`.hardware_sections`,
:mod:`.panel_sections`, :mod:`.mqtt_section`), so that :class:`~urc.config.Config` keeps
its typed fields.

Who imports the owners: :mod:`urc.registrations`, one module above them all, which every
entry point imports before it reads a configuration (urc.cli, urc.assembly, the test
suite's conftest). A configuration checked before that would pass without its owners'
checks, silently; instead :func:`owner_issues` refuses to run while any of
:data:`OWNERS` has not registered (a RuntimeError that names the fix), so a new entry
point that forgets the import fails on its first configuration, loud, in its tests.
"""

from __future__ import annotations

from typing import Any, Callable

from ..caps import RotatorCaps
from .issues import Issue

#: check(cfg, caps) -> what is wrong in the keys its owner gives a meaning to (caps:
#: the profile's, as [rotator] changes them)
Check = Callable[[Any, RotatorCaps], list[Issue]]

#: the owners whose checks every configuration needs, in the order their issues are
#: listed: the hardware backends (hardware.backend and each backend's own section),
#: the front panel ([panel]), MQTT ([mqtt]) and the protocols ([[serve]] protocol)
OWNERS: tuple[str, ...] = ("hardware", "panel", "mqtt", "protocols")

_CHECKS: dict[str, Check] = {}
_SESSION_CLASS: list[Callable[[str], type]] = []
_CROSS_CHECK: list[Callable[[Any], list[Issue]]] = []


def register_cross_check(check: Callable[[Any], list[Issue]]) -> None:
    """urc.config's own cross-checks (:func:`.checks.cross_check`, which runs the owners'
    too), registered by :mod:`.checks` when the package is imported: the schema's
    validator calls it through here, so that the schema and the checks, which name
    the Config type, do not import each other."""
    _CROSS_CHECK[:] = [check]


def cross_check(cfg: Any) -> list[Issue]:
    """Every issue of ``cfg`` (what the schema's validator runs)."""
    if not _CROSS_CHECK:  # (urc/config/__init__.py imports .checks: never, short of a bug)
        raise RuntimeError("urc.config.checks has not registered its cross-checks")
    return _CROSS_CHECK[0](cfg)


def register_check(owner: str, check: Check) -> None:
    """``check`` runs whenever a configuration is validated (one per owner: registering
    again replaces it)."""
    _CHECKS[owner] = check


def register_session_class(lookup: Callable[[str], type]) -> None:
    """``lookup(protocol)`` -> the session class a [[serve]] entry's options are checked
    against (:mod:`.serve_options`); ConfigError for an unknown protocol."""
    _SESSION_CLASS[:] = [lookup]


def owner_issues(cfg: Any, caps: RotatorCaps) -> list[Issue]:
    """Every registered owner's issues, in :data:`OWNERS` order (then any other owner's)."""
    _require(*OWNERS)
    order = list(OWNERS) + sorted(set(_CHECKS) - set(OWNERS))
    return [issue for owner in order for issue in _CHECKS[owner](cfg, caps)]


def session_class(protocol: str) -> type:
    _require("protocols")
    if not _SESSION_CLASS:
        raise RuntimeError(_unregistered(["protocols (its session classes)"]))
    return _SESSION_CLASS[0](protocol)


def _require(*owners: str) -> None:
    missing = [o for o in owners if o not in _CHECKS]
    if missing:
        raise RuntimeError(_unregistered(missing))


def _unregistered(missing: list[str]) -> str:
    return (f"a configuration was checked before {', '.join(missing)} registered with urc.config: "
            "import urc.registrations first (urc.cli, urc.assembly and tests/conftest.py do)")
