"""A line-per-sample TCP feed, for anything else (a GNU Radio flowgraph, a script
reading a power meter): urc connects and reads lines as they come.

Each line is ``VALUE [UNIT]`` or ``T_UNIX_S VALUE [UNIT]`` (spaces or a comma between),
UNIT one of dB, dBm, V, linear (default: the feed's ``unit``). Without a time the
sample is stamped when the line arrived. ``read()`` drains what has arrived (never
waits longer than ``timeout_s`` for the first connect, not at all after) and gives the
newest good line; a bad line is counted and its reason kept, never used.
"""

from __future__ import annotations

import socket
import time

from .sources import UNITS, Clock, Sample, SignalRefused, Unit, judge


def parse_feed_line(line: str, *, arrived_s: float, default_unit: Unit) -> tuple[float, float, Unit]:
    """(t_s, value, unit) of one line, or SignalRefused("bad")."""
    fields = line.replace(",", " ").split()
    unit: str = default_unit
    if fields and fields[-1] in UNITS:
        unit = fields.pop()
    try:
        nums = [float(f) for f in fields]
    except ValueError:
        nums = []
    if len(nums) not in (1, 2):
        raise SignalRefused("bad", f"feed: expected 'VALUE [UNIT]' or 'T_UNIX_S VALUE [UNIT]' "
                            f"(UNIT {'|'.join(UNITS)}), found {line.strip()[:60]!r}")
    t_s = nums[0] if len(nums) == 2 else arrived_s
    return t_s, nums[-1], unit  # type: ignore[return-value]


class LineFeed:
    """Client of a TCP feed at ``host:port``. ``max_age_s``: the newest sample older
    than this is stale (a feed that stopped)."""

    def __init__(self, host: str, port: int, *, unit: Unit = "dB", max_age_s: float = 2.0,
                 ceiling: float | None = None, timeout_s: float = 1.0, clock: Clock = time.time,
                 name: str = ""):
        self.host, self.port, self.unit = host, int(port), unit
        self.max_age_s, self.ceiling, self.timeout_s = max_age_s, ceiling, timeout_s
        self.clock = clock
        self.name = name or f"feed {host}:{port}"
        self._sock: socket.socket | None = None
        self._buf = b""
        self._last: tuple[float, float, Unit] | None = None
        self.last_error: SignalRefused | None = None
        self.bad_lines = 0

    def _connect(self) -> socket.socket:
        if self._sock is None:
            try:
                self._sock = socket.create_connection((self.host, self.port), timeout=self.timeout_s)
            except OSError as exc:
                raise SignalRefused("missing", f"{self.name}: cannot connect: {exc}") from None
            self._sock.setblocking(False)
            self._buf = b""
        return self._sock

    def feed(self, data: bytes, arrived_s: float) -> None:
        """Take bytes as they arrived (sans-I/O: tests and other transports call this)."""
        self._buf += data
        while b"\n" in self._buf:
            raw, self._buf = self._buf.split(b"\n", 1)
            text = raw.decode("ascii", "replace").strip()
            if not text:
                continue
            try:
                self._last = parse_feed_line(text, arrived_s=arrived_s, default_unit=self.unit)
            except SignalRefused as exc:
                self.bad_lines += 1
                self.last_error = exc
        if len(self._buf) > 4096:
            self.bad_lines += 1
            self.last_error = SignalRefused("bad", f"{self.name}: no line end in {len(self._buf)} bytes")
            self._buf = b""

    def _drain(self) -> None:
        sock = self._connect()
        while True:
            try:
                chunk = sock.recv(65536)
            except BlockingIOError:
                return
            except OSError as exc:
                self.close()
                raise SignalRefused("missing", f"{self.name}: connection lost: {exc}") from None
            if not chunk:
                self.close()
                return
            self.feed(chunk, self.clock())

    def read(self) -> Sample:
        self._drain()
        if self._last is None:
            why = f" (last refused: {self.last_error})" if self.last_error else ""
            raise SignalRefused("missing", f"{self.name}: no sample yet{why}")
        t_s, value, unit = self._last
        return judge(t_s, value, unit, now_s=self.clock(), max_age_s=self.max_age_s,
                     ceiling=self.ceiling, what=self.name)

    def close(self) -> None:
        if self._sock is not None:
            try:
                self._sock.close()
            finally:
                self._sock = None
