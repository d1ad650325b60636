"""Protocols tracking programs speak, as sans-I/O sessions (see base.py)."""

from .base import MAX_PENDING_BYTES, RotatorPort, Session
from .registry import PROTOCOLS, make_session, session_class

__all__ = ["MAX_PENDING_BYTES", "PROTOCOLS", "RotatorPort", "Session", "make_session", "session_class"]
