"""Bounds on what clients can make the I/O process hold or write: connections per
port, open files, and log lines.

1500 idle connections under systemd's usual limit of 1024 open files took every port
offline, and asyncio logged a traceback for each failed ``accept()`` (5 MB/s); a client
that sent 30,000 lines and closed made asyncio log a warning per reply it could not
send. Each port now admits a bounded number of clients, the process raises its soft file
limit to the hard one, and asyncio's own repeated messages are logged at a bounded rate.

64 idle rotctld connections then refused every new client for as long as they stayed
(a laptop asleep, a Wi-Fi drop: until a restart), and 256 idle HTTP ones kept the API
and the web STOP away (issue 36.1). A full port now makes room: a newcomer takes the
place of the connection that never completed a command, else of the longest idle one
(one log line per wave of such closings), and TCP keepalive finds peers that vanished.
"""

from __future__ import annotations

import asyncio
import logging
import resource
import socket
import time
from typing import Callable, Iterable, Protocol

from ..protocols.base import RateLimitedLog

log = logging.getLogger("urc.servers")

#: clients one protocol port serves at once (Hamlib's rotctld serves any number, one
#: thread each; a station has a handful: tracker, logger, SDR software, a dashboard)
MAX_CLIENTS_PER_PORT = 64
#: HTTP connections at once (the dashboard holds one WebSocket per open page): beyond
#: this a connection is closed as it arrives (``capped_http_protocol``), and a request
#: while this many are open is answered 503 (uvicorn's ``limit_concurrency``)
MAX_HTTP_CONNECTIONS = 256
#: an HTTP connection that has sent nothing for this long is closed (a browser sends its
#: request at once; nginx's client_header_timeout is 60 s): idle connections cannot
#: hold the places of the clients that would use them
FIRST_REQUEST_S = 10.0
#: one line per kind of repeated message per this many seconds
LOG_INTERVAL_S = 10.0
#: closings for newcomers within this long of the first are one wave: one log line
WAVE_S = 1.0
#: TCP keepalive: a peer silent this long is probed every KEEPALIVE_INTERVAL_S, and given
#: up after KEEPALIVE_PROBES unanswered probes (a vanished client's place is free in
#: ~2 min, not Linux's default 2 h 11 min)
KEEPALIVE_IDLE_S = 60
KEEPALIVE_INTERVAL_S = 10
KEEPALIVE_PROBES = 6

_refusals = RateLimitedLog(log, interval_s=LOG_INTERVAL_S)


def enable_keepalive(sock: socket.socket | None) -> None:
    """TCP keepalive on an accepted connection (the timings where the OS has them)."""
    if sock is None:
        return
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
        for name, value in (("TCP_KEEPIDLE", KEEPALIVE_IDLE_S), ("TCP_KEEPINTVL", KEEPALIVE_INTERVAL_S),
                            ("TCP_KEEPCNT", KEEPALIVE_PROBES)):
            option = getattr(socket, name, None)
            if option is not None:
                sock.setsockopt(socket.IPPROTO_TCP, option, value)
    except OSError:  # (a socket already reset by its peer: it goes away by itself)
        pass


class Member(Protocol):
    """A connection as a cap sees it."""

    @property
    def used(self) -> bool: ...        # it completed a command (a request, a reply)
    @property
    def idle_since_s(self) -> float: ...  # monotonic time of its last input
    @property
    def evictable(self) -> bool: ...   # nothing of it under way (no command waiting)

    def evict(self) -> None: ...


def pick_idle(members: Iterable[Member]) -> Member | None:
    """The connection a newcomer replaces: one that never completed a command (the
    longest idle of those), else the longest idle; None if every one is busy."""
    return min((m for m in members if m.evictable), key=lambda m: (m.used, m.idle_since_s), default=None)


class Waves:
    """One log line per wave of closings: the first starts a wave, the line comes
    WAVE_S later with how many there were."""

    def __init__(self, where: str, limit: int):
        self.where = where
        self.limit = limit
        self.evicted = 0
        self._in_wave = 0

    def closed_one(self) -> None:
        self.evicted += 1
        self._in_wave += 1
        if self._in_wave > 1:
            return
        try:
            asyncio.get_running_loop().call_later(WAVE_S, self._report)
        except RuntimeError:  # (no loop: said at once)
            self._report()

    def _report(self) -> None:
        log.warning("%s: %d clients already; closed %d idle connection(s) to let new clients in "
                    "(those that never completed a command first, then the longest idle)",
                    self.where, self.limit, self._in_wave)
        self._in_wave = 0


class ClientCap:
    """How many clients one port serves at once. A newcomer when all places are taken
    takes the place of an idle connection (``pick_idle``), which is closed; it is
    refused only if every connection has a command under way."""

    def __init__(self, where: str, limit: int = MAX_CLIENTS_PER_PORT):
        self.where = where
        self.limit = limit
        self.members: dict[Member, None] = {}  # (an ordered set)
        self.refused = 0
        self.waves = Waves(where, limit)

    @property
    def clients(self) -> int:
        return len(self.members)

    def admit(self, member: Member) -> bool:
        if len(self.members) >= self.limit:
            victim = pick_idle(self.members)
            if victim is None:
                self.refused += 1
                _refusals.warning("%s: %d clients already, each with a command under way; further "
                                  "connections are closed at once", self.where, self.limit)
                return False
            del self.members[victim]  # (its place is free now, not when its close is done)
            victim.evict()
            self.waves.closed_one()
        self.members[member] = None
        return True

    def release(self, member: Member) -> None:
        self.members.pop(member, None)


def raise_open_file_limit() -> tuple[int, int]:
    """The soft limit on open files up to the hard one (systemd: LimitNOFILE); returns
    (soft, hard) as they are now."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard == resource.RLIM_INFINITY or soft < hard:
        target = hard if hard != resource.RLIM_INFINITY else max(soft, 65536)
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
            soft = target
        except (ValueError, OSError):
            pass
    return soft, hard


class RepeatFilter(logging.Filter):
    """Lets each message (by its format string) through once per ``interval_s``; the
    next one after that says how many were left out. For loggers urc does not write
    itself (asyncio's: "socket.send() raised exception.", accept errors)."""

    def __init__(self, interval_s: float = LOG_INTERVAL_S, clock: Callable[[], float] = time.monotonic):
        super().__init__()
        self.interval_s = interval_s
        self._clock = clock
        self._seen: dict[tuple[str, object], list[float]] = {}  # -> [last passed s, left out]

    def filter(self, record: logging.LogRecord) -> bool:
        key = (record.name, record.msg)
        now = self._clock()
        seen = self._seen.get(key)
        if seen is not None and now - seen[0] < self.interval_s:
            seen[1] += 1
            return False
        if seen is not None and seen[1]:
            record.msg = f"{record.msg} [and {int(seen[1])} more like it since the last such line]"
        if len(self._seen) > 1000:  # (bounded memory whatever the messages)
            self._seen.clear()
        self._seen[key] = [now, 0]
        return True


def bound_library_logs(names: tuple[str, ...] = ("asyncio", "uvicorn.error")) -> RepeatFilter:
    """Install one RepeatFilter on the loggers of libraries whose messages clients can
    provoke; returns it."""
    flt = RepeatFilter()
    for name in names:
        logger = logging.getLogger(name)
        if not any(isinstance(f, RepeatFilter) for f in logger.filters):
            logger.addFilter(flt)
    return flt


def capped_http_protocol(base: type, limit: int = MAX_HTTP_CONNECTIONS,
                         first_request_s: float = FIRST_REQUEST_S) -> type:
    """uvicorn's HTTP protocol class ``base`` (for uvicorn.Config(http=...)) holding at
    most ``limit`` connections: a newcomer beyond it takes the place of an idle one
    (``pick_idle``: one that never sent a request first, then the longest idle; never a
    WebSocket or a request under way), and is closed at once only if there is none. A
    connection that sends nothing for ``first_request_s`` is closed. uvicorn's
    ``limit_concurrency`` only answers 503 to a request: connections that never sent one
    were all accepted and held for good, and 1500 of them under a file limit of 1024
    took every descriptor of the I/O process (the API answered 2 requests in 12 under
    that flood, rotctld ~1 s late)."""
    waves = Waves("HTTP", limit)

    class Capped(base):  # type: ignore[misc, valid-type]
        _refused = False
        _silence: asyncio.TimerHandle | None = None
        idle_since_s = 0.0

        @property
        def used(self) -> bool:
            return self.cycle is not None  # (uvicorn's current request; None before the first)

        @property
        def evictable(self) -> bool:
            return self.cycle is None or bool(self.cycle.response_complete and not getattr(self, "pipeline", ()))

        def evict(self) -> None:
            self.connections.discard(self)  # (its place is free now, not when its close is done)
            self.transport.close()

        def connection_made(self, transport) -> None:  # type: ignore[no-untyped-def]
            if len(self.connections) >= limit:  # (uvicorn's set of open connections)
                victim = pick_idle(c for c in self.connections if isinstance(c, Capped))
                if victim is None:
                    self._refused = True
                    _refusals.warning("%s: %d clients already, none idle; further connections are closed "
                                      "at once", "HTTP", limit)
                    transport.abort()
                    return
                victim.evict()
                waves.closed_one()
            self.idle_since_s = time.monotonic()
            enable_keepalive(transport.get_extra_info("socket"))
            super().connection_made(transport)
            self._silence = asyncio.get_running_loop().call_later(first_request_s, self._silent, transport)

        def _silent(self, transport) -> None:  # type: ignore[no-untyped-def]
            self._silence = None
            _refusals.warning("HTTP: connections that sent nothing for %g s are closed", first_request_s)
            transport.close()

        def data_received(self, data: bytes) -> None:
            if self._refused:
                return
            self.idle_since_s = time.monotonic()
            if self._silence is not None:
                self._silence.cancel()
                self._silence = None
            super().data_received(data)

        def connection_lost(self, exc: Exception | None) -> None:
            if self._refused:
                return
            if self._silence is not None:
                self._silence.cancel()
                self._silence = None
            super().connection_lost(exc)

        def eof_received(self):  # type: ignore[no-untyped-def]
            return None if self._refused else super().eof_received()

    Capped.__name__ = Capped.__qualname__ = f"Capped{base.__name__}"
    return Capped
