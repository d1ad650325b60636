"""Start every configured [[serve]] entry; all share the one rotator."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from ..config import ServeEntry, parse_host_port
from ..errors import ConfigError
from ..protocols.base import RotatorPort
from ..protocols.registry import session_class
from ..protocols.single_axis import session_port


#: serial rate of a protocol whose session class names none (``default_baud``)
DEFAULT_BAUD = 9600


@dataclass
class Endpoint:
    entry: ServeEntry
    description: str
    close: Callable[[], Any]


async def start_endpoints(entries: tuple[ServeEntry, ...], rotator: RotatorPort) -> list[Endpoint]:
    """Open every endpoint or none: a failure closes those already open and raises."""
    started: list[Endpoint] = []
    try:
        for entry in entries:
            started.append(await _start(entry, rotator))
    except BaseException:
        for ep in started:
            ep.close()
        raise
    return started


async def _start(entry: ServeEntry, rotator: RotatorPort) -> Endpoint:
    cls = session_class(entry.protocol)
    options = dict(entry.options)
    rotator = session_port(rotator)  # a single-axis rotator as its protocol puts it on the wire

    def factory():
        return cls(rotator, **options)
    try:
        factory()  # options are checked now, not at the first client
    except TypeError as exc:
        raise ConfigError(f"serve {entry.protocol}: bad options {options}: {exc}",
                          key="serve.options", found=options) from None
    kind, where = entry.transport
    try:
        if kind == "tcp":
            from .tcp import serve_tcp
            host, port = parse_host_port(where)
            server = await serve_tcp(factory, host, port, entry.protocol)
            bound = server.sockets[0].getsockname()[1]
            return Endpoint(entry, f"{entry.protocol} on tcp {host}:{bound}", server.close)
        if kind == "udp":
            from .udp import serve_udp
            host, port = parse_host_port(where)
            transport = await serve_udp(factory, host, port, entry.reply_port, entry.protocol)
            return Endpoint(entry, f"{entry.protocol} on udp {where} (replies to port {entry.reply_port})",
                            transport.close)
        if kind == "pty":
            from .pty import PtyEndpoint
            ep = PtyEndpoint(factory, where, entry.protocol)
            ep.start()
            return Endpoint(entry, f"{entry.protocol} on pty {where} -> {ep.device}", ep.close)
        from .serial import SerialEndpoint
        default_baud: int = getattr(cls, "default_baud", DEFAULT_BAUD)
        baud = entry.baud or default_baud
        sp = SerialEndpoint(factory, where, baud, entry.protocol)
        sp.start()
        return Endpoint(entry, f"{entry.protocol} on serial {where} at {baud} baud", sp.close)
    except OSError as exc:
        raise OSError(f"cannot serve {entry.describe()}: {exc}") from exc
