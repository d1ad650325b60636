"""Hamlib's NET rotctl protocol, as ``rotctld`` speaks it (protocols.md section 1).

:class:`RotctldSession` is one client connection (sans-I/O); :mod:`.lexer` turns the
byte stream into commands, :mod:`.flags` reads the status flags off a snapshot. The wire
format itself (the command table, Hamlib's codes, argument words and reply text) is
:mod:`urc.wire.rotctld`, which the bridge's NET rotctl client shares.
"""

from .session import HAMLIB_VERSIONS, RotctldSession

__all__ = ["HAMLIB_VERSIONS", "RotctldSession"]
