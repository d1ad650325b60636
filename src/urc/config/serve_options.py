"""Each [[serve]] entry's ``options`` checked against its protocol's session before
anything starts.

The options are the session class's keyword arguments (``hamlib_version`` for rotctld,
``variant`` for tartu). They were checked only when the servers started, after the
control process (some 20 s into a start on a loaded Pi): ``options = { reply_port = 12002 }``
on PstRotator refused the start that late. Here each session is built once on a stand-in
rotator, which catches an option the protocol does not have and a value its constructor
refuses; a constructor that asks the rotator something is checked by its signature only.
The session classes come from urc.protocols.registry, registered with :mod:`.owners`.
"""

from __future__ import annotations

import inspect
from typing import Any, Iterable

from ..errors import ConfigError, UrcError
from .owners import session_class

#: keys of the [[serve]] entry itself, written into its options by mistake
ENTRY_KEYS = ("baud", "reply_port")


class _Asked(Exception):
    """The session's constructor asked the stand-in rotator something."""


class _StandIn:
    """A rotator that answers nothing: building a session on it only checks its options."""

    def __getattr__(self, name: str) -> Any:
        raise _Asked(name)


def check_serve_options(entries: Iterable[Any]) -> None:
    """ConfigError naming the first entry whose options its protocol refuses."""
    for i, entry in enumerate(entries):
        cls = session_class(entry.protocol)
        options = dict(entry.options)
        try:
            inspect.signature(cls).bind(_StandIn(), **options)
            try:
                cls(_StandIn(), **options)
            except _Asked:
                pass  # (it needs a real rotator: the signature was checked)
        except (TypeError, ValueError, UrcError) as exc:
            raise ConfigError(_said(i, entry, cls, options, exc), key=f"serve[{i}].options", found=options) from None


def _said(i: int, entry: Any, cls: type, options: dict, exc: Exception) -> str:
    takes = [p.name for p in list(inspect.signature(cls).parameters.values())[1:]
             if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)]
    text = (f"serve[{i}] ({entry.describe()}): bad options {options}: {exc}; "
            f"{entry.protocol} takes {', '.join(takes) if takes else 'no options'}")
    misplaced = [k for k in options if k in ENTRY_KEYS]
    if misplaced:
        text += f" ({', '.join(misplaced)} is a key of the [[serve]] entry itself, not of its options)"
    return text
