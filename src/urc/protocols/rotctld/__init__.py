"""Hamlib's NET rotctl protocol, as ``rotctld`` speaks it (protocols.md section 1).

:class:`RotctldSession` is one client connection (sans-I/O); :mod:`.lexer` turns the
byte stream into commands, :mod:`.codec` reads argument words and formats replies,
:mod:`.commands` holds the command table and Hamlib's codes.
"""

from .session import HAMLIB_VERSIONS, RotctldSession

__all__ = ["HAMLIB_VERSIONS", "RotctldSession"]
