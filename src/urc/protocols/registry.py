"""Protocol names, as used in configuration, mapped to their session classes.

Loaded lazily by dotted path so a protocol's module is only imported when served.
Every session class is constructed as ``cls(rotator: RotatorPort, **options)``.
"""

from __future__ import annotations

import importlib
from typing import Any

from ..errors import ConfigError
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
