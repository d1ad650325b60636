"""Protocol names, as used in configuration, mapped to their session classes.

Loaded lazily by dotted path so a protocol's module is only imported when served.
Every session class is constructed as ``cls(rotator: RotatorPort, **options)``.
A [[serve]] entry's protocol is checked against these names, and its options against
the session class, by urc.config: registered with it when this module is imported.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ..config.issues import Issue, suggest
from ..config.owners import register_check, register_session_class
from ..errors import ConfigError

if TYPE_CHECKING:  # (.base imports the Status and the request effects (urc.model): not
    # for checking a configuration, which registers this module's names at every start)
    from .base import RotatorPort, Session

PROTOCOLS: dict[str, str] = {
    "rotctld": "urc.protocols.rotctld:RotctldSession",
    "easycomm1": "urc.protocols.easycomm:Easycomm1Session",
    "easycomm2": "urc.protocols.easycomm:Easycomm2Session",
    "easycomm3": "urc.protocols.easycomm:Easycomm3Session",
    "gs232a": "urc.protocols.gs232:Gs232aSession",
    "gs232b": "urc.protocols.gs232:Gs232bSession",
    "gs232": "urc.protocols.gs232:Gs232GenericSession",
    "foxdelta": "urc.protocols.gs232:FoxDeltaSession",
    "rot2prog": "urc.protocols.spid:Rot2ProgSession",
    "rot1prog": "urc.protocols.spid:Rot1ProgSession",
    "md01": "urc.protocols.spid:Md01Session",
    "urc": "urc.protocols.tartu:TartuSession",
    "sarcnet": "urc.protocols.sarcnet:SarcnetSession",
    "g4jnt": "urc.protocols.g4jnt:G4jntSession",
    "pstrotator": "urc.protocols.pstrotator:PstRotatorSession",
}


def session_class(name: str) -> type:
    try:
        target = PROTOCOLS[name]
    except KeyError:
        raise ConfigError(f"unknown protocol {name!r}; expected one of {', '.join(PROTOCOLS)}",
                          key="serve.protocol", expected=" | ".join(PROTOCOLS), found=name) from None
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def make_session(name: str, rotator: RotatorPort, **options: Any) -> Session:
    """A session on ``rotator`` (a single-axis one as its protocol puts it on the wire)."""
    from .single_axis import session_port

    return session_class(name)(session_port(rotator), **options)


def serve_issues(cfg: Any, _caps: Any) -> list[Issue]:
    """urc.config's check of each [[serve]] entry's protocol: one of :data:`PROTOCOLS`."""
    return [(f"serve[{i}].protocol", "one of " + ", ".join(PROTOCOLS), entry.protocol,
             suggest(entry.protocol, list(PROTOCOLS)))
            for i, entry in enumerate(cfg.serve or ()) if entry.protocol not in PROTOCOLS]


# (urc.registrations imports this module before any configuration is read)
register_check("protocols", serve_issues)
register_session_class(session_class)
