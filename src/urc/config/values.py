"""Values written as text in the configuration and read the same way everywhere."""

from __future__ import annotations


def parse_host_port(text: str) -> tuple[str, int]:
    """``"127.0.0.1:4533"`` or ``"[::1]:4533"`` -> (host, port); ValueError if not."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ValueError(text)
    return host.strip("[]"), int(port)
