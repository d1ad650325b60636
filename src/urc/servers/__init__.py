"""Thin asyncio adapters that serve sans-I/O protocol sessions over TCP, pseudo-terminals,
serial ports and UDP (see urc.protocols.base)."""

from .manager import Endpoint, start_endpoints

__all__ = ["Endpoint", "start_endpoints"]
