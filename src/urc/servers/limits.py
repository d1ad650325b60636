"""Bounds on what clients can make the I/O process hold or write: connections per
port, open files, and log lines.

1500 idle connections under systemd's usual limit of 1024 open files took every port
offline, and asyncio logged a traceback for each failed ``accept()`` (5 MB/s); a client
that sent 30,000 lines and closed made asyncio log a warning per reply it could not
send. Each port now admits a bounded number of clients (the excess is closed at once,
with one log line per interval), the process raises its soft file limit to the hard one,
and asyncio's own repeated messages are logged at a bounded rate.
"""

from __future__ import annotations

import asyncio
import logging
import resource
import time
from typing import Callable

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

_refusals = RateLimitedLog(log, interval_s=LOG_INTERVAL_S)


class ClientCap:
    """How many clients one port serves at once; the rest are refused as they arrive."""

    def __init__(self, where: str, limit: int = MAX_CLIENTS_PER_PORT):
        self.where = where
        self.limit = limit
        self.clients = 0
        self.refused = 0

    def admit(self) -> bool:
        if self.clients >= self.limit:
            self.refused += 1
            _refusals.warning("%s: %d clients already; further connections are closed at once",
                              self.where, self.limit)
            return False
        self.clients += 1
        return True

    def release(self) -> None:
        self.clients -= 1


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
    """uvicorn's HTTP protocol class ``base`` closing every connection beyond ``limit``
    as it arrives, and one that sends nothing for ``first_request_s`` (for
    uvicorn.Config(http=...)). uvicorn's ``limit_concurrency`` only answers 503 to a
    request: connections that never sent one were all accepted and held for good, and
    1500 of them under a file limit of 1024 took every descriptor of the I/O process
    (the API answered 2 requests in 12 under that flood, rotctld ~1 s late)."""

    class Capped(base):  # type: ignore[misc, valid-type]
        _refused = False
        _silence: asyncio.TimerHandle | None = None

        def connection_made(self, transport) -> None:  # type: ignore[no-untyped-def]
            if len(self.connections) >= limit:  # (uvicorn's set of open connections)
                self._refused = True
                _refusals.warning("%s: %d clients already; further connections are closed at once",
                                  "HTTP", limit)
                transport.abort()
                return
            super().connection_made(transport)
            self._silence = asyncio.get_running_loop().call_later(first_request_s, self._silent, transport)

        def _silent(self, transport) -> None:  # type: ignore[no-untyped-def]
            self._silence = None
            _refusals.warning("HTTP: connections that sent nothing for %g s are closed", first_request_s)
            transport.close()

        def data_received(self, data: bytes) -> None:
            if self._refused:
                return
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
